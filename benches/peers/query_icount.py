#!/usr/bin/env python3
"""Instructions per query point of `sdfmo` and FCPW (or any peer of python_sdf.py), counted by
callgrind through the same Python harness: a measure that other processes on a loaded machine
do not distort (unlike CPU seconds, which shared caches still inflate).

    benches/.venv-pypeers/bin/python benches/peers/query_icount.py ../shared/data/abc5.stl \\
        --peers "sdfmo (auto sign),FCPW unsigned" --points 5000

(the venv of python_sdf.py). Each peer runs twice under `valgrind --tool=callgrind`, on the
first N and the first 2N of the same 2N points (python_sdf.py's mix: half near the surface,
half uniform in the padded box), its structure built and one point queried before; the
difference of the two totals over N is the peer's instructions per point, set-up, imports and
point generation cancelling out. One thread each (`threads=1`; callgrind runs a process's
threads one at a time and counts them all). Instructions are not time: FCPW's wide SIMD does
more per instruction, so the side-by-side CPU-second table of python_sdf.py stays the measure
of speed; these counts show where a change moved our own work.
"""

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def child(mesh, peer, n, total, warm):
    """Runs `peer` on the first n of `total` points (inside valgrind); with `warm`, on all
    `total` points first (in both runs, so it cancels: the steady state, one-time data made)."""
    import numpy as np

    sys.path.insert(0, str(HERE))
    import python_sdf
    from python_sdf import reference, sdfmo

    m = sdfmo.Mesh.load(mesh)
    pts, _ = reference.query_points(m, total, seed=2026)
    pts32 = np.ascontiguousarray(pts.astype(np.float32))
    setup, query, *_ = python_sdf.peers(m.vertices, m.faces)[peer]
    state = setup()
    query(state, pts32[:1])
    if warm:
        query(state, pts32)
    query(state, pts32[:n])


def instructions(mesh, peer, n, total, warm):
    """callgrind's total instruction count of `child(mesh, peer, n, total, warm)`."""
    run = subprocess.run(
        ["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", sys.executable,
         __file__, "--child", mesh, peer, str(n), str(total), str(int(warm))],
        capture_output=True, text=True, env={**os.environ, "OMP_NUM_THREADS": "1"}, check=True)
    return int(re.search(r"Collected : (\d+)", run.stderr).group(1))


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        mesh, peer, n, total, warm = sys.argv[2:7]
        child(mesh, peer, int(n), int(total), warm == "1")
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("meshes", nargs="+")
    ap.add_argument("--peers", default="sdfmo (auto sign),FCPW unsigned",
                    help="comma-separated peer names of python_sdf.py")
    ap.add_argument("--points", type=int, default=5000)
    ap.add_argument("--warm", action="store_true",
                    help="the steady state: both runs query all 2N points first (see child)")
    a = ap.parse_args()
    peers = a.peers.split(",")
    print("| mesh | " + " | ".join(f"{p}: instructions/point" for p in peers) + " |")
    print("|---" * (len(peers) + 1) + "|")
    for mesh in a.meshes:
        row = []
        for peer in peers:
            once = instructions(mesh, peer, a.points, 2 * a.points, a.warm)
            twice = instructions(mesh, peer, 2 * a.points, 2 * a.points, a.warm)
            row.append(f"{(twice - once) / a.points:,.0f}")
        print(f"| {Path(mesh).name} | " + " | ".join(row) + " |", flush=True)


if __name__ == "__main__":
    main()
