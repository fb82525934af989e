#!/usr/bin/env bash
# CPU frame time against Embree, interleaved (issue 13, CPU half; docs/results/render.md).
#
#   benches/cpu_vs_embree.sh ROUNDS BEFORE_CPU_FRAME AFTER_CPU_FRAME ABC1.smo ABC5.smo
#
# Each round runs the `cpu_frame` example of two builds (paper view 0, 1024², lambert, pools of 1
# and 2 threads, 5 renders each) and then Embree (benches/peers/embree_primary.py, its own
# virtualenv benches/.venv-embree, see the script) on the same rays, so that all three see the
# same load; it prints per configuration the median over rounds of the per-round medians of the
# process CPU time per frame, the busiest thread's CPU time and the wall time.
set -euo pipefail
R=$1; OLD=$2; NEW=$3; A1=$4; A5=$5
DATA=${SDFMO_TEST_DATA:-../shared/data}
HERE=$(cd "$(dirname "$0")" && pwd)
raw=$(mktemp)
for _ in $(seq "$R"); do
  "$OLD" --repeat 5 "$A1" "$A5" | grep '\.smo' | sed 's/^/before /' >> "$raw"
  "$NEW" --repeat 5 "$A1" "$A5" | grep '\.smo' | sed 's/^/after /' >> "$raw"
  "$HERE/.venv-embree/bin/python" "$HERE/peers/embree_primary.py" "$DATA/abc1.stl" "$DATA/abc5.stl" \
    --repeat 5 --json | sed 's/^/embree /' >> "$raw"
  uptime | sed 's/^/load /' >> "$raw"
done
python3 - "$raw" <<'PY'
import collections, json, statistics as st, sys
d = collections.defaultdict(lambda: {'w': [], 'c': [], 'b': []})
loads = []
for line in open(sys.argv[1]):
    tag, rest = line.split(' ', 1)
    if tag == 'embree':
        for r in json.loads(rest):
            k = ('embree', r['mesh'], '1')
            d[k]['w'].append(r['median_ms']); d[k]['c'].append(r['cpu_median_ms'])
    elif tag == 'load':
        loads.append(rest.split('load average:')[1].strip())
    else:
        w = rest.split('|')
        k = (tag, w[1].strip().split('/')[-1].split('_')[0], w[2].strip())
        d[k]['w'].append(float(w[4])); d[k]['c'].append(float(w[5])); d[k]['b'].append(float(w[6]))
print('| build | mesh | threads | CPU ms / frame (median; per round) | busiest thread ms | wall ms (median) |')
print('|---|---|---|---|---|---|')
for k in sorted(d):
    v = d[k]
    b = '%.1f' % st.median(v['b']) if v['b'] else '—'
    print('| %s | %s | %s | %.1f (%s) | %s | %.1f |' % (*k, st.median(v['c']), ' '.join('%.1f' % x for x in v['c']), b, st.median(v['w'])))
print('load averages:', '; '.join(loads))
PY
rm -f "$raw"
