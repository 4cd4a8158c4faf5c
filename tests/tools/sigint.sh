#!/bin/sh
# sigint.sh PMG: starts a long pmg simulate -o, interrupts it once its first step is written, and
# checks the exit code (130), the one-line report and that steps.csv and every frame are complete.
pmg=$1
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT
"$pmg" simulate --duration 100 -o "$d/out" -q > "$d/log" 2>&1 &
pid=$!
i=0
# Wait until the run has finished a step (steps.csv holds the header and rows 0 and 1).
until [ -f "$d/out/steps.csv" ] && [ "$(wc -l < "$d/out/steps.csv")" -ge 2 ]; do
  i=$((i + 1))
  if [ $i -gt 1200 ]; then echo "sigint.sh: no step after 120 s"; kill $pid; exit 1; fi
  sleep 0.1
done
kill -INT $pid
wait $pid
rc=$?
cat "$d/log"
[ $rc -eq 130 ] || { echo "sigint.sh: exit code $rc, expected 130"; exit 1; }
grep -Eq "^interrupted after step [0-9]+ of 10000 \(t = [0-9.]+ s\): steps.csv and [0-9]+ frames in .* are complete" "$d/log" ||
  { echo "sigint.sh: no 'interrupted after step' line"; exit 1; }
steps=$(sed -n 's/^interrupted after step \([0-9]*\) .*/\1/p' "$d/log")
rows=$(($(wc -l < "$d/out/steps.csv") - 2))  # header and step 0
[ "$rows" -eq "$steps" ] || { echo "sigint.sh: steps.csv has $rows steps, the report says $steps"; exit 1; }
for f in "$d"/out/frame_*.vtu; do
  tail -c 20 "$f" | grep -q "</VTKFile>" || { echo "sigint.sh: $f is incomplete"; exit 1; }
done
ls "$d"/out | grep -q tmp && { echo "sigint.sh: a temporary file was left"; exit 1; }
echo "sigint.sh: stopped at step $steps, $(ls "$d"/out/frame_*.vtu | wc -l) complete frames"
exit 0
