#!/usr/bin/env bash
# Builds side by side (issue 35): our abc1 multi-octree build against OpenVDB's meshToLevelSet
# (narrow bands 1 and 3) at the same resolution, 2 threads, depths 9 and 10, ROUNDS interleaved
# rounds (who goes first alternates). Run it on a quiet machine after setup.sh and a release
# build of the CLI; CSV on stdout (build_ms as each tool reports it, process CPU seconds, load):
#
#   benches/peers/openvdb/build_side_by_side.sh > docs/results/build/openvdb-side-by-side.csv
set -euo pipefail
cd "$(dirname "$0")/../../.."
SDFMO=target/release/sdfmo
VDB=benches/peers/openvdb/build/vdbpeer
MESH=${SDFMO_TEST_DATA:-../shared/data}/abc1.stl
ROUNDS=${ROUNDS:-5}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# row ROUND DEPTH WHO JSON: one CSV row from a tool's JSON and the CPU time /usr/bin/time wrote.
row() {
  local ms cpu
  ms=$(python3 -c 'import json, sys; print(json.loads(sys.argv[1])["build_ms"])' "$4")
  cpu=$(awk '{print $1 + $2}' "$work/time")
  echo "$1,$2,$3,$ms,$cpu,$(cut -d' ' -f1 /proc/loadavg)"
}
ours() {
  row "$1" "$2" ours "$(/usr/bin/time -f '%U %S' -o "$work/time" "$SDFMO" build "$MESH" -d "$2" \
    --method multi --threads 2 -o "$work/x.smo" --json)"
}
theirs() {
  row "$1" "$2" "vdb_band$3" "$(/usr/bin/time -f '%U %S' -o "$work/time" "$VDB" build "$MESH" \
    --depth "$2" --band "$3" --out "$work" --threads 2)"
}

echo "round,depth,who,build_ms,process_cpu_s,load1"
for r in $(seq 1 "$ROUNDS"); do
  for d in 9 10; do
    if [ $((r % 2)) = 1 ]; then
      ours "$r" "$d"; theirs "$r" "$d" 1; theirs "$r" "$d" 3
    else
      theirs "$r" "$d" 3; theirs "$r" "$d" 1; ours "$r" "$d"
    fi
  done
done
