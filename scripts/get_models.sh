#!/usr/bin/env bash
# Extracts the closed surface models of Debian's libcgal-demo package (data.tar.gz) into models/:
# bunny00.off, homer.off, armadillo.off, elephant.off (the stand-ins for the seed's models).
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p models
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get download libcgal-demo > /dev/null)
dpkg-deb -x "$work"/libcgal-demo_*.deb "$work/x"
tar xzf "$work/x/usr/share/doc/libcgal-dev/data.tar.gz" -C "$work" \
  data/meshes/bunny00.off data/meshes/homer.off data/meshes/armadillo.off data/meshes/elephant.off
mv "$work"/data/meshes/*.off models/
ls models
