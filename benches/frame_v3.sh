#!/usr/bin/env bash
# Format 3.0 traced in place against its 1.x file: CPU time per frame on one thread, abc1 and
# abc5 at depth 9 (multi), the paper's views 0-3 at 1024², lambert, the two files interleaved
# round by round (the cpu_frame example: median of 5 runs, CPU time from schedstat).
#
#   benches/frame_v3.sh   (two builds side by side: benches/frame_v3_ab.sh)
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${SDFMO_TEST_DATA:-../shared/data}
cargo build --release -q -p sdfmo-cli
cargo build --release -q -p sdfmo-render --example cpu_frame
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
for m in abc1 abc5; do
  target/release/sdfmo build "$DATA/$m.stl" -d 9 --method multi -o "$dir/$m-d9.smo" > /dev/null
done
target/release/examples/cpu_frame --write-v3 "$dir" "$dir/abc1-d9.smo" "$dir/abc5-d9.smo" > /dev/null
for m in abc1 abc5; do
  for v in 0 1 2 3; do
    echo "== $m view $v"
    target/release/examples/cpu_frame --threads 1 --repeat 5 --size 1024 --view "$v" \
      "$dir/$m-d9.smo" "$dir/$m-d9.v3.smo" | sed "s#$dir/##"
  done
done
