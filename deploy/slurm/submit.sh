#!/usr/bin/env bash
# Submits a dataset sweep as a Slurm array of SHARDS tasks and its merge, which runs when every
# task has succeeded (--dependency=afterok):
#
#   deploy/slurm/submit.sh MANIFEST OUTROOT SHARDS [sweep flags…]
#
# The report lands in OUTROOT/report. Prints the two job ids. Extra sbatch options (partition,
# time limit, account) go in SBATCH_* environment variables, e.g. SBATCH_PARTITION=cpu.
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
mkdir -p "$root"
array=$(SDFMO_SHARDS=$shards sbatch --parsable --export=ALL,SDFMO_SHARDS="$shards" \
    --array="0-$((shards - 1))" --output="$root/slurm-%A_%a.out" \
    "$here/sweep-array.sbatch" "$manifest" "$root" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency="afterok:$array" --output="$root/slurm-merge-%j.out" \
    "$here/merge.sbatch" "$root" "$root/report")
echo "array job $array ($shards shards), merge job $merge; report: $root/report/index.html"
