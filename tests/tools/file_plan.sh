#!/usr/bin/env bash
# file_plan.sh PMG SCENE DATA: no output of a run may be one of its inputs or another output (the
# same file through a link or another path): each case is refused before any work with exit 2,
# naming both, and the input is unchanged.
set -u
pmg=$1 scene=$2 data=$3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work" || exit 1
fail() { echo "file_plan.sh: $*"; exit 1; }
cp "$scene" s.json
cp "$data/spd12.mtx" A1.mtx 2>/dev/null || printf '%%%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 2\n2 2 2\n3 3 2\n' > A1.mtx
ln -s s.json link.json
mkdir od
before=$(cat s.json A1.mtx | md5sum)

# expect WORDS -- command...: exit 2, one error line holding WORDS.
expect() {
  local words=$1
  shift 2
  "$@" > out.txt 2>&1
  local rc=$?
  cat out.txt
  [ $rc -eq 2 ] || fail "exit code $rc, expected 2: $*"
  [ "$(grep -c 'pmg: error' out.txt)" = 1 ] || fail "expected one error line: $*"
  grep -qF -- "$words" out.txt || fail "the error does not say '$words': $*"
}
expect "--json 's.json' is the scene file, an input" -- "$pmg" simulate s.json -q --json s.json
expect "--json 'link.json' is the scene file 's.json', an input" -- "$pmg" simulate s.json -q --json link.json
expect "--json './s.json' is the scene file 's.json', an input" -- "$pmg" simulate s.json -q --json ./s.json
expect "--json 'od/steps.csv' is a file the output folder 'od' writes (steps.csv)" -- "$pmg" simulate s.json -q -o od --json od/steps.csv
expect "--history 'A1.mtx' is --matrix, an input" -- "$pmg" compare --matrix A1.mtx --format csr --solvers cg --history A1.mtx
expect "--solution-out 'A1.mtx' is --matrix, an input" -- "$pmg" compare --matrix A1.mtx --format csr --solvers cg --solution-out A1.mtx
expect "--json 'h.csv' is also the output --history 'h.csv'" -- "$pmg" compare --matrix A1.mtx --format csr --solvers cg --history h.csv --json h.csv
[ "$(cat s.json A1.mtx | md5sum)" = "$before" ] || fail "an input changed"
[ ! -e h.csv ] && [ -z "$(ls od)" ] || fail "a refused run wrote something"
echo "file_plan.sh: ok"
