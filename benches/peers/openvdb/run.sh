#!/usr/bin/env bash
# OpenVDB / NanoVDB peer (issue 33): one command from meshes to docs/results/openvdb.md.
#
#   benches/peers/openvdb/run.sh MODEL...     e.g. ../shared/data/abc{1,3,5,8}.stl ../shared/data/teapot.obj
#
# Steps (each cached under OUT: a rerun skips what is finished; every file written atomically):
#   1. setup.sh: Debian packages, g++ build of vdbpeer (vdbpeer.cpp).
#   2. the sdfmo CLI (release).
#   3. peer.py matrix: mesh references (sdfmo render-mesh, the sweep's renderer), then per depth
#      (VDB_DEPTHS, in that order: all models at the first depth before the next), model and
#      narrow-band half-width (VDB_BANDS): meshToLevelSet, the .vdb and NanoVDB float / Fp16 /
#      Fp8 / Fp4 / FpN, the 4 paper views of each at 1024² (vdbpeer render), sdfmo compare.
#   3b. peer.py shifted: the same grids with the index origin at world (-1,-1,-1), sizes only
#      (renders checked at depth 9): NanoVDB's upper nodes are 4096³ voxels and meet at index 0.
#   4. peer.py timing: ours and theirs interleaved (build, view-0 render), VDB_ROUNDS rounds.
#   4b. peer.py intersectors: NanoVDB's ZeroCrossing as it is, refined, and the exact walk.
#   5. peer.py hard: generated CAD-like parts (thin fins, thin gaps, an open sheet) through both;
#      peer.py unsigned: OpenVDB's unsigned distance field (shell at 0.5 voxel) on open meshes.
#   6. report.py --rows-only, then `sdfmo sweep MODELS --extra-rows` (our rows, measured now, and
#      theirs in one table and plots), then report.py: OUT/results.json, docs/results/openvdb.md.
#
# Environment (all optional):
#   VDB_THREADS (2)  VDB_NICE (10)  VDB_OUT (benches/peers/openvdb/out, gitignored)
#   VDB_DEPTHS (9,10,6,7,8)  VDB_BANDS (1,2,3)  VDB_FRAMES (1: frames per view in the matrix)
#   VDB_TIMING_DEPTHS (9,10)  VDB_ROUNDS (3)  VDB_TIMING_FRAMES (3)
#   VDB_UNSIGNED (teapot: model stems also run through meshToUnsignedDistanceField)
#   VDB_SKIP_TIMING=1  VDB_SKIP_HARD=1  VDB_NO_DOCS=1 (do not rewrite docs/results/openvdb.md)
#   VDB_RERUN_SWEEP=1 (rerun the combined sweep although OUT/combined covers the models)
set -euo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
. "$HERE/../models.sh"
peer_start "$@"
THREADS="${VDB_THREADS:-2}"
NICE="${VDB_NICE:-10}"
OUT="${VDB_OUT:-$HERE/out}"
DEPTHS="${VDB_DEPTHS:-9,10,6,7,8}"
mkdir -p "$OUT"
log() { echo "[openvdb $(date -u +%H:%M:%S)] $*" >&2; }
PY=/usr/bin/python3

VDBPEER="$(VDB_NICE="$NICE" "$HERE/setup.sh" | tail -1)"
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"
log "building the sdfmo CLI (release)"
nice -n "$NICE" cargo build --release -q -p sdfmo-cli
SDFMO="$TARGET/release/sdfmo"
common=(--out "$OUT" --sdfmo "$SDFMO" --vdbpeer "$VDBPEER" --threads "$THREADS" --nice "$NICE")

log "matrix: depths $DEPTHS, bands ${VDB_BANDS:-1,2,3}"
"$PY" "$HERE/peer.py" matrix "${MODELS[@]}" "${common[@]}" --depths "$DEPTHS" --bands "${VDB_BANDS:-1,2,3}" \
    --frames "${VDB_FRAMES:-1}"
