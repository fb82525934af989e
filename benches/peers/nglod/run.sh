#!/usr/bin/env bash
# NGLOD peer (issue 22) on the CPU: venv, training, rendering, evaluation, results.json, a run page
# (docs/results/nglod-short.md or nglod-paper.md). The reference page docs/results/nglod.md is
# page.py's, from the GPU runs of gpu_batch.sh (README.md).
#
#   benches/peers/nglod/run.sh MODEL...        e.g. ../shared/data/abc8.stl ../shared/data/teapot.obj
#
# Environment (all optional):
#   NGLOD_SCHEDULE   short (default) | paper | a JSON object with the keys of the schedules below
#   NGLOD_THREADS    torch and sdfmo threads (default 2)
#   NGLOD_NICE       nice level of every heavy step (default 19: the machine is shared)
#   NGLOD_OUT        output folder (default benches/peers/nglod/out, gitignored)
#   NGLOD_CURVE      model stem whose training curve (PSNR per epoch) is recorded (default: the first)
#   NGLOD_CURVE_EVERY  epochs between curve points (default 2; 10 for the paper schedule)
#   NGLOD_RERUN_SWEEP=1  rerun `sdfmo sweep` even when OUT/sweep/results.json covers the models
#   NGLOD_RETRAIN=1  retrain models that already have OUT/models/STEM/model.pt
#   NGLOD_NO_DOCS=1  do not rewrite the page under docs/results (NGLOD_DOC below)
#   NGLOD_GAP_EPOCHS  train the curve model a second time for this many epochs of the same
#                    schedule (default 120; 0: not), recording its curve: how far the schedule is
#                    from converged, for the "gap to the full schedule" section (default 0 for
#                    the paper schedule: it is the full schedule)
#   NGLOD_DOC        name of the page written under docs/results (default nglod for the short
#                    schedule, nglod-paper for the paper's, nglod-custom otherwise)
#   NGLOD_COMPARE_WITH  results.json of an earlier run whose NGLOD rows the page compares with
#                    (default docs/results/nglod-short/results.json when NGLOD_DOC is not nglod-short)
# Needs: python3 (>= 3.9) with venv, cargo (the sdfmo CLI and the sdfmo wheel are built here).
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
. "$HERE/../models.sh"
peer_start "$@"

THREADS="${NGLOD_THREADS:-2}"
NICE="${NGLOD_NICE:-19}"
OUT="${NGLOD_OUT:-$HERE/out}"
SCHED_NAME="${NGLOD_SCHEDULE:-short}"
# The schedules. "paper": NGLOD's published training recipe as we read it (250 epochs, batch
# 512, Adam lr 1e-3, 500k fresh samples per epoch: 100k uniform, 200k near, 200k on the
# surface). "short": what fits this session on a shared 2-core machine (docs/results/nglod-short.md).
PAPER_SCHED='{"name":"paper","epochs":250,"batch":512,"lr":0.001,"resample_every":1,"n_uniform":100000,"n_near":200000,"n_surface":200000,"near_sigma":0.01,"padding":0.1}'
case "$SCHED_NAME" in
    paper) SCHED="$PAPER_SCHED" ;;
    short) SCHED='{"name":"short","epochs":12,"batch":2048,"lr":0.002,"resample_every":1,"n_uniform":20000,"n_near":40000,"n_surface":40000,"near_sigma":0.01,"padding":0.1}' ;;
    \{*) SCHED="$SCHED_NAME" ;;
    *) echo "run.sh: NGLOD_SCHEDULE must be short, paper or a JSON object, got '$SCHED_NAME'" >&2; exit 2 ;;
esac
case "$SCHED_NAME" in
    short) DOC_DEFAULT=nglod-short; CURVE_EVERY_DEFAULT=2; GAP_DEFAULT=120 ;;
    paper) DOC_DEFAULT=nglod-paper; CURVE_EVERY_DEFAULT=10; GAP_DEFAULT=0 ;;
    *) DOC_DEFAULT=nglod-custom; CURVE_EVERY_DEFAULT=2; GAP_DEFAULT=0 ;;
esac
CURVE_EVERY="${NGLOD_CURVE_EVERY:-$CURVE_EVERY_DEFAULT}"
DOC="${NGLOD_DOC:-$DOC_DEFAULT}"
COMPARE_WITH="${NGLOD_COMPARE_WITH:-}"
if [ -z "$COMPARE_WITH" ] && [ "$DOC" != nglod-short ] && [ -f "$ROOT/docs/results/nglod-short/results.json" ]; then
    COMPARE_WITH="$ROOT/docs/results/nglod-short/results.json"
fi

mkdir -p "$OUT"
log() { echo "[nglod $(date -u +%H:%M:%S)] $*" >&2; }

