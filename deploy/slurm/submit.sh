#!/usr/bin/env bash
# Submits a dataset sweep as a Slurm array of SHARDS tasks and its merge, which runs when every
# task has succeeded (--dependency=afterok):
#
#   deploy/slurm/submit.sh MANIFEST OUTROOT SHARDS [sweep flags…]
#
# The report lands in OUTROOT/report. Prints the two job ids. Extra sbatch options (partition,
# time limit, account) go in SBATCH_* environment variables, e.g. SBATCH_PARTITION=cpu;
# SDFMO_CPUS_PER_TASK=N asks for N CPUs per shard (each model then runs with --threads N).
set -euo pipefail
if [ $# -lt 3 ]; then
    echo "usage: $0 MANIFEST OUTROOT SHARDS [sweep flags...]" >&2
    exit 2
fi
here=$(cd "$(dirname "$0")" && pwd)
manifest=$(realpath "$1")
root=$(realpath -m "$2")
shards=$3
shift 3
# SHARDS goes into an arithmetic expansion below, where bash would evaluate a crafted value
# (`a[$(command)]` runs the command): plain decimal digits only, 1..1000000 (sdfmo's limit).
if ! [[ $shards =~ ^[1-9][0-9]{0,6}$ ]] || [ "$shards" -gt 1000000 ]; then
    echo "$0: SHARDS must be a number of shards in 1..1000000, got '$shards'" >&2
    exit 2
fi
cpus=()
if [ -n "${SDFMO_CPUS_PER_TASK:-}" ]; then
    if ! [[ $SDFMO_CPUS_PER_TASK =~ ^[1-9][0-9]{0,3}$ ]]; then
        echo "$0: SDFMO_CPUS_PER_TASK must be a number of CPUs in 1..9999, got '$SDFMO_CPUS_PER_TASK'" >&2
        exit 2
    fi
    cpus=(--cpus-per-task="$SDFMO_CPUS_PER_TASK")
fi
mkdir -p "$root"
array=$(SDFMO_SHARDS=$shards sbatch --parsable --export=ALL,SDFMO_SHARDS="$shards" \
    "${cpus[@]}" --array="0-$((shards - 1))" --output="$root/slurm-%A_%a.out" \
    "$here/sweep-array.sbatch" "$manifest" "$root" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency="afterok:$array" --output="$root/slurm-merge-%j.out" \
    "$here/merge.sbatch" "$root" "$root/report")
echo "array job $array ($shards shards), merge job $merge; report: $root/report/index.html"
