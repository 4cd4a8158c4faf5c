#!/usr/bin/env bash
# The mixed displacement-pressure formulation in time (pmg simulate, fem::MixedEuler), linear and
# corotational, against the displacement-only elements with their fastest solvers on the same scene:
#   1. per-step robustness: iterations per step to 1e-8 at nu = 0.3 and 0.4999, the corotational
#      quadratic bar of scenes/rubber_mixed.json (10 steps) and the cubic Homer from rest under
#      gravity (3 steps);
#   2. whole runs at nu = 0.4999 to the scenes' 1e-3 per step (and mixed-gmres also at 1e-5, the
#      mixed scenes' default): scenes/rubber_mixed.json (100 steps),
#      the free spinning bar of scenes/spinning.json (400 steps) and the cubic Homer twisted 30 degrees
#      and released (scenes/homer_twisted.json, 5 steps): mixed-gmres and mixed-minres against pmg
#      (the scenes' method; vertex patches from nu = 0.495 on) and mgpcg with point and patch smoothers.
# One run each; the time is the time loop's wall time ("steps: N in T s wall").
# Usage: docs/results/mixed_dynamics.sh > docs/results/mixed_dynamics_$(date +%F).txt   (after
# scripts/build.sh, and scripts/get_models.sh with the Homer mesh made as the README says)
set -euo pipefail
pmg=$(realpath "${PMG:-build/tools/pmg}")
here=$(pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "# $(date -u +%F) $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2), $(nproc) cores, 2 threads"

# scene FILE KEY=JSON... : FILE with the given top-level keys replaced (material's merged).
scene() {
  local src=$1
  shift
  /usr/bin/python3 - "$src" "$here" "$@" > "$work/s.json" <<'EOF'
import json, os, sys
src, here, changes = sys.argv[1], sys.argv[2], sys.argv[3:]
s = json.load(open(src))
if "file" in s.get("mesh", {}):
    s["mesh"]["file"] = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(src)), s["mesh"]["file"]))
s.pop("output", None)
for c in changes:
    k, v = c.split("=", 1)
    v = json.loads(v)
    if k == "material":
        s[k].update(v)
    else:
        s[k] = v
json.dump(s, sys.stdout)
EOF
  echo "$work/s.json"
}

run() {  # LABEL SCENE [ARGS...]: the steps and energy lines of one run
  local label=$1 file=$2
  shift 2
  echo "## $label"
  "$pmg" simulate "$file" --threads 2 "$@" | grep -E "^(solver|steps|energy|warning):" || echo "(failed)"
  sleep 2
}

echo "# 1. Iterations per step to 1e-8"
for nu in 0.3 0.4999; do
  for m in mixed-gmres mixed-minres; do
    run "rubber bar (corotational, deflected), nu = $nu, $m tol 1e-8, 10 steps" \
      "$(scene scenes/rubber_mixed.json material="{\"poisson\": $nu}" solver="{\"method\": \"$m\", \"tol\": 1e-8}")" --duration 0.1
  done
  run "rubber bar (corotational, deflected), nu = $nu, displacement-only mgpcg tol 1e-8, 10 steps" \
    "$(scene scenes/rubber_mixed.json formulation='"displacement"' material="{\"poisson\": $nu}" solver='{"method": "mgpcg", "tol": 1e-8}')" --duration 0.1
  for m in mixed-gmres mixed-minres mgpcg; do
    [ $m = mgpcg ] && f=displacement || f=mixed
    run "Homer P3 from rest under gravity, nu = $nu, $f ($m) tol 1e-8, 3 steps" \
      "$(scene scenes/homer_twisted.json formulation="\"$f\"" material="{\"model\": \"linear\", \"poisson\": $nu}" \
         initial='{"state": "rest"}' loads='{"gravity": [0, 0, -9.81]}' time='{"dt": 0.01, "duration": 0.03}' \
         solver="{\"method\": \"$m\", \"tol\": 1e-8}")"
  done
done

echo "# 2. Whole runs at nu = 0.4999, 1e-3 per step"
bar_solvers=('{"method": "mixed-gmres", "tol": 1e-5}' '{"method": "mixed-gmres", "tol": 1e-3}' '{"method": "mixed-minres", "tol": 1e-3}' '{"method": "pmg", "tol": 1e-3}'
             '{"method": "mgpcg", "tol": 1e-3}' '{"method": "mgpcg", "tol": 1e-3, "smoother.preconditioner.method": "patch"}')
for src in scenes/rubber_mixed.json scenes/spinning.json; do
  for s in "${bar_solvers[@]}"; do
    [[ $s == *mixed-* ]] && f=mixed || f=displacement
    if [ "$src" = scenes/spinning.json ]; then  # the scene's tolerance, for every method
      [[ $s == *'"tol": 1e-3'* ]] || continue
      s=${s/1e-3/1e-6}
    fi
    run "$(basename "$src"), nu = 0.4999, $f, solver $s" \
      "$(scene "$src" formulation="\"$f\"" material='{"poisson": 0.4999}' solver="$s")"
  done
done
homer_solvers=('{"method": "mixed-gmres", "tol": 1e-5}' '{"method": "mixed-gmres", "tol": 1e-3}' '{"method": "mixed-minres", "tol": 1e-3}' '{"method": "pmg", "tol": 1e-3, "operator": "assembled"}'
               '{"method": "mgpcg", "tol": 1e-3}' '{"method": "mgpcg", "tol": 1e-3, "smoother.preconditioner.method": "patch"}')
for s in "${homer_solvers[@]}"; do
  [[ $s == *mixed-* ]] && f=mixed || f=displacement
  run "homer_twisted.json, nu = 0.4999, $f, solver $s, 5 steps" \
    "$(scene scenes/homer_twisted.json formulation="\"$f\"" material='{"poisson": 0.4999}' solver="$s")" --duration 0.05
done
