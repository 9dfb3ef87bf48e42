#!/usr/bin/env bash
# A sweep as a Slurm job array: one array task per run, then one job that
# writes the table. Submit it with the run count `cosim sweep --list`
# prints (docs/sweeps.md):
#   n=$(cosim sweep FILE --out OUT --list | wc -l)
#   jid=$(sbatch --parsable --array=0-$((n - 1)) scripts/sweep-slurm.sh FILE OUT)
#   sbatch --dependency=afterany:$jid --wrap "cosim sweep FILE --out OUT --table"
# Each task runs its one run (`--only`, in its own iceoryx2 domain and
# folder); a task that is run again skips a run already done.
#SBATCH --job-name=cosim-sweep
#SBATCH --cpus-per-task=1
set -euo pipefail
file=$1
out=$2
exec cosim sweep "$file" --out "$out" --only "${SLURM_ARRAY_TASK_ID:?run this as an array job}" --parallel 1
