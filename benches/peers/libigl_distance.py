#!/usr/bin/env python3
"""libigl peer for the signed-distance benchmark: same normalised mesh, same points, same sign.

Setup (own virtualenv, ignored by git) and run, from the repository root:

    python3 -m venv benches/.venv-libigl
    benches/.venv-libigl/bin/pip install -r benches/peers/requirements-libigl.txt
    benches/.venv-libigl/bin/python benches/peers/libigl_distance.py \
        ../shared/data/abc1.stl ../shared/data/stanford-bunny.obj --points 100000 --repeats 5

For each mesh the script first runs our example `distance_peer_data` (release build), which
loads and normalises the mesh with sdfmo-mesh, draws the benchmark's points (sdfmo_distance::
sample, the same seeds as benches/benches/distance.rs), times our queries (median of
--repeats runs, batch on all cores and single-threaded) and writes mesh, points and our signed
distances to raw files. Then, in the same run, it times `igl.signed_distance` on exactly that
mesh and those points (median of --repeats calls) with the matching sign type: pseudonormal
when our sign mode is PseudoNormal (closed meshes), fast winding number (Barill et al. 2018, the
method we implement, order 2, beta 2) when it is Winding (abc1 and the bunny are not closed).
libigl builds its AABB tree (and winding-number tree) inside every call, so we also time a call
with a single point and report libigl's query-only rate (call minus that setup) as well as the
whole-call rate; our build time is reported separately.

Answers are compared point by point: our |distance| against libigl's (tolerance 1e-5,
normalised units) and the signs where |d| > 1e-5. Note: with the fast winding number, libigl
returns S = (1 − 2|w|)·d, not ±d (signed_distance.cpp), so its distance is taken as |P − C| from
the closest points C it returns, and its sign from S (inside where |w| > ½; ours: w > ½).
Our example also counts, in winding mode, how many of our signs differ from the full
hierarchical winding number (β = 2) on every point and from the exact winding number on every
100th point (columns "ours vs full w" and "ours vs exact w").
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

import igl
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def run_ours(mesh, out_dir, points, repeats):
    cmd = [
        "cargo", "run", "--release", "-q", "-p", "sdfmo-distance", "--example",
        "distance_peer_data", "--", mesh, out_dir, str(points), str(repeats),
    ]
    res = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def load(out_dir, name, cols, dtype):
    return np.fromfile(os.path.join(out_dir, name), dtype=dtype).reshape(-1, cols) if cols else \
        np.fromfile(os.path.join(out_dir, name), dtype=dtype)


def time_igl(P, V, F, sign_type, repeats):
    times = []
    S = None
    for _ in range(repeats):
        t = time.perf_counter()
        S, _, C, _ = igl.signed_distance(P, V, F, sign_type=sign_type)
        times.append(time.perf_counter() - t)
    setup = []
    for _ in range(repeats):
        t = time.perf_counter()
        igl.signed_distance(P[:1], V, F, sign_type=sign_type)
        setup.append(time.perf_counter() - t)
    # ±|P − C|: exact distance with libigl's sign (see the module docstring).
    D = np.where(S < 0, -1.0, 1.0) * np.linalg.norm(P - C, axis=1)
    return D, statistics.median(times), statistics.median(setup)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--points", type=int, default=100000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true", help="print one JSON object per mesh and set")
    args = ap.parse_args()

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for mesh in args.meshes:
            name = os.path.splitext(os.path.basename(mesh))[0]
            out = os.path.join(tmp, name)
            ours = run_ours(mesh, out, args.points, args.repeats)
            V = load(out, "vertices.f32", 3, "<f4").astype(np.float64)
            F = load(out, "faces.u32", 3, "<u4").astype(np.int64)
            if ours["sign"] == "PseudoNormal":
                sign_type, sign_name = igl.SIGNED_DISTANCE_TYPE_PSEUDONORMAL, "pseudonormal"
            else:
                sign_type, sign_name = igl.SIGNED_DISTANCE_TYPE_FAST_WINDING_NUMBER, "fast winding number"
            for set_name in ("near", "uniform"):
                P = load(out, f"{set_name}.f32", 3, "<f4").astype(np.float64)
                mine = load(out, f"{set_name}.ours.f32", None, "<f4").astype(np.float64)
                S, t_call, t_setup = time_igl(P, V, F, sign_type, args.repeats)
                dist_err = np.abs(np.abs(S) - np.abs(mine))
                off = (np.abs(S) > 1e-5) & (np.abs(mine) > 1e-5)
                sign_mismatch = int(np.sum(np.sign(S[off]) != np.sign(mine[off])))
                o = ours[set_name]
                igl_query = len(P) / max(t_call - t_setup, 1e-9)
                igl_call = len(P) / t_call
                row = {
                    "mesh": name, "set": set_name, "points": len(P), "triangles": ours["triangles"],
                    "sign": sign_name, "ours_build_ms": ours["build_ms"], "threads": ours["threads"],
                    "ours_batch_pts_per_s": o["batch_pts_per_s"], "ours_single_pts_per_s": o["single_pts_per_s"],
                    "igl_call_s": t_call, "igl_setup_s": t_setup,
                    "igl_query_pts_per_s": igl_query, "igl_call_pts_per_s": igl_call,
                    "ratio_batch_vs_igl_query": o["batch_pts_per_s"] / igl_query,
                    "ratio_single_vs_igl_query": o["single_pts_per_s"] / igl_query,
                    "max_abs_distance_diff": float(dist_err.max()),
                    "distance_diff_over_1e-5": int(np.sum(dist_err > 1e-5)),
                    "sign_mismatches": sign_mismatch,
                    "sign_vs_full_winding": o.get("sign_vs_full_winding"),
                    "sign_vs_exact_winding": o.get("sign_vs_exact_winding"),
                    "exact_checked": o.get("exact_checked"),
                }
                rows.append(row)
                if args.json:
                    print(json.dumps(row))
                sys.stdout.flush()

    if not args.json:
        print(f"libigl {getattr(igl, '__version__', '2.6.x')} vs sdfmo-distance, medians of {args.repeats} runs")
        print("| mesh | points | sign | ours batch pts/s | ours 1-thread pts/s | libigl pts/s (query) | libigl pts/s (call) | batch ÷ libigl | 1-thread ÷ libigl | max abs diff | >1e-5 | sign mismatches | ours vs full w | ours vs exact w |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            print(f"| {r['mesh']} | {r['set']} {r['points']} | {r['sign']} | {r['ours_batch_pts_per_s']:,.0f} | "
                  f"{r['ours_single_pts_per_s']:,.0f} | {r['igl_query_pts_per_s']:,.0f} | {r['igl_call_pts_per_s']:,.0f} | "
                  f"{r['ratio_batch_vs_igl_query']:.1f}× | {r['ratio_single_vs_igl_query']:.1f}× | "
                  f"{r['max_abs_distance_diff']:.1e} | {r['distance_diff_over_1e-5']} | {r['sign_mismatches']} | "
                  f"{r['sign_vs_full_winding']} | {r['sign_vs_exact_winding']} of {r['exact_checked']} |")
        for r in rows:
            print(f"{r['mesh']}: our build {r['ours_build_ms']:.1f} ms; libigl setup per call {r['igl_setup_s'] * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
