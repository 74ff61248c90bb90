#!/usr/bin/env bash
# Every test of the workspace, in two builds that each command after them reuses:
#   1. every crate but the Bevy plugin: `cargo test --profile test-opt` (the workspace's default
#      members; a few minutes cold on 2 cores), then a map's vis across a local HyperQueue cluster
#      (tools/distributed/ci_hq.sh; HyperQueue is installed in target/hq-venv);
#   2. the Bevy plugin with its viewer: `cargo test -p sightline-bevy --features viewer --profile
#      test-opt` (Bevy itself: about 18 minutes cold on 2 cores, once), then the headless walk and
#      the viewer's stills under a virtual display (tools/viewer-shots.sh).
# Usage: tools/test.sh [--no-bevy]
set -euo pipefail
cd "$(dirname "$0")/.."
export SIGHTLINE_MAPS="${SIGHTLINE_MAPS:-$(pwd)/../shared/maps}"
step_start=$SECONDS
# Print how long the step before took, then the next step's title.
step() {
    [ "$step_start" = "$SECONDS" ] || echo "   (took $((SECONDS - step_start)) s)"
    step_start=$SECONDS
    echo "== $1"
}

step "every crate but the Bevy plugin (cargo test --profile test-opt)"
cargo test --profile test-opt

step "vis across machines: a local HyperQueue cluster (tools/distributed/ci_hq.sh)"
# HyperQueue's Python package (server, workers and client in one wheel) in a virtual environment
# of its own under target/, so the machine's Python is left alone.
venv="${CARGO_TARGET_DIR:-target}/hq-venv"
if ! "$venv/bin/python3" -c 'import hyperqueue' 2>/dev/null; then
    python3 -m venv "$venv"
    "$venv/bin/python3" -m pip install --quiet hyperqueue
fi
PATH="$(realpath "$venv/bin"):$PATH" SIGHTLINE="$(realpath "${CARGO_TARGET_DIR:-target}")/test-opt/sightline" \
    tools/distributed/ci_hq.sh
if [ "${1:-}" = "--no-bevy" ]; then
    step "done (Bevy plugin not tested)"
    exit 0
fi

step "the Bevy plugin (cargo test -p sightline-bevy --features viewer --profile test-opt)"
cargo test -p sightline-bevy --features viewer --profile test-opt

step "the Bevy plugin: headless walk (its example, built by the step above)"
walk="${CARGO_TARGET_DIR:-target}/test-opt/examples/walk"
e1m1="$SIGHTLINE_MAPS/ericw/e1m1.vis.bsp"
if [ ! -f "$e1m1" ]; then
    echo "error: $e1m1 missing; the headless walk cannot run" >&2
    exit 1
fi
walk_json=$("$walk" "$e1m1" --headless --frames 300 --json)
echo "$walk_json"
python3 -c 'import json, sys
r = json.loads(sys.argv[1])
missing = [k for k in ("frames", "drawn_avg", "hidden_avg", "system_us_avg") if k not in r]
if missing:
    sys.exit("walk JSON lacks " + ", ".join(missing))
if r["hidden_avg"] <= 0:
    sys.exit("the walk hid nothing on E1M1")' "$walk_json"

step "the Bevy viewer: stills under a virtual display (tools/viewer-shots.sh)"
tools/viewer-shots.sh
step "done"
