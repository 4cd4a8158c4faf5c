#!/usr/bin/env bash
# The distributed-mesh route (pmg compare --distributed-mesh) against pmgkit's serial MGPCG and the
# replicated petsc-mgpcg route, on the quadratic unit cube clamped at z = 0 under gravity, to 1e-6
# from zero: 14^3 boxes of 24 tetrahedra refined once (2,178,120 unknowns; the serial runs refine the
# same coarse mesh themselves, the distributed one on the ranks after distribution). Peak resident
# memory of every process by /usr/bin/time (%M, kB). Two alternating batches; np 4 on this 2-core
# VM is oversubscribed: its memory counts, its time measures overhead. Each run starts after a
# 10 s pause.
#   docs/results/distributed_mesh.sh > docs/results/distributed_mesh_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
C=(compare --box 14 14 14 --refine 1 --size 1 1 1 -p 2 --fix z --load gravity --tol 1e-6)
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none)
run() {  # run TITLE COMMAND... (after a 10 s pause: see distributed_np1.sh)
  sleep 10
  echo "=== $1"
  shift
  "$@" 2>&1 | grep -v "^\s*$"
}
date; uname -n; lscpu | grep "Model name"; nproc
for batch in 1 2; do
  echo "##### batch $batch"
  run "serial mgpcg, 2 threads" env OMP_NUM_THREADS=2 /usr/bin/time -f "peak %M kB" $pmg "${C[@]}" --solvers mgpcg --no-reference
  run "distributed mesh, np 1 x 2 threads" "${mpi[@]}" -np 1 -x OMP_NUM_THREADS=2 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --distributed-mesh
  run "serial mgpcg, 1 thread" env OMP_NUM_THREADS=1 /usr/bin/time -f "peak %M kB" $pmg "${C[@]}" --solvers mgpcg --no-reference
  run "distributed mesh, np 1 x 1 thread" "${mpi[@]}" -np 1 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --distributed-mesh
  run "distributed mesh, np 2 x 1 thread" "${mpi[@]}" -np 2 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --distributed-mesh
  run "distributed mesh, np 4 x 1 thread (oversubscribed)" "${mpi[@]}" -np 4 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --distributed-mesh
done
echo "##### the replicated route (every rank builds the whole scene), once"
run "replicated petsc-mgpcg, np 1 x 1 thread" "${mpi[@]}" -np 1 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --solvers petsc-mgpcg --no-reference
run "replicated petsc-mgpcg, np 4 x 1 thread (oversubscribed)" "${mpi[@]}" -np 4 -x OMP_NUM_THREADS=1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}" --solvers petsc-mgpcg --no-reference
date
