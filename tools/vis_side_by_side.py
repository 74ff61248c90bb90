#!/usr/bin/env python3
"""Vis side by side with another vis program, on the same .bsp/.prt pairs, on this machine.

Runs the programs alternately, one run each in turn, every run on a fresh copy of the map, and
takes per run the child's CPU time (user + system, from wait4) and its wall time (around the
spawn and the wait). Prints a Markdown table of medians and the ratios reference / each other
program (above 1: the other is faster), CPU / wall.

    tools/vis_side_by_side.py --ref /path/to/ericw/vis \
        --prog now=target/release/sightline [--prog before=/tmp/old/sightline] \
        [--runs 50] [--threads N] MAP.bsp [MAP.bsp ...]

A program named `ref` is run as `vis [-threads N] MAP.bsp` (ericw-tools' command line); the
others as `sightline vis --no-progress [--threads N] MAP.bsp`. Without --threads each program
picks its own. The .prt beside each .bsp (same stem) is copied along. Only the standard library
is used.
"""

import argparse
import os
import shutil
import statistics
import sys
import tempfile
import time


def run_once(argv, cwd):
    """Spawn argv in cwd with output discarded; return (cpu_seconds, wall_seconds, status,
    peak_resident_kib)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        actions = [
            (os.POSIX_SPAWN_DUP2, devnull, 1),
            (os.POSIX_SPAWN_DUP2, devnull, 2),
        ]
        old = os.getcwd()
        os.chdir(cwd)
        try:
            start = time.perf_counter()
            pid = os.posix_spawn(argv[0], argv, os.environ, file_actions=actions)
            _, status, usage = os.wait4(pid, 0)
            wall = time.perf_counter() - start
        finally:
            os.chdir(old)
    finally:
        os.close(devnull)
    return usage.ru_utime + usage.ru_stime, wall, status, usage.ru_maxrss


def command(name, exe, threads, bsp):
    if name == "ref":
        return [exe] + (["-threads", str(threads)] if threads else []) + [bsp]
    return [exe, "vis", "--no-progress"] + (["--threads", str(threads)] if threads else []) + [bsp]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ref", required=True, help="the reference vis (ericw-tools' vis)")
    ap.add_argument("--prog", action="append", default=[], help="NAME=PATH of a sightline binary")
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("maps", nargs="+")
    args = ap.parse_args()

    progs = [("ref", os.path.abspath(args.ref))]
    for p in args.prog:
        name, _, path = p.partition("=")
        if not path or name == "ref":
            sys.exit(f"--prog takes NAME=PATH (NAME not 'ref'): {p}")
        progs.append((name, os.path.abspath(path)))

    others = [n for n, _ in progs[1:]]
    header = "| map | runs | ref ms CPU / wall | " + " | ".join(f"{n} ms CPU / wall" for n in others)
    header += " | " + " | ".join(f"ref / {n}: CPU / wall" for n in others) + " |"
    print(header)
    print("|" + "---|" * (3 + 2 * len(others)))
    sys.stdout.flush()

    work = tempfile.mkdtemp(prefix="vis_sbs_")
    try:
        for bsp in args.maps:
            stem = os.path.splitext(bsp)[0]
            prt = stem + ".prt"
            base = os.path.basename(stem)
            times = {n: ([], []) for n, _ in progs}
            for _ in range(args.runs):
                for name, exe in progs:
                    d = os.path.join(work, name)
                    os.makedirs(d, exist_ok=True)
                    shutil.copyfile(bsp, os.path.join(d, base + ".bsp"))
                    shutil.copyfile(prt, os.path.join(d, base + ".prt"))
                    cpu, wall, status, _ = run_once(command(name, exe, args.threads, base + ".bsp"), d)
                    if status != 0:
                        sys.exit(f"{name} failed on {bsp}: status {status}")
                    times[name][0].append(cpu * 1e3)
                    times[name][1].append(wall * 1e3)
            med = {n: (statistics.median(c), statistics.median(w)) for n, (c, w) in times.items()}
            rc, rw = med["ref"]
            row = f"| {base} | {args.runs} | {rc:.2f} / {rw:.2f} | "
            row += " | ".join(f"{med[n][0]:.2f} / {med[n][1]:.2f}" for n in others)
            row += " | " + " | ".join(f"**{rc / med[n][0]:.2f} / {rw / med[n][1]:.2f}**" for n in others) + " |"
            print(row)
            sys.stdout.flush()
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
