#!/usr/bin/env python3
"""The tables of docs/results/format.md, "Compressed files", from the committed
docs/results/format/compressed.csv (written by benches/compressed_sizes.sh), and with
--v3 the table of "Format 3.x compressed" (the 3.1 file brick_estimate measures) from docs/results/format/brick-estimate.csv (written
by benches/brick_estimate.sh).

    python3 benches/compressed_table.py [docs/results/format/compressed.csv]
    python3 benches/compressed_table.py --v3 [docs/results/format/brick-estimate.csv]
"""
import csv
import sys


def v3_table(path):
    rows = list(csv.DictReader(open(path)))
    print("| model | method | depth | 1.x B/voxel | 3.1 | **compressed 3.1** | compressed 1.x | 3.1 as one zstd frame | decode MB/s (median, best) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        model, method, depth = r["file"].rsplit(".", 1)[0].split("-")
        v = int(r["voxels"])
        print(f"| {model} | {method} | {depth} | {r['traced_bpv']} | {r['v3_bpv']} | **{r['v3_compressed_bpv']}** | "
              f"{r['v1_compressed_bpv']} | {int(r['v3_one_frame_bytes']) / v:.2f} | "
              f"{r['v3_decode_mb_per_s']}, {r['v3_decode_best_mb_per_s']} |")
    worst = max(float(r["v3_compressed_bpv"]) for r in rows)
    slowest = min(int(r["v3_decode_mb_per_s"]) for r in rows)
    print(f"\nLargest compressed 3.1: {worst:.2f} B/voxel; slowest median decode: {slowest} MB/s.")


if sys.argv[1:2] == ["--v3"]:
    v3_table(sys.argv[2] if len(sys.argv) > 2 else "docs/results/format/brick-estimate.csv")
    sys.exit(0)

path = sys.argv[1] if len(sys.argv) > 1 else "docs/results/format/compressed.csv"
rows = list(csv.DictReader(open(path)))
print("| model | method | depth | voxels | traced B | compressed B | traced B/voxel | **compressed B/voxel** | smaller |")
print("|---|---|---|---|---|---|---|---|---|")
for r in rows:
    if r["levels"] != r["depth"]:
        continue
    v, t, c = int(r["voxels"]), int(r["traced_bytes"]), int(r["compressed_bytes"])
    print(f"| {r['model']} | {r['method']} | {r['depth']} | {v} | {t} | {c} | {t / v:.2f} | **{c / v:.2f}** | {t / c:.1f}× |")
print()
print("| model | levels 6–10 traced B | ÷ depth 10 | levels 6–10 compressed B | ÷ depth 10 compressed |")
print("|---|---|---|---|---|")
for r in rows:
    if r["levels"] != "6-10":
        continue
    leaf = next(x for x in rows if x["model"] == r["model"] and x["method"] == "multi" and x["levels"] == "10")
    t, c = int(r["traced_bytes"]), int(r["compressed_bytes"])
    print(f"| {r['model']} | {t} | {t / int(leaf['traced_bytes']):.2f}× | {c} | {c / int(leaf['compressed_bytes']):.2f}× |")
