#!/usr/bin/env bash
# GPU timing: builds octrees, renders the paper views on the GPU (`sdfmo render --device gpu`),
# prints per-frame kernel times and rays/s, with the CPU renderer's time on the same views.
#
#   benches/gpu.sh                     # abc1 abc5 teapot, svo and multi, depths 7-10, 1024²
#   MODELS="abc5" DEPTHS="9" benches/gpu.sh
#
# Environment: MODELS (names in $DATA without extension, or "demo"), METHODS, DEPTHS, SIZE
# (image side), PROFILE (cargo profile of the sdfmo binary: release by default; `debug` builds
# octrees more slowly but renders on the GPU in the same time), DATA (the shared meshes,
# ../shared/data), OUT (where octrees and images go; a temporary directory by default),
# SDFMO (a prebuilt sdfmo binary: no cargo build, for a machine without Rust), CPU (0: skip the
# CPU renderer's column),
# WGPU_ADAPTER_NAME / WGPU_BACKEND (pick the adapter, as wgpu's examples do).
#
# Runs unchanged on Mesa's software Vulkan (lavapipe) and on a real GPU (Vulkan, Metal, DX12).
# Each configuration's paper views are rendered twice (two runs of `sdfmo render`) and the
# second run is reported, so the driver's shader cache and clock ramp-up stay out of the
# numbers; device creation and shader compilation are never in them. Kernel times come from timestamp queries where the adapter has them (the JSON's
# gpu_timing says which), else from wall time around the submission.
set -euo pipefail
cd "$(dirname "$0")/.."

MODELS=${MODELS:-"abc1 abc5 teapot"}
METHODS=${METHODS:-"svo multi"}
DEPTHS=${DEPTHS:-"7 8 9 10"}
SIZE=${SIZE:-1024}
PROFILE=${PROFILE:-release}
DATA=${DATA:-../shared/data}
OUT=${OUT:-$(mktemp -d)}
mkdir -p "$OUT"

CPU=${CPU:-1}
if [ -n "${SDFMO:-}" ]; then
    BIN=$SDFMO
elif [ "$PROFILE" = release ]; then
    cargo build --release -p sdfmo-cli >&2
    BIN=target/release/sdfmo
else
    cargo build -p sdfmo-cli >&2
    BIN=target/debug/sdfmo
fi

mesh_of() {
    if [ "$1" = demo ]; then return; fi
    for ext in stl obj glb; do
        if [ -f "$DATA/$1.$ext" ]; then echo "$DATA/$1.$ext"; return; fi
    done
    echo "no mesh $1 in $DATA" >&2
    exit 1
}

printf '%-8s %-6s %5s %9s %11s %11s %11s %12s %11s  %s\n' \
    model method depth MB gpu_ms_min gpu_ms_med frame_ms Mrays/s cpu_ms timing
for model in $MODELS; do
    mesh=$(mesh_of "$model")
    for method in $METHODS; do
        for depth in $DEPTHS; do
            smo="$OUT/$model-$method-d$depth.smo"
            # shellcheck disable=SC2086
            $BIN build $mesh -d "$depth" --method "$method" -o "$smo" --json > "$OUT/build.json"
            # The first run warms up; the second is reported (min and median over the views).
            for pass in 1 2; do
                $BIN render "$smo" --device gpu --views paper --size "$SIZE" --mode lambert \
                    -o "$OUT/gpu.png" --json 2>/dev/null > "$OUT/gpu.json"
            done
            cp "$OUT/gpu.json" "$OUT/$model-$method-d$depth.gpu.json"
            if [ "$CPU" = 1 ]; then
                $BIN render "$smo" --device cpu --views paper --size "$SIZE" --mode lambert \
                    -o "$OUT/cpu.png" --json > "$OUT/cpu.json"
            else
                echo '{"render_ms": NaN, "views": [0]}' > "$OUT/cpu.json"
            fi
            python3 - "$OUT" "$model" "$method" "$depth" "$SIZE" <<'PY'
import json, os, statistics, sys
out, model, method, depth, size = sys.argv[1:]
g = json.load(open(os.path.join(out, "gpu.json")))
c = json.load(open(os.path.join(out, "cpu.json")))
b = json.load(open(os.path.join(out, "build.json")))
ms = [v["gpu_ms"] for v in g["views"]]
frame = [v["render_ms"] for v in g["views"]]
rays = int(size) ** 2
mb = os.path.getsize(os.path.join(out, f"{model}-{method}-d{depth}.smo")) / 1e6
print(f"{model:<8} {method:<6} {depth:>5} {mb:9.2f} {min(ms):11.2f} {statistics.median(ms):11.2f} "
      f"{statistics.median(frame):11.2f} {rays / statistics.median(ms) / 1e3:12.1f} "
      f"{c['render_ms'] / len(c['views']):11.2f}  {g['gpu_timing']} on {g['device']}")
PY
        done
    done
done
echo "octrees and last images in $OUT" >&2
