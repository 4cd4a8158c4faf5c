#!/usr/bin/env bash
# vendor_libraries.sh PMG: a run that calls no GPU baseline maps neither cuBLAS nor cuSPARSE (nor
# cuBLASLt, nvJitLink): pmg::gpu opens them on first use (gpu/src/vendor_libraries.hpp). The tool
# is held at start-up by a scene file that is a FIFO nobody writes, its maps read, then stopped.
set -u
pmg=$1
work=$(mktemp -d)
trap 'kill $pid 2>/dev/null; rm -rf "$work"' EXIT
mkfifo "$work/scene.json"
"$pmg" simulate "$work/scene.json" > /dev/null 2>&1 &
pid=$!
for _ in $(seq 300); do  # until it waits in open() for the FIFO's writer: its libraries are all up
  [ "$(cat /proc/$pid/wchan 2>/dev/null)" = wait_for_partner ] && break
  sleep 0.1
done
[ "$(cat /proc/$pid/wchan 2>/dev/null)" = wait_for_partner ] || { echo "vendor_libraries.sh: the tool never reached the scene file"; exit 1; }
[ -r /proc/$pid/maps ] || { echo "vendor_libraries.sh: the tool exited early"; exit 1; }
if grep -E "libcublas|libcusparse|libnvJitLink" /proc/$pid/maps; then
  echo "vendor_libraries.sh: a CPU run maps the CUDA vendor libraries"
  exit 1
fi
echo "vendor_libraries.sh: ok (the resident memory at start-up: $(grep VmRSS /proc/$pid/status | tr -s ' '))"
