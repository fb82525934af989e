#!/usr/bin/env python3
"""The tables of docs/results/format.md, "Compressed files", from the committed
docs/results/format/compressed.csv (written by benches/compressed_sizes.sh).

    python3 benches/compressed_table.py [docs/results/format/compressed.csv]
"""
import csv
import sys

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
