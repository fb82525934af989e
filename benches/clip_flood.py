#!/usr/bin/env python3
"""The design of clip_flood(clips) in crates/sdfmo-cli/tests/hostile.rs, written from FORMAT.md
in Python (for timing the binaries of any commit, the old ones included): every leaf at
depth 4 (4,096) holds 255 volume voxels, voxels 0..253 the plane x = 0.49 (inside below), voxel
254 the plane x = 0.51 (inside above); the last CLIPS voxels of each leaf have the clip bit.
usage: flood.py CLIPS OUT.smo"""
import math, struct, sys, zlib
clips, out = int(sys.argv[1]), sys.argv[2]
DEPTH, NV = 4, 255
h = 2.0 / 16
dmax = math.sqrt(3) * h
def code(v):
    x = max(-1.0, min(1.0, v / dmax)) * 127
    return int(math.copysign(math.floor(abs(x) + 0.5), x))
def voxel(k):
    return bytes((code(h * ((0.51 - (i >> 2)) if k == NV - 1 else ((i >> 2) - 0.49))) & 0xff) for i in range(8))
a8 = lambda x: (x + 7) // 8 * 8
I = 1 + 8 + 64 + 512
L = 4096
V = L * NV
nodes_size = 12 * ((I + 7) // 8)
leaves_off = a8(128 + nodes_size); leaves_size = 12 * ((L + 7) // 8)
surface_off = a8(leaves_off + leaves_size); surface_size = 8 * ((V + 63) // 64)
corners_off = a8(surface_off + surface_size); corners_size = 8 * V
clip_size = 8 * ((V + 63) // 64) if clips else 0
file_size = corners_off + corners_size + clip_size + 4
flags = 1 | (4 if clips else 0)
hdr = b"\x89SMO\r\n\x1a\n" + struct.pack("<HHIIBBH4f4IQ8Q", 1, 1 if clips else 0, 128, flags, DEPTH, 8, 0,
      0.0, 0.0, 0.0, 1.0, I, L, V, 0, file_size, 128, nodes_size, leaves_off, leaves_size,
      surface_off, surface_size, corners_off, corners_size)
assert len(hdr) == 128
b = bytearray(hdr)
for g in range((I + 7) // 8):
    masks = bytes(0xFF if 8 * g + s < I else 0 for s in range(8))
    b += struct.pack("<I", 1 + 8 * 8 * g) + masks
b += bytes(leaves_off - len(b))
for g in range(L // 8):
    b += struct.pack("<I", NV * 8 * g) + bytes([NV] * 8)
b += bytes(surface_off - len(b))
b += bytes(surface_size)
b += bytes(corners_off - len(b))
leaf = b"".join(voxel(k) for k in range(NV))
b += leaf * L
if clips:
    bits = bytearray(clip_size)
    for l in range(L):
        for k in range(NV - clips, NV):
            x = l * NV + k
            bits[x >> 3] |= 1 << (x & 7)
    b += bits
b += struct.pack("<I", zlib.crc32(bytes(b)) & 0xffffffff)
assert len(b) == file_size
open(out, "wb").write(b)
