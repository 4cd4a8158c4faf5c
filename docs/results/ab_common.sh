# Sourced by docs/results/step_update.sh and setup_forces.sh (not run on its own): their arguments
# OLD_PMG [ROUNDS] as $old and $rounds, a temporary $work with the twisted Homer scene of
# docs/results/kernels.sh in it (removed on exit), $static the static Homer P3 MGPCG command to
# 1e-6, and pmg_of WHO, the binary of the round's build (old: OLD_PMG, new: build/tools/pmg).
set -euo pipefail
cd "$(dirname "$0")/../.."
old=$1 rounds=${2:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 docs/results/twisted_homer_scene.py "$work"
static="compare --mesh models/homer.ele -p 3 --fix z --fix-fraction 0.05 --load gravity --threads 2 --no-reference --tol 1e-6 --solvers mgpcg"
source docs/results/ab_rounds.sh
