#!/usr/bin/env bash
# Submits a dataset sweep as a Slurm array of SHARDS tasks and its merge, which runs when every
# task has succeeded (--dependency=afterok):
#
#   deploy/slurm/submit.sh MANIFEST OUTROOT SHARDS [sweep flags…]
#
# The report lands in OUTROOT/report. Prints the two job ids. Read from the environment:
#   SDFMO                the sdfmo binary the jobs run (default: sdfmo on PATH)
#   SDFMO_CPUS_PER_TASK  sbatch's --cpus-per-task for each shard (each model then runs with
#                        --threads N)
#   SDFMO_MEM_PER_TASK   sbatch's --mem for each shard (8G; no unit: MB). It must hold the
#                        sweep's --max-memory, which it then requires: without it each build's
#                        budget is half the node's memory, whatever Slurm granted
#   SBATCH_*             any other sbatch option, read by sbatch itself (SBATCH_PARTITION,
#                        SBATCH_TIMELIMIT, SBATCH_ACCOUNT, …)
# What was submitted is recorded in OUTROOT (submit.args, submit.jobs), so that resubmit.sh can
# rerun a shard with the same settings and replace the merge job.
here=$(cd "$(dirname "$0")" && pwd) || exit 2
# shellcheck source=common.sh source-path=SCRIPTDIR
. "$here/common.sh" || exit 2
need_args 3 "MANIFEST OUTROOT SHARDS [sweep flags...]" "$@"
manifest=$(realpath "$1")
root=$(realpath -m "$2")
shards=$3
shift 3
flags=("$@")
cpus=${SDFMO_CPUS_PER_TASK:-}
mem=${SDFMO_MEM_PER_TASK:-}
check_settings

# The sweep's --max-memory (either spelling), empty when not given.
max_memory=
for ((i = 0; i < ${#flags[@]}; i++)); do
    case "${flags[i]}" in
        --max-memory=*) max_memory=${flags[i]#--max-memory=} ;;
        --max-memory) max_memory=${flags[i + 1]:-} ;;
    esac
done
# sdfmo's sizes are K/M/G/T (powers of 1024, optional B or iB, decimals allowed), as numfmt's IEC
# ones are once the B is dropped; Slurm's are the same powers, MB without a unit.
bytes() {
    local s=${1^^}
    s=${s%B}
    s=${s%I}
    numfmt --from=iec -- "$s" 2> /dev/null
}
if [ -n "$mem" ]; then
    if [ -z "$max_memory" ]; then
        echo "$0: SDFMO_MEM_PER_TASK=$mem needs the sweep's --max-memory (at most $mem, e.g. 2G less for the shard's own process): without it each build's budget is half the node's memory" >&2
        exit 2
    fi
    if [[ $mem =~ [0-9]$ ]]; then mem_bytes=$(bytes "${mem}M"); else mem_bytes=$(bytes "$mem"); fi
    if ! budget=$(bytes "$max_memory"); then
        echo "$0: cannot read --max-memory '$max_memory' (expected a size such as 6G or 512M)" >&2
        exit 2
    fi
    if [ "$budget" -gt "$mem_bytes" ]; then
        echo "$0: --max-memory $max_memory is more than SDFMO_MEM_PER_TASK=$mem: Slurm would kill builds that the budget allows" >&2
        exit 2
    fi
elif [ -n "$max_memory" ]; then
    echo "$0: note: --max-memory $max_memory without SDFMO_MEM_PER_TASK: each shard gets Slurm's default memory (DefMemPerCPU or the node's)" >&2
fi

# The binary, by an absolute path where it is one, so that resubmit.sh finds it from anywhere.
sdfmo_bin=${SDFMO:-}
if [[ $sdfmo_bin == */* ]]; then
    sdfmo_bin=$(realpath "$sdfmo_bin")
    export SDFMO=$sdfmo_bin
fi
mkdir -p "$root"
write_submission
array=$(submit_array "0-$((shards - 1))")
merge=$(submit_merge "afterok:$array")
echo "array job $array ($shards shards), merge job $merge; report: $root/report/index.html"
