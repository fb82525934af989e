#!/usr/bin/env bash
# NGLOD on a CUDA machine, for a machine without Rust (the sdfmo CLI and wheel built elsewhere):
#   1. our GPU kernel's frame times on the same GPU (benches/gpu.sh, SDFMO prebuilt, multi,
#      depths 7-10: the octree side of NGLOD's like-for-like render time);
#   2. the paper schedule for every model at once (batched.py: one batched model, CUDA graphs),
#      seed 0 of every mesh plus extra seeds of one mesh (the variance rows), stopped at a
#      deadline if the budget runs out (recorded in each .train.json);
#   3. each trained model's LODs 2-5 x 4 paper views at 1024² rendered on the GPU and timed
#      (nglod.py render --device cuda), `sdfmo compare` against the mesh's references.
# Everything lands in OUTDIR as run.sh's layout (models/STEM/model.pt, images/, …) plus
# seeds/STEM-sK/, gpubench/ and logs, so that run.sh and report.py take it as it is.
#
#   gpu_batch.sh DEV OUTDIR BUDGET_S
#     DEV: a folder with `sdfmo` (the CLI), `sdf_multioctree-*.whl` (abi3) and `meshes/`
#     BUDGET_S: wall seconds the whole script may take (the training gets what is left after
#     the bench, less a reserve for the renders)
# Environment: NGLOD_MESHES (names in DEV/meshes, default abc1 abc3 abc5 abc8 teapot),
# NGLOD_SEED_MESH (default abc8), NGLOD_SEEDS (extra seeds, default "1 2"), NGLOD_RENDER_RESERVE_S
# (default 110), NGLOD_SCHEDULE_JSON (default the paper schedule of run.sh), NGLOD_DEVICE (default
# cuda; cpu to try the script on a small schedule), NGLOD_SIZE (render size, default 1024).
set -uo pipefail
HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
ROOT="$(cd "$HERE/../../.." && pwd)"
DEV="$(cd "$1" && pwd)"
OUTDIR="$2"
BUDGET="$3"
T0=$(date +%s)
mkdir -p "$OUTDIR"
OUTDIR="$(cd "$OUTDIR" && pwd)"
log() { echo "[gpu_batch +$(( $(date +%s) - T0 ))s] $*"; }
left() { echo $(( BUDGET - ($(date +%s) - T0) )); }

MESHES=${NGLOD_MESHES:-"abc1 abc3 abc5 abc8 teapot"}
SEED_MESH=${NGLOD_SEED_MESH:-abc8}
SEEDS=${NGLOD_SEEDS:-"1 2"}
RESERVE=${NGLOD_RENDER_RESERVE_S:-110}
SCHED=${NGLOD_SCHEDULE_JSON:-'{"name":"paper","epochs":250,"batch":512,"lr":0.001,"resample_every":1,"n_uniform":100000,"n_near":200000,"n_surface":200000,"near_sigma":0.01,"padding":0.1}'}
DEVICE=${NGLOD_DEVICE:-cuda}
SIZE=${NGLOD_SIZE:-1024}
THREADS=$(( $(nproc) > 2 ? $(nproc) - 2 : 1 ))
SDFMO="$DEV/sdfmo"
chmod +x "$SDFMO"
mesh_of() { for ext in stl obj glb; do [ -f "$DEV/meshes/$1.$ext" ] && { echo "$DEV/meshes/$1.$ext"; return; }; done; echo "no mesh $1" >&2; return 1; }

python3 -m pip install -q --no-index --no-deps --no-compile --target /tmp/sdfmo-site "$DEV"/sdf_multioctree-*.whl || exit 1
export PYTHONPATH=/tmp/sdfmo-site PYTHONUNBUFFERED=1
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; nproc; python3 -c 'import torch; print("torch", torch.__version__)'; } > "$OUTDIR/machine.txt" 2>&1
cat "$OUTDIR/machine.txt"

# --- 1. our kernel on this GPU ------------------------------------------------------------
[ "$DEVICE" = cpu ] && NGLOD_BENCH_DEPTHS=${NGLOD_BENCH_DEPTHS:-7}
mkdir -p "$OUTDIR/gpubench"
log "gpu.sh: multi, depths ${NGLOD_BENCH_DEPTHS:-9 10}, $MESHES"
# One small frame first, its stderr kept: says why if the adapter is missing.
"$SDFMO" build "$(mesh_of abc8)" -d 6 --method multi -o /tmp/probe.smo > /dev/null && \
    "$SDFMO" render /tmp/probe.smo --device gpu --size 64 -o /tmp/probe.png --json > "$OUTDIR/gpubench/probe.json" 2> "$OUTDIR/gpubench/probe.err"
echo "probe exit $?: $(head -c 300 "$OUTDIR/gpubench/probe.json") $(head -c 300 "$OUTDIR/gpubench/probe.err")"
MODELS="$MESHES" METHODS=multi DEPTHS="${NGLOD_BENCH_DEPTHS:-9 10}" SIZE="$SIZE" CPU=0 SDFMO="$SDFMO" DATA="$DEV/meshes" \
    OUT=/tmp/gpubench timeout 100 "$ROOT/benches/gpu.sh" > "$OUTDIR/gpubench/table.txt" 2> "$OUTDIR/gpubench/stderr.txt"
