#!/usr/bin/env bash
# Instructions per frame (callgrind: a run of 2 frames minus a run of 1, so loading and set-up
# cancel) of the cpu_frame example on each file given: one thread, 1024², paper view VIEW
# (default 0). Deterministic, so it compares two layouts or two builds on a busy machine.
#
#   cargo build --release -p sdfmo-render --example cpu_frame
#   VIEW=0 benches/frame_v3_icount.sh abc5-d9.smo abc5-d9.v3.smo
# (docs/results/format/frame-v31-instructions.txt: views 0-3 of abc1/abc5 depth-9 multi,
# the 3.0 files written by `cpu_frame --write-v3 DIR FILE`.)
set -euo pipefail
BIN=${BIN:-$(dirname "$0")/../target/release/examples/cpu_frame}
log=$(mktemp)
trap 'rm -f "$log"' EXIT
for f in "$@"; do
  for r in 1 2; do
    valgrind --tool=callgrind --callgrind-out-file=/dev/null "$BIN" --threads 1 --repeat "$r" \
      --size 1024 --view "${VIEW:-0}" "$f" > /dev/null 2> "$log"
    n=$(grep -o 'Collected : [0-9]*' "$log" | grep -o '[0-9]*')
    if [ "$r" = 1 ]; then c1=$n; else c2=$n; fi
  done
  echo "$f $((c2 - c1))"
done
