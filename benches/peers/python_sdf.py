#!/usr/bin/env python3
"""Python peers of `sdfmo` signed distance: the same mesh, the same points, one core each.

Setup (its own virtualenv, ignored by git) and run, from the repository root:

    python3 -m venv benches/.venv-pypeers
    benches/.venv-pypeers/bin/pip install -r benches/peers/requirements-pysdf.txt
    benches/.venv-pypeers/bin/pip install target/py-wheels/sdf_multioctree-*.whl   # ./test.sh builds it
    benches/.venv-pypeers/bin/python benches/peers/python_sdf.py ../shared/data/*.stl \\
        ../shared/data/stanford-bunny.obj ../shared/data/teapot.obj --points 200000

(A release wheel, `maturin build --release -m crates/sdfmo-py/Cargo.toml`, gives our release
speed; the dev wheel of ./test.sh is several times slower.)

Every library runs in this process pinned to one CPU (`os.sched_setaffinity`), so points per
second is per core whatever threads a library starts; times are CPU seconds of the process
(`time.process_time`), which on a shared machine other processes do not inflate. Points: half near the surface (vertices
plus Gaussian noise of 1 % of the diagonal), half uniform in the box padded by 10 %
(crates/sdfmo-py/tests/reference.py). Each peer's tree or structure is built before the clock
where its API allows (pysdf, point-cloud-utils and libigl build inside the call: they are timed
whole, and their setup with a 1-point call is reported). Accuracy: max |(|d|) - d_ref| over the
bounding-box diagonal on --ref-points points against the f64 brute-force reference; sign: the
fraction of points agreeing with the exact winding number (w > 1/2 inside) among those farther
than 1 % of the diagonal from the surface where |w - 1/2| > 0.2. Besides the files given, the
script adds a mesh with coincident double walls: two unit cubes sharing the face x = 1, each of
their 12 faces a separate 24 x 24 grid with its own vertices (not welded, so to a topology check
it is an open soup of 12 sheets: not watertight, `auto` picks the winding number), 13,824
triangles.
"""

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "crates" / "sdfmo-py" / "tests"))

import reference  # noqa: E402
import sdfmo  # noqa: E402


def double_wall_mesh(subdiv=24):
    """Two cubes [0,1]^3 and [1,2]x[0,1]^2, outward oriented, each face its own grid of
    subdiv^2 quads with its own vertices (not welded): coincident walls at x = 1."""
    verts, faces = [], []

    def quad_grid(origin, du, dv):
        base = sum(len(v) for v in verts)
        g = np.linspace(0, 1, subdiv + 1)
        vv = np.array([origin + a * du + b * dv for a in g for b in g])
        idx = lambda i, j: base + i * (subdiv + 1) + j  # noqa: E731
        ff = []
        for i in range(subdiv):
            for j in range(subdiv):
                ff += [[idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)], [idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]]
        verts.append(vv)
        faces.append(np.array(ff))

    for x0 in (0.0, 1.0):
        o = np.array([x0, 0, 0.0])
        ex, ey, ez = np.eye(3)
        # Outward-oriented faces: (du x dv) points out.
        quad_grid(o, ez, ey)                       # x = x0, normal -x
        quad_grid(o + ex, ey, ez)                  # x = x0 + 1, normal +x
        quad_grid(o, ex, ez)                       # y = 0, normal -y
        quad_grid(o + ey, ez, ex)                  # y = 1, normal +y
        quad_grid(o, ey, ex)                       # z = 0, normal -z
        quad_grid(o + ez, ex, ey)                  # z = 1, normal +z
    return np.concatenate(verts).astype(np.float32), np.concatenate(faces)


def timed(f, *args):
    """f(*args) and the CPU seconds it took (all threads of the process; pinned to one core,
    that is the wall time on an idle core, and other processes sharing it do not count)."""
    t = time.process_time()
    out = f(*args)
    return out, time.process_time() - t


