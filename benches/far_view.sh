#!/usr/bin/env bash
# Far view against full depth (issue 35): `sdfmo render FILE --eye 0,0,12 --pixel-error 1`
# against the same render at full depth, one thread, 1024², `render_ms` (the median of FRAMES (default 5) frames
# each), ROUNDS interleaved rounds of every binary given; prints each binary's medians and the
# ratio pixel error ÷ full depth.
#
#   benches/far_view.sh ROUNDS FILE.smo BINARY [BINARY...]
#
# FILE is a file with levels (e.g. `sdfmo build abc5 --depth 10 --levels 6..10`).
set -euo pipefail
rounds=$1 file=$2
shift 2
declare -A times
for ((r = 0; r < rounds; r++)); do
    for bin in "$@"; do
        for pe in full pe; do
            extra=()
            [ "$pe" = pe ] && extra=(--pixel-error 1)
            ms=$("$bin" render "$file" --eye 0,0,12 --target 0,0,0 --normalized --fov 60 \
                --threads 1 "${extra[@]}" --frames "${FRAMES:-5}" --json -o /tmp/far_view_$$.png |
                python3 -c 'import json,sys; print(json.load(sys.stdin)["render_ms"])')
            times["$bin $pe"]+="$ms "
        done
    done
done
rm -f /tmp/far_view_$$.png
for bin in "$@"; do
    python3 - "$bin" "${times["$bin full"]}" "${times["$bin pe"]}" <<'PY'
import statistics, sys
bin, full, pe = sys.argv[1], [float(x) for x in sys.argv[2].split()], [float(x) for x in sys.argv[3].split()]
f, p = statistics.median(full), statistics.median(pe)
print(f"{bin}: full {f:.3f} ms ({min(full):.3f}-{max(full):.3f}), pixel error {p:.3f} ms ({min(pe):.3f}-{max(pe):.3f}): {p / f:.3f}x")
PY
done