log "shifted index origin: sizes of every cell (the root cube in one upper node)"
"$PY" "$HERE/peer.py" shifted "${MODELS[@]}" "${common[@]}" --depths "$DEPTHS" --bands "${VDB_BANDS:-1,2,3}"
log "intersectors: ZeroCrossing as it is, refined, exact (${MODELS[0]##*/}, finest depth)"
"$PY" "$HERE/peer.py" intersectors "${MODELS[0]}" "${common[@]}" --depths "$DEPTHS"
if [ -z "${VDB_SKIP_TIMING:-}" ]; then
    log "interleaved timing"
    "$PY" "$HERE/peer.py" timing "${MODELS[@]}" "${common[@]}" --timing-depths "${VDB_TIMING_DEPTHS:-9,10}" \
        --rounds "${VDB_ROUNDS:-3}" --timing-frames "${VDB_TIMING_FRAMES:-3}"
fi
if [ -z "${VDB_SKIP_HARD:-}" ]; then
    log "hard cases"
    "$PY" "$HERE/peer.py" hard "${common[@]}"
fi
# OpenVDB's tool for open meshes (meshToUnsignedDistanceField, shell at 0.5 voxel) on the models
# named in VDB_UNSIGNED (stems; default teapot: its body, lid and spout are open sheets) and the
# generated parts
UNSIGNED=()
for m in "${MODELS[@]}"; do
    st="$(basename "${m%.*}")"
    case ",${VDB_UNSIGNED:-teapot}," in *",$st,"*) UNSIGNED+=("$m") ;; esac
done
log "unsigned distance field for open meshes: ${UNSIGNED[*]##*/} and the generated parts"
"$PY" "$HERE/peer.py" unsigned "${UNSIGNED[@]}" "${common[@]}" --depths "$DEPTHS"

# the combined sweep: ours measured now with theirs merged (--extra-rows)
dmin="$(echo "$DEPTHS" | tr ',' '\n' | sort -n | head -1)"
dmax="$(echo "$DEPTHS" | tr ',' '\n' | sort -n | tail -1)"
"$PY" "$HERE/report.py" --out "$OUT" --rows-only "${MODELS[@]}"
# rerun the combined sweep when its merged rows are not this run's rows (or VDB_RERUN_SWEEP=1)
same_rows() {
    "$PY" - "$OUT/results.json" "$OUT/combined/results.json" <<'PYEOF'
import json, sys
rows = json.load(open(sys.argv[1]))["rows"]
comb = json.load(open(sys.argv[2]))
key = lambda r: (r["model"], r["method"], r["depth"], r["psnr"], r["bytes"])
mine = sorted(key(r) for r in rows)
merged = sorted(key(r) for r in comb["rows"] if r["method"] not in ("svo", "multi"))
sys.exit(0 if mine == merged else 1)
PYEOF
}
if [ ! -f "$OUT/combined/results.json" ] || [ -n "${VDB_RERUN_SWEEP:-}" ] || ! same_rows; then
    log "sdfmo sweep --extra-rows (depths $dmin..$dmax, 1024², $THREADS threads)"
    rm -rf "$OUT/combined.tmp"
    nice -n "$NICE" "$SDFMO" sweep "${MODELS[@]}" --depths "$dmin..$dmax" --size 1024 --threads "$THREADS" \
        --extra-rows "$OUT/results.json" -o "$OUT/combined.tmp" > /dev/null
    rm -rf "$OUT/combined"
    mv "$OUT/combined.tmp" "$OUT/combined"
fi
report_args=(--out "$OUT" --combined "$OUT/combined")
[ -n "${VDB_NO_DOCS:-}" ] || report_args+=(--docs "$ROOT/docs/results")
"$PY" "$HERE/report.py" "${report_args[@]}" "${MODELS[@]}"
log "done: $OUT/results.json"
