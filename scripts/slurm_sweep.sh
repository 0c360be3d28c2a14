#!/usr/bin/env bash
# One shard of a kfx sweep per Slurm array task (docs/sweep.md, "Shards"). Submit as an array;
# task I of N runs the plan's runs j with j mod N = I into OUT/shard_I, then merge:
#   jobs=$(sbatch --parsable --array=0-7 scripts/slurm_sweep.sh PLAN.json OUT [sweep options])
#   sbatch --dependency=afterok:$jobs --wrap "kfx sweep merge OUT/merged OUT/shard_*"
# A cut-off task resumes when resubmitted alone, saying how many shards there are:
#   KFX_SHARDS=8 sbatch --array=3 scripts/slurm_sweep.sh PLAN.json OUT [the same options]
# Environment: KFX (the kfx binary, default kfx on PATH), KFX_BACKEND (default cuda),
# KFX_CONCURRENT (runs at once per GPU, default 4), KFX_SHARDS (N; default the array's size).
#SBATCH --job-name=kfx-sweep
#SBATCH --gres=gpu:1
#SBATCH --cpus-per-task=8
#SBATCH --time=04:00:00
#SBATCH --output=kfx-sweep-%A_%a.log
set -euo pipefail
if [ $# -lt 2 ]; then
  echo "usage: sbatch --array=0-(N-1) $0 PLAN.json OUT [kfx sweep options...]" >&2
  exit 2
fi
plan="$1"
out="$2"
shift 2
: "${SLURM_ARRAY_TASK_ID:?not an array task: submit with sbatch --array=0-(N-1)}"
# N: KFX_SHARDS, else the array's size, and then the array must be 0..N-1.
if [ -n "${KFX_SHARDS:-}" ]; then
  count="$KFX_SHARDS"
else
  count="${SLURM_ARRAY_TASK_COUNT:?not an array task: submit with sbatch --array=0-(N-1)}"
fi
if [ -z "${KFX_SHARDS:-}" ] && { [ "${SLURM_ARRAY_TASK_MIN:-0}" != 0 ] || [ "${SLURM_ARRAY_TASK_MAX:-$((count - 1))}" != $((count - 1)) ]; }; then
  echo "the array must be 0-$((count - 1)) (one task per shard), got ${SLURM_ARRAY_TASK_MIN:-?}-${SLURM_ARRAY_TASK_MAX:-?}" >&2
  exit 2
fi
kfx="${KFX:-kfx}"
mkdir -p "$out"
exec "$kfx" sweep "$plan" --out "$out/shard_${SLURM_ARRAY_TASK_ID}" --backend "${KFX_BACKEND:-cuda}" \
  --shard "${SLURM_ARRAY_TASK_ID}/${count}" --concurrent "${KFX_CONCURRENT:-4}" "$@"
