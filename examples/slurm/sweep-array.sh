#!/usr/bin/env bash
# A sweep as a Slurm job array: array task i runs shards i, i + T, i + 2T, … of N (T tasks), so
# N may exceed the cluster's MaxArraySize (Debian's default is 1001) and a `%` throttle limits how
# many run at once. Every shard resumes where an earlier try stopped; merge when all are done.
#
#   jobid=$(sbatch --parsable --array=1-8%4 examples/slurm/sweep-array.sh sweep.toml out 32 --backend cpu-fast)
#   sbatch --dependency=afterok:$jobid --kill-on-invalid-dep=yes --wrap "sonarproj merge out"
#
# Arguments: the sweep file, the output directory (on a file system every node shares), the
# number of shards N, then any further `sonarproj sweep` options (e.g. --backend cpu-fast).
# SONARPROJ names the binary when `sonarproj` is not on the nodes' PATH.
#SBATCH --job-name=sonarproj-sweep
#SBATCH --output=sonarproj-sweep-%A_%a.out
set -euo pipefail
if [ "$#" -lt 3 ]; then
    echo "usage: sbatch --array=1-T sweep-array.sh SWEEP.toml OUT_DIR SHARDS [sweep options]" >&2
    exit 2
fi
config=$1 out=$2 shards=$3
shift 3
: "${SLURM_ARRAY_TASK_ID:?submit with sbatch --array=1-T (one task per shard or fewer)}"
case "$shards" in '' | *[!0-9]*) echo "SHARDS must be a whole number, got '$shards'" >&2; exit 2 ;; esac
shards=$((10#$shards)) # decimal, whatever leading zeros
if [ "$shards" -lt 1 ]; then
    echo "SHARDS must be at least 1, got $shards" >&2
    exit 2
fi
tasks=$SLURM_ARRAY_TASK_COUNT
# The arithmetic below needs a contiguous array (1-T, not 1-T:2 or 1,5,9).
if [ $((SLURM_ARRAY_TASK_MAX - SLURM_ARRAY_TASK_MIN + 1)) -ne "$tasks" ]; then
    echo "the array must be contiguous (--array=1-T); this one has $tasks tasks from $SLURM_ARRAY_TASK_MIN to $SLURM_ARRAY_TASK_MAX" >&2
    exit 2
fi
task=$((SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN))
for ((k = task + 1; k <= shards; k += tasks)); do
    "${SONARPROJ:-sonarproj}" sweep --config "$config" --out "$out" --shard "$k/$shards" "$@"
done
