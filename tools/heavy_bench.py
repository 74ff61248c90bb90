#!/usr/bin/env python3
"""The heavy benchmark set, side by side with ericw-tools on this machine (issue 46).

For each item, a generated map name (`terrain_24`, `arena_16`, `city_12`, `tiny_1000`: see
`tests/src/heavy.rs` and `tests/examples/heavy_maps.rs`) or a compiled `.bsp` with its `.prt`
beside it (for example the heaviest shared maps):

1. a generated map is written by the `heavy_maps` example and compiled twice: by ericw-tools'
   `qbsp -notex` (its `.bsp` and `.prt`) and by `sightline compile --json` (our compiler and our
   vis, on our own portals);
2. ericw-tools' `vis -threads N` and `sightline vis --threads N` each run once on a fresh copy of
   the same `.bsp` and `.prt` (the ericw-compiled one);
3. the two vised files are read back with `sightline info --json` for their visible leaf pairs.

Per run it records the child's CPU time (user + system), wall time and peak resident memory
(from wait4). It prints a Markdown table as rows finish and writes every number as JSON lines
(`--json FILE`). A run over `--timeout` seconds is stopped and shown as "> T s".

    cargo build --release -p sightline -p sightline-tests --example heavy_maps
    tools/heavy_bench.py --ericw /path/to/ericw/build --sightline target/release/sightline \\
        --heavy-maps target/release/examples/heavy_maps [--threads 2] [--timeout 3600] \\
        [--work DIR] [--json results.jsonl] terrain_24 arena_16 ../shared/maps/ericw/e1m1.bsp

`--ericw DIR` holds `qbsp` and `vis` (a CMake build folder: `DIR/qbsp/qbsp`, `DIR/vis/vis`, or
both directly in DIR). Only the standard library is used.
"""

import argparse
import json
import os
import shutil
import signal
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vis_side_by_side import run_once  # noqa: E402


GNU_TIME = "/usr/bin/time"


def run_limited(argv, cwd, timeout, stdout_path=None):
    """Like `run_once`, stopped after `timeout` seconds (status None), stdout kept in
    `stdout_path` when given. Returns (cpu_seconds, wall_seconds, status, peak_resident_kib).

    Linux keeps a process's peak resident size across exec, so a child spawned from this Python
    process reports at least Python's own size; with GNU time installed the child runs under it
    (a small process) and the peak is the one time reports."""
    peak_file = None
    if os.access(GNU_TIME, os.X_OK):
        peak_file = os.path.join(cwd, ".peak_kib")
        argv = [GNU_TIME, "-q", "-f", "%M", "-o", peak_file] + argv
    cpu, wall, status, rss = run_spawned(argv, cwd, timeout, stdout_path)
    if peak_file:
        try:
            with open(peak_file) as f:
                rss = int(f.read().split()[-1])
            os.remove(peak_file)
        except (OSError, ValueError, IndexError):
            pass
    return cpu, wall, status, rss


def run_spawned(argv, cwd, timeout, stdout_path):
    """Spawn argv in cwd, stopped after `timeout` seconds (status None), stdout kept in
    `stdout_path` when given; (cpu_seconds, wall_seconds, status, peak_resident_kib)."""
    if timeout is None and stdout_path is None:
        return run_once(argv, cwd)
    devnull = os.open(os.devnull, os.O_WRONLY)
    out = os.open(stdout_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644) if stdout_path else devnull
    try:
        actions = [(os.POSIX_SPAWN_DUP2, out, 1), (os.POSIX_SPAWN_DUP2, devnull, 2)]
        start = time.perf_counter()
        old = os.getcwd()
        os.chdir(cwd)
        try:
            # A process group of its own, so a stop reaches the program under GNU time too.
            pid = os.posix_spawn(argv[0], argv, os.environ, file_actions=actions, setpgroup=0)
        finally:
            os.chdir(old)
        stopped = False
        while True:
            got, status, usage = os.wait4(pid, os.WNOHANG)
            if got == pid:
                break
            if timeout is not None and time.perf_counter() - start > timeout and not stopped:
                os.killpg(pid, signal.SIGKILL)
                stopped = True
            time.sleep(0.1)
        wall = time.perf_counter() - start
    finally:
        if out != devnull:
            os.close(out)
        os.close(devnull)
    return usage.ru_utime + usage.ru_stime, wall, None if stopped else status, usage.ru_maxrss


