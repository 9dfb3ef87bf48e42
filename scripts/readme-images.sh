#!/usr/bin/env bash
# Regenerates the pictures of README.md (docs/img/) from the reference scene.
set -euo pipefail
cd "$(dirname "$0")/.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
cargo run --release -q -p cosim-server -- run --quiet --duration 2 --plot --out "$out/run"
cargo run --release -q -p cosim-server -- plot "$out/run" --stills 4 > /dev/null
mkdir -p docs/img
cp "$out/run/plots/velocities.png" docs/img/velocities.png
for k in 0 1 2 3; do cp "$out/run/frame_$k.png" "docs/img/frame_$k.png"; done
echo "docs/img/ updated"
