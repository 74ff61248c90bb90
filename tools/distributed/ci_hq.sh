#!/usr/bin/env bash
# CI: a real HyperQueue cluster on this machine (a local server and 2 workers, started and stopped
# by hq_vis.py) runs the vis of a shared map in 8 shards and merges them; the map must be the
# same bytes as the one-process run of the plan (`sightline vis --waves 1`). Then again with one
# shard task killed midway (SIGKILL to its process): the driver finds it missing
# (`sightline vis status`), resubmits it, and the merge is the same bytes again.
#
#   pip install hyperqueue && cargo build --profile test-opt -p sightline && tools/distributed/ci_hq.sh
#
# Env: SIGHTLINE (the binary, default target/test-opt/sightline), SIGHTLINE_MAPS (the shared maps,
# default ../shared/maps), HQ_CI_MAP (default ericw/e1m1: shards long enough to be killed midway).
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
SIGHTLINE=${SIGHTLINE:-$ROOT/target/test-opt/sightline}
MAPS=${SIGHTLINE_MAPS:-$ROOT/../shared/maps}
MAP=${HQ_CI_MAP:-ericw/e1m1}
DRIVER=$ROOT/tools/distributed/hq_vis.py
fail() { echo "ci_hq: FAIL: $*" >&2; exit 1; }
python3 -c 'import hyperqueue' 2>/dev/null || { echo "ci_hq: the hyperqueue Python package is missing (pip install hyperqueue)" >&2; exit 2; }
[ -x "$SIGHTLINE" ] || { echo "ci_hq: $SIGHTLINE missing (cargo build --profile test-opt -p sightline)" >&2; exit 2; }
[ -f "$MAPS/$MAP.bsp" ] && [ -f "$MAPS/$MAP.prt" ] || { echo "ci_hq: $MAPS/$MAP.bsp or .prt missing" >&2; exit 2; }
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT
copy() { cp "$MAPS/$MAP.bsp" "$WORK/$1.bsp"; cp "$MAPS/$MAP.prt" "$WORK/$1.prt"; chmod u+w "$WORK/$1".*; }

copy one
"$SIGHTLINE" vis --waves 1 --no-progress "$WORK/one.bsp" >/dev/null

echo "ci_hq: $MAP in 8 shards on a local HyperQueue cluster of 2 workers" >&2
copy whole
python3 "$DRIVER" "$WORK/whole.bsp" --shards 8 --local-workers 2 --sightline "$SIGHTLINE" \
    >/dev/null 2>"$WORK/whole.log" || { cat "$WORK/whole.log" >&2; fail "the driver failed"; }
grep "done in" "$WORK/whole.log" >&2
cmp "$WORK/one.bsp" "$WORK/whole.bsp" || fail "the merge of 8 shards differs from the one-process run"

echo "ci_hq: again, one shard task killed midway" >&2
copy killed
python3 "$DRIVER" "$WORK/killed.bsp" --shards 8 --local-workers 2 --sightline "$SIGHTLINE" \
    >/dev/null 2>"$WORK/driver.log" &
driver=$!
victim=""
# The first shard process of this map found running is killed 0.05 s later, by its process id.
# The scan reads each command line with a builtin (no process per entry): a scan that forked
# once per process took longer than a shard of E1M1 runs on an idle host, and found none.
while [ -z "$victim" ] && kill -0 "$driver" 2>/dev/null; do
    for p in /proc/[0-9]*; do
        { mapfile -d '' args <"$p/cmdline"; } 2>/dev/null || continue
        case " ${args[*]} " in
            *" vis shard "*"$WORK/killed.bsp"*)
                sleep 0.05
                if kill -9 "${p#/proc/}" 2>/dev/null; then victim=${p#/proc/}; fi
                break
                ;;
        esac
    done
    sleep 0.01
done
wait "$driver" || { cat "$WORK/driver.log" >&2; fail "the driver failed"; }
[ -n "$victim" ] || fail "no shard task ran long enough to be killed (try a heavier HQ_CI_MAP)"
grep -q "missing or stale after round 1" "$WORK/driver.log" || { cat "$WORK/driver.log" >&2; fail "the killed shard was not resubmitted"; }
cmp "$WORK/one.bsp" "$WORK/killed.bsp" || fail "the merge after a retry differs from the one-process run"
echo "ci_hq: ok (killed shard process $victim; resubmitted; both merges byte-identical)" >&2
