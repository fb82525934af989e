#!/usr/bin/env bash
# The dataset sweep on a real Slurm (deploy/slurm/local-setup.sh), as .ci/run runs it:
#
#   deploy/slurm/ci-test.sh target/debug/sdfmo
#
# A manifest of 42 models (4 shared meshes, 36 generated parts, one malformed file, one model
# too slow for its --model-timeout) is swept by the recipe as a user runs it: submit.sh submits
# a 4-task array job and its merge (--dependency=afterok); shard 1 is cancelled mid-run while
# the others run or wait (shard 3 is held in the queue); resubmit.sh reruns shard 1, cancels the
# stale merge (which waits on the cancelled array) and submits one that waits on the rerun and
# on the shards still queued or running. The reference is the plain in-process `sdfmo sweep` of
# the 40 good models. Checks: the stale merge is CANCELLED, the new one waits for the held shard
# and completes, its rows equal the single process's bit for bit (model, method, depth, bytes,
# PSNR and FLIP of every view, octree counts), no ledger holds a model twice and nothing
# finished before the kill ran again, and exactly the two bad models are failures. About 3
# minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
sdfmo=$(realpath "${1:?usage: $0 PATH/TO/sdfmo}")
data=$(realpath "${SDFMO_TEST_DATA:-../shared/data}")
here=$PWD/deploy/slurm
work=$(mktemp -d /tmp/sdfmo-slurm-ci.XXXXXX)
jobs=()
# On the way out (an error included), cancel this test's jobs and no one else's.
trap 'if [ ${#jobs[@]} -gt 0 ]; then scancel "${jobs[@]}" > /dev/null 2>&1 || true; fi' EXIT
shards=4
flags=(--depths 5..6 --size 48 --model-timeout 20 --max-memory 2G)
t0=$(date +%s)

"$sdfmo" generate-parts -n 36 --seed 24 -o "$work/parts" > /dev/null
printf 'v 0 0 0\nv 1 0 0\nf 1 2 7\n' > "$work/malformed.obj"
# Too slow for 20 s: a UV sphere of 1.96 M triangles (about 30 CPU-seconds in a debug build).
python3 - "$work/slow.obj" <<'PY'
import math, sys
n, m = 700, 1400
out = ["v 0 1 0"]
for i in range(1, n):
    th = math.pi * i / n
    y, r = math.cos(th), math.sin(th)
    out += ["v %.7f %.7f %.7f" % (r * math.cos(2 * math.pi * j / m), y, r * math.sin(2 * math.pi * j / m)) for j in range(m)]
out.append("v 0 -1 0")
idx = lambda i, j: 2 + (i - 1) * m + (j % m)
last = 2 + (n - 1) * m
out += ["f 1 %d %d" % (idx(1, j + 1), idx(1, j)) for j in range(m)]
for i in range(1, n - 1):
    for j in range(m):
        a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
        out.append("f %d %d %d\nf %d %d %d" % (a, b, d, a, d, c))
out += ["f %d %d %d" % (last, idx(n - 1, j), idx(n - 1, j + 1)) for j in range(m)]
open(sys.argv[1], "w").write("\n".join(out) + "\n")
PY
# Shard k owns the entries k, k + 4, …: the slow model (entry 5) and the malformed one
# (entry 10) belong to shard 1 and 2; shard 1 is killed while it runs the slow model.
{
    for f in abc8.stl teapot.obj abc5_parts.obj abc3.stl; do echo "$data/$f"; done
    echo parts/part_000000.obj
    echo slow.obj
    for i in $(seq 1 4); do printf 'parts/part_%06d.obj\n' "$i"; done
    echo malformed.obj
    for i in $(seq 5 35); do printf 'parts/part_%06d.obj\n' "$i"; done
} > "$work/manifest.txt"
echo "ci-test: $(wc -l < "$work/manifest.txt") models in $work/manifest.txt"

