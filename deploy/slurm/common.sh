# shellcheck shell=bash
# shellcheck disable=SC2154 # here, root and the settings are globals of the sourcing script
# Sourced by submit.sh and resubmit.sh (not run on its own): one submission of a sweep, written
# down in OUTROOT so that a shard can be resubmitted with exactly the settings it started with.
#
#   OUTROOT/submit.args  NUL-separated: SDFMO, SHARDS, CPUs per task, memory per task (each
#                        possibly empty), MANIFEST, then the sweep flags
#   OUTROOT/submit.jobs  one line per job submitted: `array ID TASKS` or `merge ID DEPENDENCY`
#
# Nothing in these files is evaluated by the shell: they are read back as plain words, and the
# numbers are checked again (check_settings) before any use.

set -euo pipefail
# A failed sbatch inside $(submit_array …) must stop the script, not record an empty job id.
shopt -s inherit_errexit

# need_args MIN USAGE "$@": exits 2 with `usage: SCRIPT USAGE` when fewer than MIN arguments
# were given.
need_args() {
    local min=$1 usage=$2
    shift 2
    if [ $# -lt "$min" ]; then
        echo "usage: $0 $usage" >&2
        exit 2
    fi
}

# Checks the globals `shards`, `cpus` and `mem`. SHARDS goes into an arithmetic expansion, where
# bash would evaluate a crafted value (`a[$(command)]` runs the command): plain decimal digits
# only, 1..1000000 (sdfmo's limit); CPUs and memory likewise digits (memory with Slurm's unit).
check_settings() {
    if ! [[ $shards =~ ^[1-9][0-9]{0,6}$ ]] || [ "$shards" -gt 1000000 ]; then
        echo "$0: SHARDS must be a number of shards in 1..1000000, got '$shards'" >&2
        exit 2
    fi
    if [ -n "$cpus" ] && ! [[ $cpus =~ ^[1-9][0-9]{0,3}$ ]]; then
        echo "$0: SDFMO_CPUS_PER_TASK must be a number of CPUs in 1..9999, got '$cpus'" >&2
        exit 2
    fi
    if [ -n "$mem" ] && ! [[ $mem =~ ^[1-9][0-9]{0,8}[KMGT]?$ ]]; then
        echo "$0: SDFMO_MEM_PER_TASK must be a memory size as sbatch --mem takes it (8G, 8000M; no unit: MB), got '$mem'" >&2
        exit 2
    fi
}

# Submits the array tasks TASKS (`0-63`, `17`, `3,17`) of the sweep described by the globals
# `root`, `shards`, `cpus`, `mem`, `manifest` and `flags`; prints the array's job id and records it.
submit_array() {
    local tasks=$1 id
    local opts=()
    if [ -n "$cpus" ]; then opts+=(--cpus-per-task="$cpus"); fi
    if [ -n "$mem" ]; then opts+=(--mem="$mem"); fi
    id=$(sbatch --parsable --export=ALL,SDFMO_SHARDS="$shards" \
        "${opts[@]}" --array="$tasks" --output="$root/slurm-%A_%a.out" \
        "$here/sweep-array.sbatch" "$manifest" "$root" "${flags[@]}")
    id=${id%%;*}
    echo "array $id $tasks" >> "$root/submit.jobs"
    echo "$id"
}

# Submits the merge of `root`'s shards into `root/report` once DEPENDENCY (sbatch's syntax) is
# met; prints its job id and records it.
submit_merge() {
    local dependency=$1 id
    id=$(sbatch --parsable --dependency="$dependency" --output="$root/slurm-merge-%j.out" \
        "$here/merge.sbatch" "$root" "$root/report")
    id=${id%%;*}
    echo "merge $id $dependency" >> "$root/submit.jobs"
    echo "$id"
}

# Reads OUTROOT/submit.args back into the globals submit_array uses.
read_submission() {
    local file="$root/submit.args" words=()
    if [ ! -f "$file" ] || [ ! -f "$root/submit.jobs" ]; then
        echo "$0: $root holds no submit.args and submit.jobs: was it submitted with submit.sh?" >&2
        exit 2
    fi
    mapfile -d '' words < "$file"
    if [ ${#words[@]} -lt 5 ]; then
        echo "$0: $file is truncated (${#words[@]} fields, need at least 5)" >&2
        exit 2
    fi
    sdfmo_bin=${words[0]} shards=${words[1]} cpus=${words[2]} mem=${words[3]} manifest=${words[4]}
    flags=("${words[@]:5}")
}

# Writes the globals to OUTROOT/submit.args (atomically: a temporary beside it, renamed).
write_submission() {
    local tmp
    tmp=$(mktemp "$root/.submit.args.XXXXXX")
    printf '%s\0' "$sdfmo_bin" "$shards" "$cpus" "$mem" "$manifest" "${flags[@]}" > "$tmp"
    mv -f "$tmp" "$root/submit.args"
}
