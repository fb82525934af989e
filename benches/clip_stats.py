#!/usr/bin/env python3
"""Clip voxels per leaf and all-zero voxels of `.smo` files (issue 19), read straight from the
bytes as crates/sdfmo-format/FORMAT.md specifies them (no validation: run on files the builder
wrote). Usage: clip_stats.py FILE.smo... ; prints one line per file:
name, leaves, voxels, clip voxels, most clip voxels in one leaf, leaves with clip voxels,
largest leaf with clip voxels (voxels), voxels whose codes are all 0."""
import struct
import sys


def stats(path):
    b = open(path, "rb").read()
    flags, depth, bits = struct.unpack_from("<IBB", b, 16)
    inner, leaves, voxels, _surface = struct.unpack_from("<IIII", b, 40)
    leaves_off = struct.unpack_from("<Q", b, 80)[0]
    corners_off, corners_size = struct.unpack_from("<QQ", b, 112)
    clip_off = corners_off + corners_size if flags & 4 else None
    counts = []
    for g in range((leaves + 7) // 8):
        rec = b[leaves_off + 12 * g + 4: leaves_off + 12 * g + 12]
        counts.extend(rec[: min(8, leaves - 8 * g)])
    per_voxel = 8 * (bits // 8)
    zero = bytes(per_voxel)
    all_zero = sum(
        1 for v in range(voxels) if b[corners_off + v * per_voxel: corners_off + (v + 1) * per_voxel] == zero
    )
    clip_total = max_clips = clip_leaves = largest = 0
    v = 0
    for c in counts:
        n = 0
        if clip_off is not None:
            n = sum((b[clip_off + (x >> 3)] >> (x & 7)) & 1 for x in range(v, v + c))
        clip_total += n
        max_clips = max(max_clips, n)
        if n:
            clip_leaves += 1
            largest = max(largest, c)
        v += c
    return leaves, voxels, clip_total, max_clips, clip_leaves, largest, all_zero


for p in sys.argv[1:]:
    print(p, *stats(p))
