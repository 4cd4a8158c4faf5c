#!/usr/bin/env bash
# Installs a build of pmgkit into a prefix and leaves the build folder as it was:
#   scripts/install.sh PREFIX [BUILD_DIR]        (BUILD_DIR: build)
# `cmake --install` writes its list of installed files, install_manifest.txt, into the build
# folder (CMake has no option to put it elsewhere); this script moves it to
# PREFIX/share/pmgkit/install_manifest.txt (what an uninstall reads) and puts back a manifest the
# build folder had before, if any. Installing with `cmake --install BUILD_DIR --prefix PREFIX` works
# as well; it only leaves that file behind.
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  echo "usage: scripts/install.sh PREFIX [BUILD_DIR]" >&2
  exit 2
fi
prefix=$1 build=${2:-build}
if [ ! -f "$build/cmake_install.cmake" ]; then
  echo "install.sh: $build is not a configured build folder (run scripts/build.sh first)" >&2
  exit 2
fi
manifest="$build/install_manifest.txt"
saved=""
if [ -e "$manifest" ]; then
  saved=$(mktemp)
  cp -p "$manifest" "$saved"
fi
restore() {
  if [ -n "$saved" ]; then mv -f "$saved" "$manifest"; else rm -f "$manifest"; fi
}
trap restore EXIT
cmake --install "$build" --prefix "$prefix"
mkdir -p "$prefix/share/pmgkit"
cp "$manifest" "$prefix/share/pmgkit/install_manifest.txt"