# --- tools: the sdfmo CLI (release) and a venv with torch and the sdfmo wheel -----------------
TARGET="${CARGO_TARGET_DIR:-$ROOT/target}"
log "building the sdfmo CLI (release)"
nice -n "$NICE" cargo build --release -q -p sdfmo-cli
SDFMO="$TARGET/release/sdfmo"

VENV="$HERE/.venv"
PY="$VENV/bin/python"
if [ ! -x "$PY" ]; then
    log "creating $VENV"
    python3 -m venv "$VENV"
fi
if ! "$PY" -c 'import torch, numpy, matplotlib' 2> /dev/null; then
    log "installing $HERE/requirements.txt (torch from PyPI: its CUDA libraries come along, ~5 GB)"
    "$PY" -m pip install -q --disable-pip-version-check -r "$HERE/requirements.txt"
fi
if ! "$PY" -c 'import sdfmo' 2> /dev/null || [ -n "${NGLOD_REBUILD_WHEEL:-}" ]; then
    log "building the sdfmo wheel (release)"
    WHEELS="$OUT/wheels"
    rm -rf "$WHEELS"
    nice -n "$NICE" "$VENV/bin/maturin" build --release -q -m crates/sdfmo-py/Cargo.toml -o "$WHEELS"
    "$PY" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps "$WHEELS"/sdf_multioctree-*.whl
fi

# --- the octree side: sdfmo sweep at depths 7-10, same protocol (also gives the references) --
SWEEP="$OUT/sweep"
need_sweep=1
if [ -f "$SWEEP/results.json" ] && [ -z "${NGLOD_RERUN_SWEEP:-}" ]; then
    if "$PY" - "$SWEEP/results.json" "${MODELS[@]}" <<'PYEOF'
import json, os, sys
d = json.load(open(sys.argv[1]))
have = {m["source"] for m in d["models"]}
ok = all(os.path.abspath(m) in have for m in sys.argv[2:]) and set(d["settings"]["depths"]) >= {7, 8, 9, 10} \
    and d["settings"]["size"] == 1024
sys.exit(0 if ok else 1)
PYEOF
    then need_sweep=0; log "reusing $SWEEP (covers the models; NGLOD_RERUN_SWEEP=1 to rerun)"; fi
fi
if [ "$need_sweep" = 1 ]; then
    log "sdfmo sweep (depths 7..10, 1024², $THREADS threads)"
    rm -rf "$SWEEP.tmp"
    nice -n "$NICE" "$SDFMO" sweep "${MODELS[@]}" --depths 7..10 --size 1024 --threads "$THREADS" -o "$SWEEP.tmp"
    rm -rf "$SWEEP"
    mv "$SWEEP.tmp" "$SWEEP"
fi

# --- NGLOD per model -------------------------------------------------------------------------
CURVE="${NGLOD_CURVE:-}"
declare -A MESH_OF
for m in "${MODELS[@]}"; do
    stem="$(basename "${m%.*}" | tr -c 'A-Za-z0-9_.\n-' '_')"
    MESH_OF["$stem"]="$m"
    [ -n "$CURVE" ] || CURVE="$stem"
    dir="$OUT/models/$stem"
    mkdir -p "$dir"
    ref="$SWEEP/images/$stem"
    [ -f "$ref/reference_0.png" ] || { echo "run.sh: no reference images in $ref" >&2; exit 1; }
    if [ ! -f "$dir/model.pt" ] || [ -n "${NGLOD_RETRAIN:-}" ] || ! "$PY" -c "import json,sys; sys.exit(0 if json.load(open('$dir/model.train.json'))['schedule']==json.loads(sys.argv[1]) else 1)" "$SCHED"; then
        curve_args=()
        if [ "$stem" = "$CURVE" ]; then
            nice -n "$NICE" "$SDFMO" render-mesh "$m" -o "$dir/ref256.png" --size 256 --threads "$THREADS" > /dev/null
            curve_args=(--curve-ref "$dir/ref256.png" --curve-every "$CURVE_EVERY")
        fi
        log "$stem: training ($(echo "$SCHED" | tr -d ' '))"
        nice -n "$NICE" "$PY" "$HERE/nglod.py" train "$m" --out "$dir/model" --schedule "$SCHED" \
            --threads "$THREADS" "${curve_args[@]}"
    fi
    if [ ! -f "$dir/images/render.json" ] || [ "$dir/images/render.json" -ot "$dir/model.pt" ] || [ -n "${NGLOD_RERENDER:-}" ]; then
        log "$stem: rendering LODs 2-5, 4 views, 1024²"
        rm -f "$dir/images/render.json"
        nice -n "$NICE" "$PY" "$HERE/nglod.py" render "$dir/model.pt" --out-dir "$dir/images" --threads "$THREADS"
        log "$stem: comparing with the mesh references"
        for k in 2 3 4 5; do
            for v in 0 1 2 3; do
                nice -n "$NICE" "$SDFMO" compare "$ref/reference_$v.png" "$dir/images/nglod_lod${k}_$v.png" --json \
                    > "$dir/images/compare_lod${k}_$v.json.tmp"
                mv "$dir/images/compare_lod${k}_$v.json.tmp" "$dir/images/compare_lod${k}_$v.json"
            done
        done
    else
        log "$stem: reusing the renders in $dir/images (newer than the model; NGLOD_RERENDER=1 to redo)"
    fi
    if [ "$stem" = "$CURVE" ] && [ ! -f "$dir/paper_cost.json" ]; then
        log "$stem: timing the paper schedule's epoch (sampling + 30 steps at batch 512)"
        nice -n "$NICE" "$PY" "$HERE/nglod.py" timepaper "$m" --schedule "$PAPER_SCHED" --out "$dir/paper_cost.json" --threads "$THREADS"
    fi
    if [ "$stem" = "$CURVE" ] && { [ ! -f "$dir/timing.json" ] || [ "$dir/timing.json" -ot "$dir/model.pt" ]; }; then
        log "$stem: interleaved render timing, view 0 (NGLOD LOD k, SVO and multi-octree at depth k + 5)"
        nice -n "$NICE" "$PY" "$HERE/nglod.py" timing "$m" "$dir/model.pt" --reps "${NGLOD_TIMING_REPS:-2}" \
            --out "$dir/timing.json" --threads "$THREADS"
    fi
    log "$stem: SDF check on held-out points"
    [ -f "$dir/sdfcheck.json" ] && [ "$dir/sdfcheck.json" -nt "$dir/model.pt" ] || nice -n "$NICE" "$PY" "$HERE/nglod.py" sdfcheck "$m" "$dir/model.pt" --schedule "$SCHED" --out "$dir/sdfcheck.json" \
        --threads "$THREADS"
