# Sourced by the peers' run.sh: `peer_start "$@"` sets MODELS to the mesh files given (paths
# relative to the caller's directory, made absolute), ROOT to the repository root, and then cds
# there; usage or a missing file: exit 2.
peer_start() {
    [ "$#" -ge 1 ] || { echo "usage: $0 MODEL..." >&2; exit 2; }
    MODELS=()
    local m
    for m in "$@"; do
        [ -f "$m" ] || { echo "$0: no such mesh file: $m" >&2; exit 2; }
        MODELS+=("$(cd "$(dirname "$m")" && pwd)/$(basename "$m")")
    done
    ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
    cd "$ROOT"
}
