#!/usr/bin/env python3
"""Embree peer for the render benchmark: cast the same primary rays at the same normalised mesh.

Setup (own virtualenv, ignored by git):

    python3 -m venv benches/.venv-embree
    benches/.venv-embree/bin/pip install -r benches/peers/requirements-embree.txt
    benches/.venv-embree/bin/python benches/peers/embree_primary.py \
        ../shared/data/abc1.stl ../shared/data/abc5.stl --size 1024 --view 0

The mesh is normalised exactly as sdfmo-mesh does it (f32): bounding-box centre to the origin,
longest extent to 2·(1 − margin). The rays follow design §3 / sdfmo-render's camera: pinhole,
pixel centres, vertical fov, right = normalize(fwd × up), up' = right × fwd, computed in f64
and rounded to f32 once (as `CameraFrame::ray`). Paper view k: eye = 3·(sin θ, 0, cos θ),
θ = 2πk/4, target the origin, fov 60°.

What is timed: wall time (min and median of --repeat runs) and process CPU time per frame (mean,
and `cpu_median_ms` in --json: the median of the per-run CPU times) of
`EmbreeScene.run` on all W·H rays (closest hit, primitive ids only), which in
embreex is a loop of rtcIntersect1 calls on one thread. The BVH build is timed separately.
`--mask-out DIR` writes the hit mask as a binary PGM (255 = hit) per mesh, for comparing
silhouettes with `sdfmo render-mesh --mode mask`.
"""

import argparse
import json
import math
import os
import statistics
import sys
import time

import numpy as np
import trimesh
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def normalised_triangles(path, margin):
    mesh = trimesh.load(path, process=False, force="mesh")
    v = np.asarray(mesh.vertices, dtype=np.float32)
    f = np.asarray(mesh.faces, dtype=np.int64)
    lo = v.min(axis=0)
    hi = v.max(axis=0)
    center = ((lo + hi) * np.float32(0.5)).astype(np.float32)
    longest = np.float32((hi - lo).max())
    target = np.float32(2.0) * (np.float32(1.0) - np.float32(margin))
    scale = np.float32(target / longest) if longest > 0 else np.float32(1.0)
    vn = ((v - center) * scale).astype(np.float32)
    return vn[f], len(f)


def paper_camera(k):
    theta = 2.0 * math.pi * (k % 4) / 4.0
    eye = np.array([3.0 * math.sin(theta), 0.0, 3.0 * math.cos(theta)], dtype=np.float32)
    return eye.astype(np.float64), np.zeros(3), np.array([0.0, 1.0, 0.0]), 60.0


def primary_rays(eye, target, up, fov_deg, w, h):
    fwd = target - eye
    fwd /= np.linalg.norm(fwd)
    hint = up / np.linalg.norm(up)
    if np.linalg.norm(np.cross(fwd, hint)) < 1e-9:
        z = np.array([0.0, 0.0, 1.0])
        hint = np.array([0.0, 1.0, 0.0]) if np.linalg.norm(np.cross(fwd, z)) < 1e-9 else z
    right = np.cross(fwd, hint)
    right /= np.linalg.norm(right)
    upp = np.cross(right, fwd)
    tan_half = math.tan(math.radians(fov_deg) * 0.5)
    px = np.arange(w, dtype=np.float64)
    py = np.arange(h, dtype=np.float64)
    u = (2.0 * (px + 0.5) / w - 1.0) * tan_half * w / h
    v = (1.0 - 2.0 * (py + 0.5) / h) * tan_half
    uu, vv = np.meshgrid(u, v)  # rows = py from the top
    d = fwd[None, None, :] + uu[..., None] * right[None, None, :] + vv[..., None] * upp[None, None, :]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    dirs = d.reshape(-1, 3).astype(np.float32)
    origins = np.tile(eye.astype(np.float32), (w * h, 1))
    return origins, dirs


def write_pgm(path, mask, w, h):
    with open(path, "wb") as fh:
        fh.write(b"P5\n%d %d\n255\n" % (w, h))
        fh.write((mask.reshape(h, w) * 255).astype(np.uint8).tobytes())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--view", type=int, default=0)
    ap.add_argument("--margin", type=float, default=0.05)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--mask-out", default=None)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()

    eye, target, up, fov = paper_camera(a.view)
    origins, dirs = primary_rays(eye, target, up, fov, a.size, a.size)
    n = len(dirs)
    results = []
    for path in a.meshes:
        tris, ntri = normalised_triangles(path, a.margin)
        t0 = time.perf_counter()
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, tris)
        scene.run(origins[:1], dirs[:1])  # forces the (lazy) commit/BVH build
        build_ms = (time.perf_counter() - t0) * 1e3
        times = []
        cpu_times = []
        c0 = time.process_time()
        for _ in range(a.repeat):
            t0 = time.perf_counter()
            p0 = time.process_time()
            prim = scene.run(origins, dirs)
            cpu_times.append((time.process_time() - p0) * 1e3)
            times.append((time.perf_counter() - t0) * 1e3)
        cpu_ms = (time.process_time() - c0) * 1e3 / a.repeat
        hits = int((prim >= 0).sum())
        assert hits > 0, f"{path}: no ray hit the mesh"
        name = os.path.splitext(os.path.basename(path))[0]
        if a.mask_out:
            os.makedirs(a.mask_out, exist_ok=True)
            write_pgm(os.path.join(a.mask_out, f"{name}_embree_mask_{a.view}.pgm"), prim >= 0, a.size, a.size)
        results.append(
            dict(
                mesh=name,
                triangles=ntri,
                rays=n,
                hits=hits,
                build_ms=build_ms,
                min_ms=min(times),
                median_ms=statistics.median(times),
                cpu_ms=cpu_ms,
                cpu_median_ms=statistics.median(cpu_times),
                mrays_per_s=n / (min(times) * 1e-3) / 1e6,
            )
        )
    if a.json:
        print(json.dumps(results))
    else:
        print(f"Embree (embreex, rtcIntersect1 loop, 1 thread), paper view {a.view}, {a.size}x{a.size}")
        print(f"{'mesh':<10} {'tris':>8} {'hits':>9} {'build ms':>9} {'min ms':>8} {'median ms':>10} {'cpu ms':>7} {'Mrays/s':>8}")
        for r in results:
            print(
                f"{r['mesh']:<10} {r['triangles']:>8} {r['hits']:>9} {r['build_ms']:>9.1f} "
                f"{r['min_ms']:>8.1f} {r['median_ms']:>10.1f} {r['cpu_ms']:>7.1f} {r['mrays_per_s']:>8.2f}"
            )


if __name__ == "__main__":
    sys.exit(main())
