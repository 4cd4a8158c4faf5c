#!/usr/bin/env bash
# Installs clang 14 with its sanitizer and libFuzzer runtimes and LLVM's OpenMP, where missing:
# the compiler of the sanitizer build (scripts/test.sh --sanitize) and of fuzzing (scripts/fuzz.sh).
set -euo pipefail
need=()
for p in clang-14 libclang-rt-14-dev libomp-14-dev; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || need+=("$p")
done
if [ ${#need[@]} -gt 0 ]; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${need[@]}"
fi
