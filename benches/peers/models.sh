# Sourced by the peers' run.sh: `peer_models "$@"` sets MODELS to the mesh files given, as
# absolute paths (the scripts cd to the repository root first); usage or a missing file: exit 2.
peer_models() {
    [ "$#" -ge 1 ] || { echo "usage: $0 MODEL..." >&2; exit 2; }
    MODELS=()
    local m
    for m in "$@"; do
        [ -f "$m" ] || { echo "run.sh: no such mesh file: $m" >&2; exit 2; }
        MODELS+=("$(cd "$(dirname "$m")" && pwd)/$(basename "$m")")
    done
}
