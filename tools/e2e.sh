#!/usr/bin/env bash
# End to end on one map: compile (with vis), validate the PVS by ray sampling, print stats.
# Usage: tools/e2e.sh [map.map|mesh.obj]   (default maps/two_rooms.map)
set -euo pipefail
cd "$(dirname "$0")/.."
map="${1:-maps/two_rooms.map}"
name="$(basename "${map%.*}")"
mkdir -p out
cargo build --release --quiet -p sightline
bin="${CARGO_TARGET_DIR:-target}/release/sightline"
echo "== compile $map"
"$bin" compile "$map" -o "out/$name.slvl"
echo "== validate out/$name.slvl"
"$bin" validate "out/$name.slvl"
echo "== info out/$name.slvl"
"$bin" info "out/$name.slvl"
