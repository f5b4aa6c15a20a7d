#!/bin/bash
# facespace batch as a Slurm job array: 4 tasks, each its own shard of one batch, all writing to
# one folder on a filesystem every node sees. Submit from the checkout, then merge when the array is done:
#   job=$(sbatch --parsable service/deploy/slurm-batch.sh)
#   sbatch --dependency=afterok:$job --wrap "facespace batch merge $PWD/variants/run1"
# A task that failed or was killed: submit it again alone (sbatch --array=2 service/deploy/slurm-batch.sh);
# it resumes where it stopped (--shards 4 makes the array id the shard, so a part of the array
# keeps its shard number). tests/integration/slurm_test.sh submits this script to a one-node cluster.
# The environment may override: FACESPACE (the binary), RIG, OUT, COUNT.
#SBATCH --job-name=facespace-batch
#SBATCH --array=0-3
#SBATCH --cpus-per-task=2
#SBATCH --output=facespace-batch-%A_%a.log
set -euo pipefail
exec "${FACESPACE:-facespace}" batch "${RIG:-assets/facecap/facecap.glb}" --sample uniform --count "${COUNT:-100000}" \
  --seed 7 --active 8 --format glb --out "${OUT:-variants/run1}" --shard auto --shards 4 --quiet
