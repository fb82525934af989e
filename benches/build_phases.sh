#!/usr/bin/env bash
# Instructions per build phase of one `sdfmo build` (docs/results/build.md): callgrind dumps its
# counters at each phase boundary, one thread, release CLI. Counts, not times: usable on a
# loaded machine.
#
#   benches/build_phases.sh ../shared/data/abc1.stl -d 9 --method multi
#
# Prints one line per phase: instructions (Ir) and name. The boundaries are functions:
# normalize ends where MeshDistance::new starts, distance where it returns (the winding sign's
# per-leaf data is made later, by the corners that need it), subdivide after subdivide(), corners where the multi-octree's Components::new starts (an SVO build reports
# corners and leaves as one), leaves where the packing starts; pack includes writing the file.
set -euo pipefail
cd "$(dirname "$0")/.."
SDFMO=${SDFMO:-target/release/sdfmo}
[ -n "${SDFMO_NO_BUILD:-}" ] || cargo build --release -q -p sdfmo-cli
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
valgrind --tool=callgrind --callgrind-out-file="$tmp/cg" --dump-instr=no \
    '--dump-before=sdfmo_distance::MeshDistance::new' \
    '--dump-after=sdfmo_distance::MeshDistance::new' \
    '--dump-after=sdfmo_build::subdivide::subdivide' \
    '--dump-before=sdfmo_build::components::Components::new' \
    '--dump-before=sdfmo_format::octree::Octree::from_leaves' \
    "$SDFMO" build "$@" --threads 1 -o "$tmp/out.smo" > /dev/null 2> "$tmp/log"
# Dumps are numbered in order (cg.1, cg.2, ...), the last one (cg) at exit; each holds the
# counts since the previous one, so its trigger names the boundary that ends its phase.
python3 - "$tmp" <<'PY'
import glob, os, re, sys
tmp = sys.argv[1]
files = sorted(glob.glob(os.path.join(tmp, "cg.*")), key=lambda f: int(f.rsplit(".", 1)[1]))
files.append(os.path.join(tmp, "cg"))
name = {"before=sdfmo_distance::MeshDistance::new": "normalize", "after=sdfmo_distance::MeshDistance::new": "distance",
        "subdivide::subdivide": "subdivide", "Components::new": "corners", "from_leaves": "leaves",
        "Program termination": "pack"}
total = acc = 0
seen = set()
for f in files:
    text = open(f).read()
    trig = re.search(r"^desc: Trigger: (.*)$", text, re.M).group(1)
    ir = int(re.search(r"^totals: (\d+)", text, re.M).group(1))
    phase = next((v for k, v in name.items() if k in trig), trig)
    total += ir
    acc += ir
    # The multi-octree's leaves build a MeshDistance per component: not a phase boundary.
    if phase in seen:
        continue
    seen.add(phase)
    print(f"{acc / 1e9:8.3f} G  {phase}")
    acc = 0
print(f"{total / 1e9:8.3f} G  total")
PY
