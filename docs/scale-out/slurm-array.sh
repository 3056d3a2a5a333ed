#!/usr/bin/env bash
# Slurm array job: one `mapkeeper validate` shard per array task. Submit with
#   sbatch --array=1-10 docs/scale-out/slurm-array.sh
# then merge once every task is done (the job id is printed by sbatch):
#   sbatch --dependency=afterok:JOBID --wrap 'mapkeeper merge $(for k in $(seq 1 10); do echo sweep/shards/$k; done) --out sweep/all --force'
# Shard k of N is the k-th contiguous slice of the (preset × seed) jobs. N is SHARDS (default
# 10), not the array's size, so that re-submitting only the failed indices, e.g. --array=3,7,
# runs the same shards; keep it equal to the array's last index and to the merge's `seq`.
# A task whose shard folder is complete exits at once, so re-submitting the same array after a
# failure runs only the shards that did not finish.
#
# Environment (sbatch passes the submitting shell's by default):
#   OUT            results folder on a shared file system (default ./sweep)
#   SHARDS         N (default 10)
#   VALIDATE_ARGS  the sweep (default "--presets paper,mapkeeper --seeds 30"); no --shard,
#                  --jobs, --out or --force (the script sets the first three; --force would
#                  defeat the resume)
#   MAPKEEPER      the binary (default `mapkeeper` on PATH)
# Run for real on a single-node Slurm by docs/scale-out/slurm-single-node.sh.
#SBATCH --job-name=mapkeeper-validate
#SBATCH --cpus-per-task=2
#SBATCH --mem=1G
#SBATCH --time=04:00:00
#SBATCH --output=mapkeeper-%A_%a.log
set -euo pipefail
out=${OUT:-$PWD/sweep}
k=${SLURM_ARRAY_TASK_ID:?run as an array job (sbatch --array=1-10)}
n=${SHARDS:-10}
bin=${MAPKEEPER:-mapkeeper}
read -r -a sweep <<<"${VALIDATE_ARGS:---presets paper,mapkeeper --seeds 30}"
if [ -f "$out/shards/$k/runs.json" ] || [ -f "$out/shards/$k/summary.json" ]; then
    echo "shard $k/$n: complete, skipped"
    exit 0
fi
mkdir -p "$out/shards"
"$bin" validate "${sweep[@]}" --shard "$k/$n" \
    --jobs "${SLURM_CPUS_PER_TASK:-1}" --resume --out "$out/shards/$k"