def ericw_tool(folder, name):
    for path in (os.path.join(folder, name, name), os.path.join(folder, name)):
        if os.path.isfile(path) and os.access(path, os.X_OK):
            return os.path.abspath(path)
    sys.exit(f"no {name} in {folder} (looked for {name}/{name} and {name})")


def visible_pairs(sightline, bsp):
    """Ordered visible leaf pairs of a vised `.bsp`, from `sightline info --json`."""
    out = bsp + ".info.json"
    _, _, status, _ = run_limited([sightline, "info", "--json", os.path.basename(bsp)], os.path.dirname(bsp), None, out)
    if status != 0:
        return None
    with open(out) as f:
        info = json.load(f)
    if info.get("pvs_pairs") is None:
        return None
    return info["pvs_pairs"]


def prt_counts(path):
    """(vis leaves, portals) from a `.prt` header (PRT1: leaves, portals; PRT2: leaves,
    clusters, portals)."""
    with open(path, errors="replace") as f:
        head = [f.readline().strip() for _ in range(4)]
    if head[0] == "PRT2":
        return int(head[1]), int(head[3])
    return int(head[1]), int(head[2])


def fresh_copy(src_stem, folder):
    os.makedirs(folder, exist_ok=True)
    base = os.path.basename(src_stem)
    for ext in (".bsp", ".prt"):
        shutil.copyfile(src_stem + ext, os.path.join(folder, base + ext))
    return os.path.join(folder, base + ".bsp")


def measure(item, args, work, record):
    name = os.path.splitext(os.path.basename(item))[0]
    row = {"map": name, "threads": args.threads}
    d = os.path.join(work, name)
    os.makedirs(d, exist_ok=True)
    if item.endswith(".bsp"):
        stem = os.path.splitext(os.path.abspath(item))[0]
        if not os.path.isfile(stem + ".prt"):
            sys.exit(f"{item}: no {name}.prt beside it")
    else:
        _, _, status, _ = run_limited([args.heavy_maps, d, name], d, None)
        if status != 0:
            sys.exit(f"heavy_maps could not write {name}")
        qd = os.path.join(d, "ericw")
        os.makedirs(qd, exist_ok=True)
        shutil.copyfile(os.path.join(d, name + ".map"), os.path.join(qd, name + ".map"))
        cpu, wall, status, rss = run_limited([args.qbsp, "-notex", name + ".map"], qd, args.timeout)
        row["ericw_qbsp"] = {"cpu": cpu, "wall": wall, "peak_kib": rss, "status": status}
        if status != 0:
            record(row)
            return row
        stem = os.path.join(qd, name)
        od = os.path.join(d, "ours")
        os.makedirs(od, exist_ok=True)
        shutil.copyfile(os.path.join(d, name + ".map"), os.path.join(od, name + ".map"))
        report = os.path.join(od, "compile.json")
        argv = [args.sightline, "compile", "--json", "--threads", str(args.threads), name + ".map"]
        cpu, wall, status, rss = run_limited(argv, od, args.timeout, report)
        row["ours_compile"] = {"cpu": cpu, "wall": wall, "peak_kib": rss, "status": status}
        if status == 0:
            with open(report) as f:
                stats = json.load(f)["stats"]
            row["ours_compile"]["portals"] = stats["portals"]
            row["ours_compile"]["vis_leaves"] = stats["vis_leaves"]
            row["ours_compile"]["vis_seconds"] = next(p["seconds"] for p in stats["phases"] if p["name"] == "vis")
    row["vis_leaves"], row["portals"] = prt_counts(stem + ".prt")
    for tool, argv in (
        ("ericw", [args.vis, "-threads", str(args.threads), name + ".bsp"]),
        ("ours", [args.sightline, "vis", "--no-progress", "--threads", str(args.threads), name + ".bsp"]),
    ):
        bsp = fresh_copy(stem, os.path.join(d, tool + "_vis"))
        cpu, wall, status, rss = run_limited(argv, os.path.dirname(bsp), args.timeout)
        row[tool + "_vis"] = {"cpu": cpu, "wall": wall, "peak_kib": rss, "status": status}
        if status == 0:
            row[tool + "_vis"]["pairs"] = visible_pairs(args.sightline, bsp)
    record(row)
    return row


