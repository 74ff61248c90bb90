#!/usr/bin/env python3
"""Measure what sharding a vis costs: for each portal file given, the default one-process vis, the
one-process runs of plans of W waves, and the shards of plans of W waves of N shards, each
process on one thread, CPU seconds (user + system) from the kernel's accounting of the children.

Prints a Markdown table (docs/distributed.md). Usage:
    tools/distributed/measure.py [--sightline PATH] [--shards 1,2,4,8,16,32] [--waves 1,2,4,8]
                                 [--shard-waves 1,4] MAP.prt...
The portal files are copied into a temporary folder (vis writes NAME.vis beside them).
"""
import argparse, json, os, resource, shutil, subprocess, sys, tempfile


def cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(args):
    before = cpu()
    out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
    return cpu() - before, out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sightline", default="target/test-opt/sightline")
    ap.add_argument("--shards", default="1,2,4,8,16,32")
    ap.add_argument("--waves", default="1,2,4,8", help="one-process runs of W waves")
    ap.add_argument("--shard-waves", default="1,4", help="plans of W waves run as shards")
    ap.add_argument("maps", nargs="+")
    a = ap.parse_args()
    s = a.sightline
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for m in a.maps:
            name = os.path.splitext(os.path.basename(m))[0]
            prt = os.path.join(tmp, name + ".prt")
            shutil.copy(m, prt)
            base = [s, "vis", prt, "--threads", "1", "--json", "--no-progress"]
            t, out = run(base)
            v = json.loads(out)["vis"]
            default = (t, v["visible_pairs"], v["chains"])
            print(f"{name}: default {t:.2f} s CPU, {v['visible_pairs']} pairs, {v['chains']} chains", file=sys.stderr)
            waves = {}
            for w in map(int, a.waves.split(",")):
                t, out = run(base + ["--waves", str(w)])
                v = json.loads(out)["vis"]
                waves[w] = (t, v["visible_pairs"], v["chains"])
                print(f"{name}: --waves {w}: {t:.2f} s, {v['visible_pairs']} pairs, {v['chains']} chains", file=sys.stderr)
            for w in map(int, a.shard_waves.split(",")):
                for n in map(int, a.shards.split(",")):
                    d = os.path.join(tmp, f"{name}.{w}.{n}")
                    total, critical = 0.0, 0.0
                    for wave in range(1, w + 1):
                        times = []
                        for k in range(1, n + 1):
                            t, _ = run([s, "vis", "shard", f"{k}/{n}", prt, "--dir", d, "--waves", str(w),
                                        "--wave", str(wave), "--threads", "1", "--no-progress"])
                            times.append(t)
                        total += sum(times)
                        critical += max(times)
                    tm, _ = run([s, "vis", "merge", "--shards", str(n), "--waves", str(w), prt, "--dir", d,
                                 "--no-progress", "--json"])
                    shutil.rmtree(d)
                    rows.append((name, w, n, total, critical, tm, default, waves))
                    print(f"{name}: {w} waves x {n} shards: total {total:.2f} s, critical {critical:.2f} s, "
                          f"merge {tm:.2f} s", file=sys.stderr)
    print("| map | waves | N | total CPU of the shards (s) | longest shard, summed over waves (s) | merge (s) | speed-up on N machines vs default one-process vis |")
    print("|---|---|---|---|---|---|---|")
    for name, w, n, total, critical, tm, default, waves in rows:
        print(f"| {name} | {w} | {n} | {total:.2f} | {critical:.2f} | {tm:.2f} | {default[0] / (critical + tm):.2f} |")
    print()
    print("| map | schedule | CPU s | visible pairs | chains |")
    print("|---|---|---|---|---|")
    seen = set()
    for name, _, _, _, _, _, default, waves in rows:
        if name in seen:
            continue
        seen.add(name)
        print(f"| {name} | default batches | {default[0]:.2f} | {default[1]} | {default[2]} |")
        for w, (t, p, c) in sorted(waves.items()):
            print(f"| {name} | {w} waves | {t:.2f} | {p} ({(p - default[1]) / default[1] * 100:+.2f} %) | {c} |")


if __name__ == "__main__":
    main()
