#!/usr/bin/env python3
"""Vis one map across machines with HyperQueue (https://github.com/It4innovations/hyperqueue).

plan -> submit the N shard tasks of each wave -> wait -> resubmit the shards `sightline vis status`
finds missing or stale (a task killed, a worker lost) -> merge. The merge writes the map exactly as
`sightline vis --waves W` would on one machine.

    pip install hyperqueue
    # a local cluster (a server and 2 workers of 1 core each, stopped at the end):
    tools/distributed/hq_vis.py maps/e1m1.bsp --shards 8 --local-workers 2
    # a running cluster's server (`hq server start`, workers started by Slurm/PBS allocations):
    tools/distributed/hq_vis.py maps/e1m1.bsp --shards 64 --server-dir ~/.hq-server

Every worker runs `sightline` (give its path with --sightline) and sees the input and the shard
folder at the same paths (a shared file system). Shard tasks take their index from HQ_TASK_ID
(`sightline vis shard N`); resubmitted ones name theirs (`K/N`). Vis flags that change rows
(`--level`, `--portals-from-bsp`, ...) go after `--` and are passed to every step.
"""
import argparse
import json
import os
import subprocess
import sys
import time


def sightline(args, check=True):
    out = subprocess.run(args, capture_output=True, text=True)
    if check and out.returncode != 0:
        sys.exit(f"hq_vis: {' '.join(args)} failed ({out.returncode}):\n{out.stderr}")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input", help="the .bsp (its .prt beside it) or .prt")
    ap.add_argument("--shards", type=int, required=True, help="shards per wave")
    ap.add_argument("--waves", type=int, default=1, help="waves (default 1)")
    ap.add_argument("--dir", help="folder of the shard files (default INPUT.shards), on a shared file system")
    ap.add_argument("--sightline", default="sightline", help="the sightline binary, as the workers see it")
    ap.add_argument("--threads", type=int, default=1, help="threads per shard task (and cores it asks for)")
    ap.add_argument("--server-dir", help="a running HyperQueue server's directory; else a local cluster")
    ap.add_argument("--local-workers", type=int, default=2, help="workers of a local cluster (default 2)")
    ap.add_argument("--retries", type=int, default=2, help="rounds of resubmitting failed shards (default 2)")
    ap.add_argument("--json", action="store_true", help="print the merge report as JSON")
    argv = sys.argv[1:]
    cut = argv.index("--") if "--" in argv else len(argv)
    a = ap.parse_args(argv[:cut])
    flags = argv[cut + 1 :]
    s = os.path.abspath(a.sightline) if os.path.sep in a.sightline else a.sightline
    inp = os.path.abspath(a.input)
    plan_flags = ["--shards", str(a.shards), "--waves", str(a.waves)]
    if a.dir:
        plan_flags += ["--dir", os.path.abspath(a.dir)]
    t0 = time.monotonic()
    plan = json.loads(sightline([s, "vis", "plan", inp, "--json", *plan_flags, *flags]).stdout)
    print(
        f"hq_vis: {inp}: {a.shards} shards x {a.waves} waves over {plan['portals']} portals, "
        f"largest shard {plan['imbalance']:.2f} x the mean",
        file=sys.stderr,
    )

    from hyperqueue import Client, Job
    from hyperqueue.cluster import LocalCluster, WorkerConfig

    cluster = None
    if a.server_dir:
        client = Client(a.server_dir)
    else:
        cluster = LocalCluster()
        for _ in range(a.local_workers):
            cluster.start_worker(WorkerConfig(cores=a.threads))
        client = cluster.client()
    try:
        for wave in range(1, a.waves + 1):
            shard = [s, "vis", "shard", "--wave", str(wave), "--waves", str(a.waves), "--threads", str(a.threads)]
            shard += ["--no-progress", *flags]
            if a.dir:
                shard += ["--dir", os.path.abspath(a.dir)]
            # First round: task i is shard i + 1 (HQ_TASK_ID counts from 0).
            todo = list(range(1, a.shards + 1))
            for attempt in range(a.retries + 1):
                job = Job(max_fails=len(todo))
                for k in todo:
                    spec = str(a.shards) if attempt == 0 else f"{k}/{a.shards}"
                    job.program([*shard, spec, inp], cwd=os.getcwd(), stdout=None, stderr=None)
                submitted = client.submit(job)
                client.wait_for_jobs([submitted], raise_on_error=False)
                status = sightline([s, "vis", "status", inp, "--json", *plan_flags, *flags], check=False)
                left = [
                    e["index"]
                    for e in json.loads(status.stdout)
                    if e["wave"] == wave and e["state"] != "done"
                ]
                if not left:
                    break
                print(f"hq_vis: wave {wave}: shards {left} missing or stale after round {attempt + 1}", file=sys.stderr)
                todo = left
            else:
                sys.exit(f"hq_vis: wave {wave}: shards {todo} still missing after {a.retries} retries")
    finally:
        if cluster is not None:
            cluster.stop()
    merged = sightline([s, "vis", "merge", inp, "--no-progress", *(["--json"] if a.json else []), *plan_flags, *flags])
    sys.stdout.write(merged.stdout)
    print(f"hq_vis: done in {time.monotonic() - t0:.2f} s wall", file=sys.stderr)


if __name__ == "__main__":
    main()