def cell(run, timeout):
    if run is None:
        return "—"
    if run["status"] is None:
        return f"> {timeout:.0f} s (stopped)"
    if run["status"] != 0:
        return f"failed ({run['status']})"
    return f"{run['cpu']:.1f} / {run['wall']:.1f} / {run['peak_kib'] / 1024:.0f}"


def print_row(row, timeout):
    e, o = row.get("ericw_vis"), row.get("ours_vis")
    ok = e and o and e["status"] == 0 and o["status"] == 0
    ratio = f"**{e['cpu'] / max(o['cpu'], 1e-3):.1f}**" if ok else "—"
    pairs = f"{o['pairs']:,} / {e['pairs']:,} = {o['pairs'] / e['pairs']:.3f}" if ok and o["pairs"] and e["pairs"] else "—"
    c = row.get("ours_compile")
    own = (
        f"{c['portals']:,} portals, vis {c['vis_seconds']:.1f} s wall, total {c['cpu']:.1f} CPU s"
        if c and c.get("status") == 0
        else cell(c, timeout)
    )
    q = row.get("ericw_qbsp")
    print(
        f"| {row['map']} | {row.get('vis_leaves', '—')} / {row.get('portals', '—')} | {cell(q, timeout)} | {cell(e, timeout)} | {cell(o, timeout)} "
        f"| {ratio} | {pairs} | {own} |"
    )
    sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ericw", required=True, help="folder holding ericw-tools' qbsp and vis")
    ap.add_argument("--sightline", required=True)
    ap.add_argument("--heavy-maps", help="the heavy_maps example binary (for generated names)")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per run")
    ap.add_argument("--work", help="keep the files here (default: a temporary folder, removed)")
    ap.add_argument("--json", help="append every row as a JSON line to this file")
    ap.add_argument("items", nargs="+")
    args = ap.parse_args()
    args.qbsp, args.vis = ericw_tool(args.ericw, "qbsp"), ericw_tool(args.ericw, "vis")
    args.sightline = os.path.abspath(args.sightline)
    if any(not i.endswith(".bsp") for i in args.items):
        if not args.heavy_maps:
            sys.exit("generated names need --heavy-maps PATH")
        args.heavy_maps = os.path.abspath(args.heavy_maps)

    def record(row):
        if args.json:
            with open(args.json, "a") as f:
                f.write(json.dumps(row) + "\n")

    print(
        f"| map | ericw .prt: vis leaves / portals | ericw qbsp CPU s / wall s / MB | ericw vis -threads {args.threads}: CPU s / wall s / MB "
        f"| ours vis --threads {args.threads}: CPU s / wall s / MB | ericw / ours CPU | pairs ours / ericw "
        "| ours from our own compile |"
    )
    print("|---|---:|---|---|---|---|---|---|")
    work = args.work or tempfile.mkdtemp(prefix="heavy_bench_")
    try:
        for item in args.items:
            print_row(measure(item, args, os.path.abspath(work), record), args.timeout)
    finally:
        if not args.work:
            shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
