#!/bin/bash
# docs/distributed.md: Homer P3 and Bunny P2 with petsc-mgpcg on 1-4 ranks (oversubscribed, 1 thread each), to 1e-10: iterations and error against CHOLMOD
cd /work/main
for sys in "homer|--mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity" "bunny|--mesh models/bunny_17k.ele -p 2 --fix y --fix-fraction 0.05 --load gravity"; do
  name=${sys%%|*}; args=${sys#*|}
  for np in 1 2 3 4; do
    echo "== $name np=$np: mpirun --oversubscribe -x OMP_NUM_THREADS=1 -np $np build/tools/pmg compare $args --tol 1e-10 --solvers mgpcg,petsc-mgpcg"
    mpirun --allow-run-as-root --oversubscribe --bind-to none -x OMP_NUM_THREADS=1 -np $np build/tools/pmg compare $args --tol 1e-10 --solvers mgpcg,petsc-mgpcg 2>&1 | grep -E "^(mgpcg|petsc-mgpcg) |^size|ghost/owned" | sed 's/.*ghost\/owned/  ghost\/owned/'
  done
done
