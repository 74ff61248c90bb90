#!/usr/bin/env bash
# End to end on one map: compile (with vis), validate the PVS by ray sampling, print stats.
# Usage: tools/e2e.sh [map.map|mesh.obj]   (default maps/two_rooms.map)
# Uses the `sightline` on the PATH when there is one (`cargo install-sightline`), else the one
# `cargo build-sightline` left, else builds it (a release build: a few minutes on 2 cores, shown).
set -euo pipefail
cd "$(dirname "$0")/.."
map="${1:-maps/two_rooms.map}"
name="$(basename "${map%.*}")"
mkdir -p out
target="${CARGO_TARGET_DIR:-target}"
host=$(rustc -vV 2>/dev/null | sed -n 's/^host: //p')
if command -v sightline >/dev/null; then
    bin=$(command -v sightline)
elif [ -n "$host" ] && [ -x "$target/$host/release/sightline" ]; then
    bin="$target/$host/release/sightline"
else
    echo "== building sightline (cargo build --release --locked -p sightline; first time: a few minutes)"
    cargo build --release --locked -p sightline
    bin="$target/release/sightline"
fi
echo "== using $bin"
echo "== compile $map"
"$bin" compile "$map" -o "out/$name.slvl"
echo "== validate out/$name.slvl"
"$bin" validate "out/$name.slvl"
echo "== info out/$name.slvl"
"$bin" info "out/$name.slvl"
