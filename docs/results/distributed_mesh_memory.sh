#!/usr/bin/env bash
# Peak resident memory per rank of the distributed-mesh route on the 2.28M-unknown quadratic cube
# (14^3 boxes of 24 tetrahedra refined once on the ranks, gravity, to 1e-6): np 1 against np 4
# (oversubscribed on the 2-core VM: memory counts, time measures overhead), 1 thread per rank, by
# /usr/bin/time (%M kB) for every process; two alternating batches. The issue's target: the np 4
# peak per rank at most 0.35x the np 1 peak.
#   docs/results/distributed_mesh_memory.sh > docs/results/distributed_mesh_memory_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
C=(compare --box 14 14 14 --refine 1 --size 1 1 1 -p 2 --fix z --load gravity --tol 1e-6 --distributed-mesh)
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
run() {  # run TITLE COMMAND...
  echo "=== $1"
  shift
  "$@" 2>&1 | grep -E "^(system|t\(|petsc-mgpcg:|peak resident|rank peak)"
}
date; uname -n; lscpu | grep "Model name"; nproc
for batch in 1 2; do
  echo "##### batch $batch"
  run "distributed mesh, np 1 x 1 thread" "${mpi[@]}" -np 1 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}"
  run "distributed mesh, np 4 x 1 thread (oversubscribed)" "${mpi[@]}" -np 4 /usr/bin/time -f "rank peak %M kB" $pmg "${C[@]}"
done
date
