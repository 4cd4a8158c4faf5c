#!/usr/bin/env bash
# Bigger than a rank's memory: the quadratic unit cube of 14^3 boxes refined twice on the ranks
# after distribution (4.2M tetrahedra, 17.1M unknowns), solved to 1e-6 on 4 ranks, each limited to
# 6 GiB of address space (ulimit -v); then the replicated route (every rank builds the whole
# scene) under the same limit. 4 ranks on this 2-core VM are oversubscribed: the times measure
# overhead, not speed-up; the memory counts.
#   docs/results/distributed_mesh_large.sh > docs/results/distributed_mesh_large_$(date +%F).txt 2>&1
set -u
cd "$(dirname "$0")/../.."
pmg=build/tools/pmg
C="compare --box 14 14 14 --refine 2 --size 1 1 1 -p 2 --fix z --load gravity --tol 1e-6"
mpi=(mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1)
date; uname -n; lscpu | grep "Model name"; nproc; free -g | head -2
echo "=== distributed mesh, np 4 x 1 thread, ulimit -v 6 GiB per rank"
"${mpi[@]}" -np 4 bash -c "ulimit -v 6291456; exec /usr/bin/time -f 'rank peak %M kB, %e s' $pmg $C --distributed-mesh --json /tmp/distributed_mesh_large.json" 2>&1 | grep -v "^\s*$"
echo "exit code ${PIPESTATUS[0]}"
echo "=== replicated petsc-mgpcg, np 4 x 1 thread, ulimit -v 6 GiB per rank"
timeout 1200 "${mpi[@]}" -np 4 bash -c "ulimit -v 6291456; exec /usr/bin/time -f 'rank peak %M kB, %e s' $pmg $C --solvers petsc-mgpcg --no-reference" 2>&1 | grep -v "^\s*$" | grep -v "^---\|MPI_ABORT\|NOTE: invoking\|You may or may not\|exactly when\|with errorcode"
echo "exit code ${PIPESTATUS[0]}"
date
