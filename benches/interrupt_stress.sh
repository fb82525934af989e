#!/usr/bin/env bash
# Interrupts `sdfmo sweep` N times (default 60) at a random 0–0.4 s after it starts writing,
# alternating SIGINT and SIGTERM, and counts the runs that leave a temporary file behind
# (`*.tmp`) and the runs that end otherwise than the CI test expects (exit 130 with the one
# line `sdfmo: interrupted`; a sweep that finished first, exit 0, is fine). The CI test
# `an_interrupt_leaves_no_temporary` does this twice at one fixed delay; this script hunts the
# race windows it can miss.
#
# Usage: benches/interrupt_stress.sh [PATH/TO/sdfmo] [N]   (default target/debug/sdfmo, 60)
set -u
bin=${1:-target/debug/sdfmo}
runs=${2:-60}
leftover_runs=0
wrong_exits=0
for i in $(seq 1 "$runs"); do
    dir=$(mktemp -d)
    "$bin" sweep --size 128 --depths 5..8 -o "$dir/sweep" > /dev/null 2> "$dir/stderr" &
    pid=$!
    while [ ! -e "$dir/sweep/images" ] && kill -0 "$pid" 2> /dev/null; do sleep 0.01; done
    sleep "$(python3 -c 'import random; print(random.uniform(0, 0.4))')"
    if [ $((i % 2)) = 0 ]; then signal=INT; else signal=TERM; fi
    kill -s "$signal" "$pid" 2> /dev/null
    wait "$pid"
    code=$?
    err=$(cat "$dir/stderr")
    if [ "$code" != 0 ] && { [ "$code" != 130 ] || [ "$err" != "sdfmo: interrupted" ]; }; then
        wrong_exits=$((wrong_exits + 1))
        echo "run $i (SIG$signal): exit $code: $err"
    fi
    left=$(find "$dir" -name '*.tmp')
    if [ -n "$left" ]; then
        leftover_runs=$((leftover_runs + 1))
        echo "run $i (SIG$signal): $left"
    fi
    rm -rf "$dir"
done
echo "runs=$runs with_leftovers=$leftover_runs wrong_exits=$wrong_exits"
[ "$leftover_runs" = 0 ] && [ "$wrong_exits" = 0 ]
