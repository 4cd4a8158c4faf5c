#!/usr/bin/env bash
# Fuzzes every reader of untrusted input with libFuzzer (clang, ASan + UBSan): Matrix Market,
# Gmsh, TetGen, OFF, STL and scene JSON. Each target starts from its corpus in tests/fuzz/corpus/
# (seeds and every input that once crashed a reader) and runs SECONDS (default 30), one target per
# core at a time; the corpus it grows stays in build-asan/corpus/, crashes go to
# build-asan/crashes/<target>/ and fail the run. The targets are built in the sanitizer build
# (scripts/sanitize_build.sh: clang, ASan + UBSan, libFuzzer coverage on the readers' sources).
#   scripts/fuzz.sh [SECONDS] [TARGET...]     e.g. scripts/fuzz.sh 600 gmsh scene
#   (clang 14 and its runtimes are installed where missing: apt, Debian 12)
#   PMG_FUZZ_SEED=1 scripts/fuzz.sh 30        a fixed seed (CI: the same inputs every run); 0: random
# A crash found here is fixed, then its input is copied into tests/fuzz/corpus/<target>/ as
# crash-<what>: the normal test suite replays that folder (ctest -L fuzz).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-30}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(matrix_market petsc_binary gmsh tetgen off stl scene)
build=build-asan
scripts/sanitize_build.sh $(printf 'fuzz_%s ' "${targets[@]}")
# Leaks are LeakSanitizer's business in the sanitizer suite; a reader refusing input by exception
# must not be reported as a crash because of OpenMP's or MPI's start-up allocations.
export ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=0 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
# One target per core at a time (each libFuzzer process is single-threaded): the same time per
# target, the whole run in 1/nproc of the wall time.
fuzz_one() {
  local t=$1 work="$build/corpus/$1" crashes="$build/crashes/$1" log="$build/fuzz_$1.log"
  mkdir -p "$work" "$crashes"
  # -rss_limit_mb/-malloc_limit_mb: a reader allocating for a count its input does not back is a
  # finding; -timeout: a reader looping on its input is one too.
  if "$build/tests/fuzz/fuzz_$t" "$work" "tests/fuzz/corpus/$t" -max_total_time="$seconds" \
      -rss_limit_mb=2048 -malloc_limit_mb=1024 -timeout=10 -max_len=65536 -print_final_stats=1 \
      -seed="${PMG_FUZZ_SEED:-0}" -artifact_prefix="$crashes/" > "$log" 2>&1; then
    echo ok > "$build/fuzz_$t.result"
  else
    echo "FAILED (see $log; inputs in $crashes/)" > "$build/fuzz_$t.result"
  fi
}
jobs_max=$(nproc)
for t in "${targets[@]}"; do
  rm -f "$build/fuzz_$t.result"
  while [ "$(jobs -rp | wc -l)" -ge "$jobs_max" ]; do wait -n || true; done
  echo "== fuzz_$t: $seconds s =="
  fuzz_one "$t" &
done
wait
status=0
summary=()
for t in "${targets[@]}"; do
  log="$build/fuzz_$t.log"
  result=$(cat "$build/fuzz_$t.result" 2>/dev/null || echo "FAILED (no result; see $log)")
  if [ "$result" != ok ]; then
    status=1
    tail -40 "$log" || true
  fi
  runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo "?")
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | grep -o '[0-9]*' || echo "?")
  summary+=("$(printf '%-14s %10s executions  %6s edges  %s' "$t" "$runs" "$cov" "$result")")
done
echo "== fuzz summary ($seconds s per target) =="
printf '%s\n' "${summary[@]}"
exit $status
