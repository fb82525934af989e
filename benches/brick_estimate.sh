#!/usr/bin/env bash
# Traced bytes per voxel of the brick layout (docs/format-3.md): estimated from today's files
# and measured on their 3.1 encoding (checked lossless; the 3.0 file's size in the last two
# columns), the five shared models at depths 8-10, both methods, built by the release CLI, then
# counted by sdfmo-format's brick_estimate example; also the compressed container over the 3.1
# and 1.x files (zstd 9) and its single-threaded decode speed of the 3.1 file (the only timing: median and best of 7; under
# other load both are lower bounds). Tables: python3 benches/compressed_table.py --v3.
#
#   benches/brick_estimate.sh > docs/results/format/brick-estimate.csv
#   DEPTHS="6 7" benches/brick_estimate.sh > docs/results/format/brick-estimate-d6-7.csv
#
# (the shallow depths are for the PSNR-against-bytes plots of docs/results/openvdb.md, which
# span depths 6-10.)
set -euo pipefail
DEPTHS=${DEPTHS:-8 9 10}
DATA=${SDFMO_TEST_DATA:-../shared/data}
cd "$(dirname "$0")/.."
cargo build --release -q -p sdfmo-cli
cargo build --release -q -p sdfmo-format --example brick_estimate
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
files=()
for model in abc1.stl abc3.stl abc5.stl abc8.stl teapot.obj; do
  for method in svo multi; do
    for depth in $DEPTHS; do
      out="$tmp/${model%.*}-$method-$depth.smo"
      target/release/sdfmo build "$DATA/$model" -d "$depth" --method "$method" -o "$out" > /dev/null 2>&1
      files+=("$out")
    done
  done
done
target/release/examples/brick_estimate "${files[@]}"
