#!/usr/bin/env bash
# Submits `nerf bench SUITE` to Slurm: a job array of one task per scene
# (bench-task.sbatch, $SLURM_ARRAY_TASK_ID as --task), then a gather job
# (bench-gather.sbatch) that writes the table once every task has ended,
# however it ended. OUT must be on storage every node sees: it is the only
# meeting point of the tasks. Prints the two job ids; the jobs' logs
# (nerf-bench-JOB_TASK.log, nerf-bench-gather-JOB.log) go to the folder it
# is run from.
#
#   examples/bench/slurm/submit.sh SUITE OUT --minutes 60 [other nerf bench flags]
#
# NERF names the nerf binary (default: nerf on PATH); sbatch passes the
# environment on to the jobs. SBATCH_* variables and a partition, account or
# time limit given here in SBATCH_ARGS reach both jobs.
set -euo pipefail
if [ $# -lt 2 ]; then
    echo "usage: $0 SUITE OUT [nerf bench flags, e.g. --minutes 60]" >&2
    exit 2
fi
suite=$1 out=$2
shift 2
here=$(cd "$(dirname "$0")" && pwd)
export NERF=${NERF:-nerf}
# the scene count, which sizes the array (the same flags: --downscale changes no count, but a bad flag fails here)
n=$("$NERF" bench "$suite" --list "$@" | wc -l)
# the jobs' logs go where sbatch runs (this folder): OUT holds only the bench's files
# shellcheck disable=SC2086
array=$(sbatch --parsable ${SBATCH_ARGS:-} --array="0-$((n - 1))" --output="nerf-bench-%A_%a.log" \
    "$here/bench-task.sbatch" "$suite" "$out" "$@")
# shellcheck disable=SC2086
gather=$(sbatch --parsable ${SBATCH_ARGS:-} --dependency="afterany:${array%%;*}" --output="nerf-bench-gather-%j.log" \
    "$here/bench-gather.sbatch" "$suite" "$out") || {
    echo "submit.sh: the gather job was not submitted; the array ${array%%;*} runs: gather later with" \
        "nerf bench $suite --out $out --gather" >&2
    exit 1
}
echo "array ${array%%;*} ($n tasks), gather ${gather%%;*}"
