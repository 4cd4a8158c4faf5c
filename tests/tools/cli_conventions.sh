#!/usr/bin/env bash
# cli_conventions.sh PMG DATA: the command line's conventions across every subcommand.
#  - Every option CLI11 refuses while parsing (a missing file, a value out of range, an unknown
#    flag, a missing argument) is bad input: exit 2 and exactly one line, "pmg: error: ...".
#  - --help exits 0 for pmg and each subcommand, and shows no value after a flag's name
#    ("--no-reference{false}" reads as a default).
#  - Under an MPI launcher the progress is plain lines, never the '\r' bar, even where standard
#    output is a (pseudo-)terminal, as mpirun gives its ranks.
set -u
pmg=$1 data=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "cli_conventions.sh: $*"; exit 1; }

# refused WORDS -- command...: exit 2, one line, the error line holding WORDS.
refused() {
  local words=$1
  shift 2
  "$@" > "$work/out.txt" 2>&1
  local rc=$?
  cat "$work/out.txt"
  [ $rc -eq 2 ] || fail "exit code $rc, expected 2: $*"
  [ "$(wc -l < "$work/out.txt")" -eq 1 ] || fail "expected one line of output: $*"
  grep -q '^pmg: error: ' "$work/out.txt" || fail "no 'pmg: error:' line: $*"
  grep -qF -- "$words" "$work/out.txt" || fail "the error does not say '$words': $*"
}
refused "File does not exist: $work/nonexistent.json" -- "$pmg" simulate "$work/nonexistent.json"
refused "File does not exist" -- "$pmg" compare --matrix "$work/no_such.mtx"
refused "--tol: 'nan' is not a finite number" -- "$pmg" compare --grid 4 --tol nan
refused "--threads: Value 0 not in range 1 to 1024" -- "$pmg" coarse --threads 0
refused "The following argument was not expected: --bogus" -- "$pmg" mesh "$data/octahedron.ele" --bogus
refused "input is required" -- "$pmg" mesh
refused "--output is required" -- "$pmg" render "$work"
refused "--field: von-mises not in" -- "$pmg" render "$work" -o "$work/r" --field von-mises
refused "--size: '800' is not WIDTHxHEIGHT" -- "$pmg" render "$work" -o "$work/r" --size 800
refused "subcommand is required" -- "$pmg"

for cmd in "" compare simulate mesh coarse solvers render; do
  # shellcheck disable=SC2086  # $cmd empty: pmg's own help
  "$pmg" $cmd --help > "$work/help.txt" 2>&1
  rc=$?
  [ $rc -eq 0 ] || fail "pmg $cmd --help: exit code $rc"
  if grep -F -e '{false}' -e '{true}' "$work/help.txt"; then fail "pmg $cmd --help shows a flag's value"; fi
done
"$pmg" compare --help | grep -q -- '--no-reference  ' || fail "pmg compare --help lacks --no-reference"

# The progress under a pseudo-terminal (script(1)): the bar without a launcher, plain lines with one.
if command -v script > /dev/null; then
  OMP_NUM_THREADS=1 script -qec "'$pmg' simulate --duration 0.05" /dev/null > "$work/tty.txt" 2>&1 || fail "simulate on a terminal failed"
  grep -aq '\] step 5/5' "$work/tty.txt" || fail "no progress bar on a terminal"
  OMPI_COMM_WORLD_SIZE=1 OMP_NUM_THREADS=1 script -qec "'$pmg' simulate --duration 0.05" /dev/null > "$work/mpi.txt" 2>&1 ||
    fail "simulate under a launcher's environment failed"
  if grep -aq '\] step' "$work/mpi.txt"; then fail "the progress bar was drawn under an MPI launcher"; fi
  grep -aq '^step 5/5' "$work/mpi.txt" || fail "no plain progress line under an MPI launcher"
else
  echo "cli_conventions.sh: script(1) not found, the terminal checks skipped"
fi
echo "cli_conventions.sh: ok"