echo "gpu.sh exit $?" >> "$OUTDIR/gpubench/table.txt"
cp /tmp/gpubench/*.gpu.json "$OUTDIR/gpubench/" 2> /dev/null
cat "$OUTDIR/gpubench/table.txt"

# --- 2. training --------------------------------------------------------------------------
specs=()
refs=()
for m in $MESHES; do
    mesh=$(mesh_of "$m") || continue
    mkdir -p "$OUTDIR/models/$m"
    specs+=(--model "$mesh:0:$OUTDIR/models/$m/model")
    if [ "$m" = "$SEED_MESH" ]; then
        for s in $SEEDS; do
            mkdir -p "$OUTDIR/seeds/$m-s$s"
            specs+=(--model "$mesh:$s:$OUTDIR/seeds/$m-s$s/model")
        done
    fi
done
# The curve's references (view 0 at 256², as run.sh's ref256.png) and the 1024² paper views.
python3 - "$DEV/meshes" "$OUTDIR" $MESHES <<'PY'
import os, sys, sdfmo
dev, out = sys.argv[1:3]
for m in sys.argv[3:]:
    path = next(os.path.join(dev, m + e) for e in (".stl", ".obj", ".glb") if os.path.exists(os.path.join(dev, m + e)))
    mesh = sdfmo.Mesh.load(path)
    sdfmo.save_png(os.path.join(out, "models", m, "ref256.png"), mesh.render(256, view=0))
PY
for m in $MESHES; do
    refs+=("$OUTDIR/models/$m/model=$OUTDIR/models/$m/ref256.png")
    for s in $SEEDS; do [ "$m" = "$SEED_MESH" ] && refs+=("$OUTDIR/seeds/$m-s$s/model=$OUTDIR/models/$m/ref256.png"); done
    "$SDFMO" render-mesh "$(mesh_of "$m")" --views paper --size "$SIZE" --threads "$THREADS" -o "$OUTDIR/models/$m/reference.png" > /dev/null
done
deadline=$(( $(left) - RESERVE ))
log "training $(( ${#specs[@]} / 2 )) models, deadline ${deadline} s"
(cd "$HERE" && python3 batched.py "${specs[@]}" --schedule "$SCHED" --threads "$THREADS" --device "$DEVICE" \
    --deadline-s "$deadline" --curve-refs "$(IFS=,; echo "${refs[*]}")" --curve-every 50) 2>&1 | tee "$OUTDIR/train.log" | awk '!/^\[batched\] epoch/ || ($3 + 0) % 25 == 0 || ($3 + 0) <= 3'
log "training exit ${PIPESTATUS[0]}"

# --- 3. renders, timed, and compare -------------------------------------------------------
render_one() {  # model_dir mesh_name
    local dir=$1 m=$2
    [ -f "$dir/model.pt" ] || return
    (cd "$HERE" && python3 nglod.py render "$dir/model.pt" --out-dir "$dir/images" --threads "$THREADS" --device "$DEVICE" --size "$SIZE") \
        > "$dir/render.log" 2>&1 || { log "render failed: $dir"; tail -5 "$dir/render.log"; return; }
    for k in 2 3 4 5; do
        for v in 0 1 2 3; do
            "$SDFMO" compare "$OUTDIR/models/$m/reference_$v.png" "$dir/images/nglod_lod${k}_$v.png" --json \
                > "$dir/images/compare_lod${k}_$v.json"
        done
    done
    python3 -c "import json,sys; r=json.load(open(sys.argv[1])); print(sys.argv[2], {k: round(sum(v)/len(v)) for k, v in r['render_ms_views'].items()}, 'ms')" "$dir/images/render.json" "$dir"
}
for m in $MESHES; do
    [ "$(left)" -gt 25 ] || { log "no time left to render $m"; continue; }
    render_one "$OUTDIR/models/$m" "$m"
done
for s in $SEEDS; do
    [ "$(left)" -gt 25 ] || { log "no time left to render seed $s"; continue; }
    render_one "$OUTDIR/seeds/$SEED_MESH-s$s" "$SEED_MESH"
done
# --- 4. the short schedule's variance: three seeds of one mesh, if time is left ------------
SHORT='{"name":"short","epochs":12,"batch":2048,"lr":0.002,"resample_every":1,"n_uniform":20000,"n_near":40000,"n_surface":40000,"near_sigma":0.01,"padding":0.1}'
if [ "$(left)" -gt 70 ]; then
    sspecs=()
    for s in 0 $SEEDS; do
        mkdir -p "$OUTDIR/seeds-short/$SEED_MESH-s$s"
        sspecs+=(--model "$(mesh_of "$SEED_MESH"):$s:$OUTDIR/seeds-short/$SEED_MESH-s$s/model")
    done
    log "short schedule, $SEED_MESH seeds 0 $SEEDS"
    (cd "$HERE" && python3 batched.py "${sspecs[@]}" --schedule "$SHORT" --threads "$THREADS" --device "$DEVICE" \
        --deadline-s "$(( $(left) - 40 ))") > "$OUTDIR/train-short.log" 2>&1
    tail -2 "$OUTDIR/train-short.log"
    for s in 0 $SEEDS; do
        [ "$(left)" -gt 15 ] || { log "no time left to render short seed $s"; continue; }
        render_one "$OUTDIR/seeds-short/$SEED_MESH-s$s" "$SEED_MESH"
    done
fi
log "done"