def peers(v, f):
    """name -> (setup() -> state, query(state, points) -> distances[, post(raw) -> distances]):
    signed distances negative inside (unsigned for the peers named so); `post`, outside the
    clock, turns a peer's raw result into an array. Peers whose package is missing are left
    out."""
    out = {}
    m = sdfmo.Mesh(v, f)
    out["sdfmo (auto sign)"] = (lambda: (m.signed_distance(np.zeros((1, 3))), m)[1],
                                lambda s, p: s.signed_distance(p, threads=1))
    out["sdfmo unsigned"] = (lambda: m, lambda s, p: s.unsigned_distance(p, threads=1))
    try:
        import igl

        v64, f64 = v.astype(np.float64), f.astype(np.int64)
        for name, st in (("libigl pseudonormal", igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL),
                         ("libigl fast winding", igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER)):
            def q(s, p, st=st):
                d, _, c = igl.signed_distance(np.asarray(p, np.float64), v64, f64, st)[:3]
                # Fast winding returns (1 - 2|w|) * d: keep |P - C| and the sign.
                return np.sign(d) * np.linalg.norm(np.asarray(p, np.float64) - c, axis=1)
            out[name] = (lambda: None, q)
    except ImportError:
        pass
    try:
        import pysdf

        out["pysdf"] = (lambda: pysdf.SDF(v, f.astype(np.uint32)),
                        lambda s, p: -s(np.asarray(p, np.float32)))  # pysdf: positive inside
    except ImportError:
        pass
    try:
        import point_cloud_utils as pcu

        out["point-cloud-utils"] = (
            lambda: None,
            lambda s, p: pcu.signed_distance_to_mesh(np.ascontiguousarray(p, np.float64),
                                                     v.astype(np.float64), f.astype(np.int32))[0])
    except ImportError:
        pass
    try:
        import trimesh

        tm = trimesh.Trimesh(v.astype(np.float64), f, process=False)
        out["trimesh (subset)"] = (lambda: tm, lambda s, p: -trimesh.proximity.signed_distance(s, p))
    except ImportError:
        pass
    try:
        import fcpw

        def fcpw_setup():
            scene = fcpw.scene_3D()
            scene.set_object_count(1)
            scene.set_object_vertices(np.asfortranarray(v, np.float32), 0)
            scene.set_object_triangles(np.asfortranarray(f, np.int32), 0)
            scene.build(fcpw.aggregate_type.bvh_surface_area, True)
            return scene

        def fcpw_query(scene, p):
            p = np.asfortranarray(p, np.float32)
            inter = fcpw.interaction_3D_list()
            scene.find_closest_points(p, np.full(len(p), np.inf, np.float32), inter)
            return inter

        def fcpw_post(inter):
            # Outside the clock: reading the interactions one by one is Python-bound.
            return np.array([x.d for x in inter], np.float32)

        out["FCPW unsigned"] = (fcpw_setup, fcpw_query, fcpw_post)
    except ImportError:
        pass
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--points", type=int, default=200_000)
    ap.add_argument("--ref-points", type=int, default=300)
    ap.add_argument("--trimesh-points", type=int, default=2000)
    ap.add_argument("--only", default="", help="comma-separated peer names to run (prefix match)")
    ap.add_argument("--warm", action="store_true",
                    help="query the same points once before the clock, every peer: the steady "
                         "state of a structure whose one-time data is made (ours: the winding "
                         "sign's per-leaf radii, made for the leaves a query reaches)")
    a = ap.parse_args()
    os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    meshes = [(Path(p).name, sdfmo.Mesh.load(p)) for p in a.meshes]
    v, f = double_wall_mesh()
    meshes.append(("double-wall cubes", sdfmo.Mesh(v, f)))
    print("| mesh | peer | points/s per core | setup s | max error / diagonal | sign agreement |")
    print("|---|---|---|---|---|---|")
    for name, m in meshes:
        v, f = m.vertices, m.faces
        pts, diag = reference.query_points(m, a.points, seed=2026)
        pts32 = pts.astype(np.float32)
        ref_pts = pts32[:: max(1, len(pts) // a.ref_points)][: a.ref_points].astype(np.float64)
        ref, _ = reference.unsigned_distance(m, ref_pts)
        w = reference.winding_number(m, ref_pts)
        far = (ref > 0.01 * diag) & (np.abs(w - 0.5) > 0.2)
        for peer, (setup, query, *post) in peers(v, f).items():
            post = post[0] if post else (lambda x: x)
            if a.only and not any(peer.startswith(o) for o in a.only.split(",")):
                continue
            try:
                state, setup_s = timed(setup)
                n = a.trimesh_points if peer.startswith("trimesh") else len(pts32)
                _, one_s = timed(query, state, pts32[:1])
                if a.warm:
                    query(state, pts32[:n])
                _, wall = timed(query, state, pts32[:n])
                d = np.asarray(post(query(state, ref_pts.astype(np.float32))), np.float64)
            except Exception as e:  # noqa: BLE001
                print(f"| {name} | {peer} | failed: {type(e).__name__}: {str(e)[:80]} | | | |")
                continue
            err = np.max(np.abs(np.abs(d) - ref)) / diag
            signed = "unsigned" not in peer
            agree = f"{100 * np.mean((d[far] < 0) == (w[far] > 0.5)):.2f} % of {far.sum()}" if signed else "-"
            print(f"| {name} | {peer} | {n / wall / 1e6:.3f} M | {setup_s + one_s:.3f} | {err:.1e} | {agree} |",
                  flush=True)


if __name__ == "__main__":
    main()
