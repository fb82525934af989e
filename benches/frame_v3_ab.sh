#!/usr/bin/env bash
# CPU time per frame of two builds of the cpu_frame example on the 1.x and 3.1 files of the same
# octrees (one thread, 1024², lambert, paper views 0-3), interleaved: ROUNDS rounds, each view,
# each build, the four files in one process (median of 9 frames each, CPU time from schedstat);
# then per view the median over rounds, and 3.1 (after) against 1.x (before).
#
#   cargo build --release -p sdfmo-render --example cpu_frame   # the build after, and one before
#   sdfmo build ../shared/data/abc1.stl -d 9 --method multi -o DIR/abc1-d9.smo   # and abc5
#   target/release/examples/cpu_frame --write-v3 DIR DIR/abc1-d9.smo DIR/abc5-d9.smo
#   benches/frame_v3_ab.sh 5 BEFORE_CPU_FRAME AFTER_CPU_FRAME DIR
set -euo pipefail
R=$1; BEFORE=$2; AFTER=$3; DIR=$4
raw=$(mktemp)
trap 'rm -f "$raw"' EXIT
for r in $(seq "$R"); do
  for v in 0 1 2 3; do
    for b in before after; do
      bin=$BEFORE; [ "$b" = after ] && bin=$AFTER
      "$bin" --threads 1 --repeat 9 --size 1024 --view "$v" "$DIR/abc1-d9.smo" "$DIR/abc1-d9.v3.smo" \
        "$DIR/abc5-d9.smo" "$DIR/abc5-d9.v3.smo" | grep '\.smo' |
        awk -F'|' -v b="$b" -v v="$v" -v r="$r" '{gsub(/ /,"",$2); gsub(/ /,"",$6); print r, v, b, $2, $6}' >> "$raw"
    done
  done
  uptime | sed 's/^/load /' >> "$raw"
done
python3 - "$raw" <<'PY'
import collections, statistics as st, sys
d = collections.defaultdict(list)
loads = []
for line in open(sys.argv[1]):
    if line.startswith('load'):
        loads.append(line.split('load average:')[1].strip())
        continue
    r, v, b, f, c = line.split()
    d[(v, b, f.rsplit('/', 1)[-1])].append(float(c))
print('| model | view | 1.x before ms | 1.x after ms | 3.1 before ms | 3.1 after ms | 3.1 after ÷ 1.x before | 3.1 after ÷ 1.x after |')
print('|---|---:|---:|---:|---:|---:|---:|---:|')
for m in ('abc1', 'abc5'):
    for v in '0123':
        med = {(b, k): st.median(d[(v, b, f'{m}-d9{k}.smo')]) for b in ('before', 'after') for k in ('', '.v3')}
        b1, a1, b3, a3 = med[('before', '')], med[('after', '')], med[('before', '.v3')], med[('after', '.v3')]
        print(f'| {m} | {v} | {b1:.1f} | {a1:.1f} | {b3:.1f} | {a3:.1f} | {a3 / b1:.3f} | {a3 / a1:.3f} |')
print()
print('load averages after each round: ' + '; '.join(loads))
PY
