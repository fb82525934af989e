#!/usr/bin/env bash
# Resubmits shards of a sweep that submit.sh submitted, and replaces its merge job:
#
#   deploy/slurm/resubmit.sh OUTROOT SHARD [SHARD…]
#
# Each SHARD (a killed, preempted, failed or timed-out one) runs again as a task of a new array
# job with the settings submit.sh recorded in OUTROOT (manifest, shard count, flags, binary,
# CPUs and memory), so it resumes from its ledger. The merge job submitted before waits on
# `afterok` of a job that can no longer succeed and would wait forever: it is cancelled
# (scancel), and a new merge waits for the resubmitted shards and for every other shard still
# queued or running. Shards that have already ended are not waited for: the merge itself refuses
# shards with models left unfinished (exit 2, naming the entries), so resubmit those as well.
# SBATCH_* variables (partition, time limit) are read by sbatch now, as on the first submission.
# Prints the new array and merge job ids.
here=$(cd "$(dirname "$0")" && pwd) || exit 2
# shellcheck source=common.sh source-path=SCRIPTDIR
. "$here/common.sh" || exit 2
need_args 2 "OUTROOT SHARD [SHARD...]" "$@"
root=$(realpath -m "$1")
shift
read_submission
check_settings
if [ -n "$sdfmo_bin" ]; then
    export SDFMO=$sdfmo_bin
fi

# The shards to run again: each a shard index of this sweep, once.
declare -A again=()
for k in "$@"; do
    if ! [[ $k =~ ^(0|[1-9][0-9]{0,6})$ ]] || [ "$k" -ge "$shards" ]; then
        echo "$0: SHARD must be a shard index in 0..$((shards - 1)), got '$k'" >&2
        exit 2
    fi
    again[$k]=1
done
tasks=$(printf '%s\n' "${!again[@]}" | sort -n | paste -sd,)

# Every task of this sweep's arrays that Slurm still has queued or running (%F: array job id,
# %K: task id, one line per task with -r). A shard to resubmit may not be among them: two jobs
# would write one ledger.
declare -A ours=()
while read -r kind id _; do
    if [ "$kind" = array ]; then ours[$id]=1; fi
done < "$root/submit.jobs"
dependency="afterok"
while read -r job task state; do
    if [ -z "${ours[$job]:-}" ]; then continue; fi
    if [ -n "${again[$task]:-}" ]; then
        echo "$0: shard $task is still $state as job ${job}_$task: scancel ${job}_$task first, or let it end" >&2
        exit 2
    fi
    dependency+=":${job}_$task"
done < <(squeue -h -r -o '%F %K %T')

old_merge=$(awk '$1 == "merge" { id = $2 } END { print id }' "$root/submit.jobs")
array=$(submit_array "$tasks")
merge=$(submit_merge "$dependency:$array")
if [ -n "$old_merge" ]; then
    # The old merge may have ended already (then there is nothing to cancel).
    scancel "$old_merge" 2> /dev/null || true
fi
echo "array job $array (shards $tasks), merge job $merge${old_merge:+ (replaces $old_merge, cancelled)}; report: $root/report/index.html"