done

# --- the gap to the full schedule: the curve model trained longer, its curve only ---------
GAP_EPOCHS="${NGLOD_GAP_EPOCHS:-$GAP_DEFAULT}"
if [ "$GAP_EPOCHS" -gt 0 ] && [ -n "${MESH_OF[$CURVE]:-}" ]; then
    gdir="$OUT/models/$CURVE"
    GAP_SCHED="$("$PY" -c "import json,sys; s=json.loads(sys.argv[1]); s['epochs']=int(sys.argv[2]); s['name']+='-x'+str(round(int(sys.argv[2])/max(1,json.loads(sys.argv[1])['epochs']))); print(json.dumps(s))" "$SCHED" "$GAP_EPOCHS")"
    if [ ! -f "$gdir/gap.train.json" ] || ! "$PY" -c "import json,sys; sys.exit(0 if json.load(open('$gdir/gap.train.json'))['schedule']==json.loads(sys.argv[1]) else 1)" "$GAP_SCHED"; then
        [ -f "$gdir/ref256.png" ] || nice -n "$NICE" "$SDFMO" render-mesh "${MESH_OF[$CURVE]}" -o "$gdir/ref256.png" --size 256 --threads "$THREADS" > /dev/null
        log "$CURVE: the gap run, $GAP_EPOCHS epochs of the same schedule (curve only)"
        nice -n "$NICE" "$PY" "$HERE/nglod.py" train "${MESH_OF[$CURVE]}" --out "$gdir/gap" \
            --schedule "$GAP_SCHED" --threads "$THREADS" --curve-ref "$gdir/ref256.png" \
            --curve-every "$(( GAP_EPOCHS / 12 > 0 ? GAP_EPOCHS / 12 : 1 ))"
        rm -f "$gdir/gap.pt"
    fi
fi

# --- results.json (sweep row schema), the combined sweep, docs ------------------------------
log "writing $OUT/results.json and the report"
report_args=(--out "$OUT" --sweep "$SWEEP" --curve "$CURVE" --doc "$DOC")
[ -z "$COMPARE_WITH" ] || report_args+=(--compare-with "$COMPARE_WITH")
[ -n "${NGLOD_NO_DOCS:-}" ] || report_args+=(--docs "$ROOT/docs/results")
if "$SDFMO" sweep --help | grep -q -- '--extra-rows'; then
    rm -rf "$OUT/combined.tmp"
    log "sdfmo sweep --extra-rows (combined SVO / multi / NGLOD table and plots)"
    "$PY" "$HERE/report.py" "${report_args[@]}" --rows-only
    nice -n "$NICE" "$SDFMO" sweep "${MODELS[@]}" --depths 7..10 --size 1024 --threads "$THREADS" \
        --extra-rows "$OUT/results.json" -o "$OUT/combined.tmp"
    rm -rf "$OUT/combined"
    mv "$OUT/combined.tmp" "$OUT/combined"
    report_args+=(--combined "$OUT/combined")
fi
"$PY" "$HERE/report.py" "${report_args[@]}"
log "done: $OUT/results.json"
