#!/usr/bin/env bash
# Vis one map across a Slurm cluster: one array task per shard, then the merge once all are done.
# Every node sees the map and its shard folder at the same path (a shared file system) and has
# `sightline` on its PATH.
#
#   tools/distributed/slurm_array.sh maps/e1m1.bsp 32          # 32 shards, one wave
#   WAVES=4 tools/distributed/slurm_array.sh maps/e1m1.bsp 16  # 4 waves of 16 (less CPU in all)
#
# Each array task runs `sightline vis shard N`, which takes its shard from SLURM_ARRAY_TASK_ID
# (counting from 0, hence --array=0-(N-1)). A wave's array depends on the previous wave's; the
# merge, on the last. A failed task is rerun with `sbatch --array=K-1 ...` (or
# `sightline vis status` lists what is missing), and merge refuses to run on a partial set unless
# told `--allow-partial`.
set -euo pipefail
MAP=$(realpath "$1")
SHARDS=$2
WAVES=${WAVES:-1}
THREADS=${THREADS:-1}
FLAGS=${FLAGS:-}   # vis flags that change rows, the same for every step: --level 3, ...
sightline vis plan "$MAP" --shards "$SHARDS" --waves "$WAVES" $FLAGS | head -1
dep=""
for wave in $(seq 1 "$WAVES"); do
    job=$(sbatch --parsable --array=0-$((SHARDS - 1)) --cpus-per-task="$THREADS" ${dep:+--dependency=afterok:$dep} \
        --job-name="vis-w$wave" --output="vis-w$wave-%a.log" \
        --wrap="sightline vis shard $SHARDS '$MAP' --wave $wave --waves $WAVES --threads $THREADS --no-progress $FLAGS")
    dep=$job
done
sbatch --dependency=afterok:"$dep" --job-name=vis-merge --output=vis-merge.log \
    --wrap="sightline vis merge '$MAP' --shards $SHARDS --waves $WAVES --no-progress $FLAGS"
echo "submitted: $WAVES wave(s) of $SHARDS shards, then the merge (squeue -u $USER)"
