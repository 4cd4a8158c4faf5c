#!/bin/sh
# mesh_sigint.sh PMG SURFACE: starts pmg mesh on a fine target, interrupts it while TetGen runs the
# way Ctrl-C in a terminal does (SIGINT to pmg and to TetGen), and checks the exit code (130), the
# message, that no pmg_mesh_<pid> folder is left in the temporary directory and that nothing was written.
pmg=$1
surface=$2
d=$(mktemp -d)
trap 'rm -rf "$d"' EXIT
TMPDIR=$d "$pmg" mesh "$surface" -n 3000000 -o "$d/out" > "$d/log" 2>&1 &
pid=$!
# TetGen's command line names the scratch folder pmg_mesh_<pid> inside $d.
tetgen_pids() {
  for p in /proc/[0-9]*; do
    tr '\0' ' ' < "$p/cmdline" 2>/dev/null | grep -q "^[^ ]*tetgen .*$d/pmg_mesh_" && echo "${p#/proc/}"
  done
}
i=0
until [ -n "$(tetgen_pids)" ]; do
  i=$((i + 1))
  if [ $i -gt 600 ]; then echo "mesh_sigint.sh: TetGen did not start within 60 s"; cat "$d/log"; kill $pid; exit 1; fi
  sleep 0.1
done
sleep 0.3
kill -INT $pid               # the terminal sends SIGINT to the whole foreground group:
kill -INT $(tetgen_pids) 2>/dev/null  # pmg (which ignores it while TetGen runs, as system() did) and TetGen
wait $pid
rc=$?
cat "$d/log"
[ $rc -eq 130 ] || { echo "mesh_sigint.sh: exit code $rc, expected 130"; exit 1; }
grep -q "^pmg: interrupted" "$d/log" || { echo "mesh_sigint.sh: no 'pmg: interrupted' line"; exit 1; }
if ls -d "$d"/pmg_mesh_* > /dev/null 2>&1; then echo "mesh_sigint.sh: the temporary folder was left"; exit 1; fi
if [ -e "$d/out.node" ]; then echo "mesh_sigint.sh: an output was written"; exit 1; fi
echo "mesh_sigint.sh: exit 130, temporary folder removed, nothing written"
exit 0
