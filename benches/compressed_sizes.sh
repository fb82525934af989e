#!/usr/bin/env bash
# Bytes per voxel of the compressed container on the shared models (docs/results/format.md,
# "Compressed files"): every model at depths 8-10, both methods, plus a file with levels 6-10,
# built by the release CLI with --compress=LEVEL, the sizes read from --json. Sizes are exact and
# deterministic (no timing here).
#
#   benches/compressed_sizes.sh [LEVEL] > docs/results/format/compressed.csv
set -euo pipefail
LEVEL=${1:-9}
DATA=${SDFMO_TEST_DATA:-../shared/data}
cd "$(dirname "$0")/.."
cargo build --release -q -p sdfmo-cli
SDFMO=target/release/sdfmo
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "model,method,depth,levels,voxels,traced_bytes,compressed_bytes,zstd_level"
for model in abc1.stl abc3.stl abc5.stl abc8.stl teapot.obj; do
  for method in svo multi; do
    for depth in 8 9 10; do
      "$SDFMO" build "$DATA/$model" -d "$depth" --method "$method" -o "$tmp/x.smo" \
        --compress="$LEVEL" --json > "$tmp/x.json" 2> /dev/null
      python3 - "$tmp/x.json" "${model%.*}" "$method" "$depth" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print(f"{sys.argv[2]},{sys.argv[3]},{sys.argv[4]},{sys.argv[4]},{j['voxels']},{j['bytes']},{j['stored_bytes']},{j['compress_level']}")
PY
    done
  done
  "$SDFMO" build "$DATA/$model" -d 10 --lod --coarsest 6 -o "$tmp/x.smo" \
    --compress="$LEVEL" --json > "$tmp/x.json" 2> /dev/null
  python3 - "$tmp/x.json" "${model%.*}" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
v = sum(l['voxels'] for l in j['levels'])
print(f"{sys.argv[2]},multi,10,6-10,{v},{j['bytes']},{j['stored_bytes']},{j['compress_level']}")
PY
done
