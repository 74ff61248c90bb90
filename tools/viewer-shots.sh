#!/usr/bin/env bash
# The Bevy viewer, windowed on a virtual display with software Vulkan: it opens the level at its
# info_player_start and takes four stills (start with culling on and off, a view of sky, a view
# of a liquid) as PNG, then this checks what they show: sky pixels in the sky still, liquid
# pixels in the liquid still, fewer meshes drawn with culling than without, and the same picture
# either way (culling may only drop what the eye cannot see).
# Needs the walk example (`cargo test -p sightline-bevy --features viewer --profile test-opt`
# builds it), `xvfb-run` and a Vulkan driver (Debian/Ubuntu: `apt-get install xvfb
# mesa-vulkan-drivers`).
# Usage: tools/viewer-shots.sh [LEVEL] [OUT_DIR]   (default: id's E1M1, out/viewer)
set -euo pipefail
cd "$(dirname "$0")/.."
maps="${SIGHTLINE_MAPS:-../shared/maps}"
level="${1:-$maps/id_bsp_orig/e1m1.bsp}"
out="${2:-out/viewer}"
walk="${CARGO_TARGET_DIR:-target}/test-opt/examples/walk"
for need in "$walk" "$level"; do
    [ -e "$need" ] || { echo "error: $need missing" >&2; exit 1; }
done
command -v xvfb-run >/dev/null || {
    echo "error: xvfb-run missing (Debian/Ubuntu: apt-get install xvfb mesa-vulkan-drivers)" >&2
    exit 1
}
mkdir -p "$out"
json=$(xvfb-run -a -s "-screen 0 1024x768x24" "$walk" "$level" --shots "$out")
echo "$json"
python3 - "$json" "$out" <<'PY'
import json, sys
report, out = json.loads(sys.argv[1]), sys.argv[2]
shots = {s["name"]: s for s in report["shots"]}
errors = []
for name in ("start", "start-nocull", "sky", "liquid"):
    if name not in shots:
        errors.append(f"no {name} still (not in level: {report['not_in_level']})")
if not errors:
    area = 640 * 480
    if shots["sky"]["sky_pixels"] < area // 50:
        errors.append(f"sky still: {shots['sky']['sky_pixels']} sky pixels")
    if shots["liquid"]["liquid_pixels"] < area // 50:
        errors.append(f"liquid still: {shots['liquid']['liquid_pixels']} liquid pixels")
    on, off = shots["start"], shots["start-nocull"]
    if not (on["hidden"] > 0 and off["hidden"] == 0 and off["drawn"] > on["drawn"]):
        errors.append(f"culling toggle: on drew {on['drawn']} hid {on['hidden']}, off drew {off['drawn']} hid {off['hidden']}")
    errors += [f"{n}: never settled" for n, s in shots.items() if not s["settled"]]
if errors:
    sys.exit("viewer stills: " + "; ".join(errors))
if open(f"{out}/start.png", "rb").read() != open(f"{out}/start-nocull.png", "rb").read():
    sys.exit("viewer stills: the start differs with culling on and off: culling hid something visible")
print(f"viewer stills ok: {out}/{{start,start-nocull,sky,liquid}}.png")
PY
