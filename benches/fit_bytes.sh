#!/usr/bin/env bash
# Format 3.1 bytes of the exact and the fitted octree (`sdfmo build --format 3` with and without
# `--fit-corners`), the five shared models, depths 8–10, both methods; one line each:
# `model method depth exact_bytes voxels fitted_bytes`. Sizes are deterministic.
#
#   benches/fit_bytes.sh [SDFMO] > docs/results/sweep/fit-corners-bytes.txt
set -euo pipefail
sdfmo=${1:-target/release/sdfmo}
data=${SDFMO_TEST_DATA:-../shared/data}
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
field() { python3 -c "import json,sys; j=json.load(sys.stdin); print(*(j[k] for k in sys.argv[1:]))" "$@"; }
for mesh in abc1.stl abc3.stl abc5.stl abc8.stl teapot.obj; do
    for method in svo multi; do
        for depth in 8 9 10; do
            exact=$("$sdfmo" build "$data/$mesh" -d "$depth" --method "$method" --format 3 \
                -o "$out/e.smo" --json | field file_bytes voxels)
            fitted=$("$sdfmo" build "$data/$mesh" -d "$depth" --method "$method" --format 3 \
                --fit-corners -o "$out/f.smo" --json | field file_bytes)
            echo "${mesh%.*} $method $depth $exact $fitted"
        done
    done
done
