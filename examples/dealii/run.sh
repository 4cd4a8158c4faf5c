#!/usr/bin/env bash
# Builds the deal.II quick start against a pmgkit build tree and runs it: exit 77 (skipped) where
# deal.II 9.4 is not installed. Arguments: BUILD_DIR SOURCE_DIR (examples/dealii).
set -euo pipefail
build=$(cd "$1" && pwd) src=$2
found=${DEAL_II_DIR:-}
for f in /usr/share/cmake/deal.II/deal.IIConfig.cmake /usr/lib/*/cmake/deal.II/deal.IIConfig.cmake \
         /usr/local/lib/cmake/deal.II/deal.IIConfig.cmake; do
  [ -f "$f" ] && found=$f
done
if [ -z "$found" ]; then
  echo "skipped: deal.II is not installed (apt-get install libdeal.ii-dev)"
  exit 77
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake -S "$src" -B "$work" -DCMAKE_PREFIX_PATH="$build" -DCMAKE_BUILD_TYPE=Release > "$work/configure.log" ||
  { cat "$work/configure.log"; exit 1; }
cmake --build "$work" > "$work/build.log" 2>&1 || { tail -50 "$work/build.log"; exit 1; }
"$work/quickstart"