# The reference: one uninterrupted process, the classic in-process sweep (no manifest, no
# child processes, no ledger) over the 40 good models in manifest order.
good=()
while read -r p; do
    case "$p" in slow.obj | malformed.obj) ;; /*) good+=("$p") ;; *) good+=("$work/$p") ;; esac
done < "$work/manifest.txt"
"$sdfmo" sweep "${good[@]}" "${flags[@]:0:4}" -o "$work/single" > /dev/null
echo "ci-test: single process done ($(($(date +%s) - t0)) s)"

# The recipe as a user runs it: submit.sh submits the array and its merge; shard 1 is cancelled
# once it has finished a model and started the slow one; resubmit.sh reruns it, cancels the
# merge that waits on the cancelled array and submits one that waits on the rerun.
export SDFMO="$sdfmo" SDFMO_MEM_PER_TASK=3G
"$here/submit.sh" "$work/manifest.txt" "$work/shards" $shards "${flags[@]}"
job() { awk -v k="$1" '$1 == k { id = $2 } END { print id }' "$work/shards/submit.jobs"; }
array=$(job array)
old_merge=$(job merge)
jobs+=("$array" "$old_merge")
# Shard 3 is held in the queue (2 cores: it cannot have started yet) until after the
# resubmission, so that the new merge must also wait for a shard of the first array.
scontrol hold "${array}_3"
ledger1="$work/shards/shard-1/ledger.jsonl"
for _ in $(seq 600); do
    [ -s "$ledger1" ] && break
    sleep 0.2
done
[ -s "$ledger1" ] || { echo "ci-test: shard 1 wrote no ledger line" >&2; cat "$work"/shards/slurm-*_1.out >&2; exit 1; }
sleep 2
scancel "${array}_1"
while [ -n "$(squeue -h -j "${array}_1" 2> /dev/null)" ]; do sleep 1; done
before=$(wc -l < "$ledger1")
echo "ci-test: shard 1 cancelled with $before ledger line(s)"
cp "$ledger1" "$work/ledger1-before-resume.jsonl"
"$here/resubmit.sh" "$work/shards" 1
merge=$(job merge)
jobs+=("$(job array)" "$merge")
state() { scontrol show job "$1" | grep -o 'JobState=[A-Z_]*' | cut -d= -f2; }
[ "$merge" != "$old_merge" ] || { echo "ci-test: resubmit.sh submitted no new merge" >&2; exit 1; }
[ "$(state "$old_merge")" = CANCELLED ] || { echo "ci-test: the stale merge $old_merge is $(state "$old_merge"), not CANCELLED" >&2; exit 1; }
dependency=$(scontrol show job "$merge" | grep -o 'Dependency=[^ ]*')
case "$dependency" in
    *"afterok:${array}_3("*) ;;
    *) echo "ci-test: the new merge does not wait for the held shard 3: $dependency" >&2; exit 1 ;;
esac
scontrol release "${array}_3"
while [ -n "$(squeue -h -j "$merge" 2> /dev/null)" ]; do sleep 1; done
[ "$(state "$merge")" = COMPLETED ] || { echo "ci-test: the merge $merge ended $(state "$merge")" >&2; cat "$work"/shards/slurm-merge-*.out >&2; exit 1; }
echo "ci-test: array, resubmission and merge done ($(($(date +%s) - t0)) s; stale merge $old_merge cancelled, merge $merge with $dependency completed)"

python3 - "$work" <<'PY'
import json, sys, glob
work = sys.argv[1]
single = json.load(open(f"{work}/single/results.json"))
merged = json.load(open(f"{work}/shards/report/results.json"))
keys = ["model", "method", "depth", "psnr", "flip", "bytes", "nodes", "leaves", "voxels",
        "surface_voxels", "cap_hits", "psnr_views", "flip_views"]
strip = lambda rows: [{k: r[k] for k in keys} for r in rows]
assert len(single["rows"]) == 40 * 2 * 2, len(single["rows"])
assert strip(merged["rows"]) == strip(single["rows"]), "merged rows differ from the single run's"
assert [m["model"] for m in merged["models"]] == [m["model"] for m in single["models"]]
fails = {f["model"]: f["error"] for f in merged["failures"]}
assert set(fails) == {"slow", "malformed"}, fails
assert "timed out" in fails["slow"], fails["slow"]
for ledger in glob.glob(f"{work}/shards/shard-*/ledger.jsonl"):
    ids = [json.loads(l)["id"] for l in open(ledger)]
    assert len(ids) == len(set(ids)), f"{ledger} holds a model twice"
before = [json.loads(l)["id"] for l in open(f"{work}/ledger1-before-resume.jsonl")]
after = [json.loads(l)["id"] for l in open(f"{work}/shards/shard-1/ledger.jsonl")]
assert after[: len(before)] == before and not set(after[len(before):]) & set(before), "a model ran twice"
assert len(after) == 11 and len(before) < len(after), (len(before), len(after))
print(f"ci-test: ok: {len(merged['rows'])} rows equal, failures {sorted(fails)}, "
      f"shard 1 resumed after {len(before)} of {len(after)} models")
PY
rm -rf "$work"
