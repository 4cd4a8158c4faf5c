#!/usr/bin/env bash
# gpu_solvers.sh PMG: the GPU solvers in `pmg compare`, beside a CPU solver, on a cubic scene:
# each converges to the tolerance by the true residual. Exits 77 (skipped) without a CUDA device.
set -u
pmg=$1
out=$("$pmg" compare --box 3 1 1 -p 3 --solvers gpu-pmg,gpu-mcg,gpu-pcg,gpu-mgpcg,mgpcg -t 1e-8 2>&1)
rc=$?
printf '%s\n' "$out"
if printf '%s\n' "$out" | grep -q "no CUDA device or driver"; then
  echo "gpu_solvers.sh: no CUDA device: skipped"
  exit 77
fi
if [ "$rc" -ne 0 ]; then echo "gpu_solvers.sh: exit code $rc"; exit 1; fi
for s in gpu-pmg gpu-mcg gpu-pcg gpu-mgpcg mgpcg; do
  printf '%s\n' "$out" | grep -Eq "^$s +converged" || { echo "gpu_solvers.sh: $s did not converge"; exit 1; }
done
exit 0
