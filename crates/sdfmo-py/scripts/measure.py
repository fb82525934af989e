"""The numbers of docs/results/python.md, measured on the installed wheel.

    python crates/sdfmo-py/scripts/measure.py [--data ../shared/data] [--cli target/release/sdfmo]
        [--points 1000000] [--ref-points 500] [--only accuracy,speed,sample,memory,roundtrip,errors]

Prints Markdown tables. Accuracy: the query points of tests/reference.py (half within about 1 %
of the diagonal of the surface, half uniform in the padded box) against the f64 brute-force
reference. Speed: points per second per core = points / CPU seconds of the process (all
threads; on an idle machine that is wall x threads, and unlike wall time it is not inflated by
other processes sharing the cores), the distance structure built before the clock starts.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))

import sdfmo  # noqa: E402
import reference  # noqa: E402

MESHES = ["abc1.stl", "abc3.stl", "abc5.stl", "abc8.stl", "stanford-bunny.obj", "teapot.obj"]


def accuracy(data, n_ref):
    print(f"\n### Accuracy against the f64 reference ({n_ref} points per mesh)\n")
    print("| mesh | triangles | auto sign | max abs. error / diagonal | mean | sign agreement with the exact winding number (points farther than 1 % of the diagonal, w not within 0.2 of 1/2) |")
    print("|---|---|---|---|---|---|")
    for name in MESHES:
        m = sdfmo.Mesh.load(data / name)
        pts, diag = reference.query_points(m, n_ref, seed=2026)
        ref, _ = reference.unsigned_distance(m, pts)
        d = m.signed_distance(pts).astype(np.float64)
        err = np.abs(np.abs(d) - ref) / diag
        w = reference.winding_number(m, pts)
        far = (ref > 0.01 * diag) & (np.abs(w - 0.5) > 0.2)
        agree = np.mean((d[far] < 0) == (w[far] > 0.5))
        print(f"| {name} | {m.face_count} | {m.auto_sign} | {err.max():.2e} | {err.mean():.2e} | "
              f"{100 * agree:.2f} % of {far.sum()} |")


def speed(data, n):
    print(f"\n### Throughput ({n} points: half near the surface, half uniform in the padded box)\n")
    print("Points per CPU-second (per core).\n")
    print("| mesh | signed, 1 thread | signed, 2 threads | unsigned, 1 thread | signed + closest + face, 1 thread | winding number, 1 thread |")
    print("|---|---|---|---|---|---|")
    for name in MESHES:
        m = sdfmo.Mesh.load(data / name)
        pts, _ = reference.query_points(m, n, seed=7)
        pts = pts.astype(np.float32)
        m.signed_distance(pts[:100])  # build the distance structure outside the clock

        def rate(f, threads):
            # Per core: points / CPU seconds of the process (all its threads), which a loaded
            # machine does not inflate the way it inflates wall time; best of two.
            best = float("inf")
            for _ in range(2):
                t = time.process_time()
                f(pts, threads=threads)
                best = min(best, time.process_time() - t)
            return n / best

        s1 = rate(m.signed_distance, 1)
        s2 = rate(m.signed_distance, 2)
        u1 = rate(m.unsigned_distance, 1)
        c1 = rate(lambda p, threads: m.signed_distance(p, return_closest=True, return_face=True,
                                                        threads=threads), 1)
        w1 = rate(m.winding_number, 1)
        fmt = lambda r: f"{r / 1e6:.2f} M/s"  # noqa: E731
        print(f"| {name} | {fmt(s1)} | {fmt(s2)} | {fmt(u1)} | {fmt(c1)} | {fmt(w1)} |")


def sample(data):
    print("\n### sample_sdf(bunny, 500 000)\n")
    print(f"Load average before: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs.\n")
    print("| call | threads | wall | CPU time (all threads) |")
    print("|---|---|---|---|")
    for threads in (2, 1):
        m = sdfmo.Mesh.load(data / "stanford-bunny.obj")
        t, c = time.perf_counter(), time.process_time()
        p, d = sdfmo.sample_sdf(m, 500_000, seed=1, threads=threads)
        cold, cold_cpu = time.perf_counter() - t, time.process_time() - c
        t, c = time.perf_counter(), time.process_time()
        p2, d2 = sdfmo.sample_sdf(m, 500_000, seed=1, threads=threads)
        warm, warm_cpu = time.perf_counter() - t, time.process_time() - c
        assert np.array_equal(p, p2) and np.array_equal(d, d2)
        print(f"| first call (builds the distance structure) | {threads} | {cold:.3f} s | {cold_cpu:.3f} s |")
        print(f"| second call | {threads} | {warm:.3f} s | {warm_cpu:.3f} s |")


def _statm_rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _hwm():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise RuntimeError("no VmHWM")


def memory_child(path, dtype, n, return_closest):
    m = sdfmo.Mesh.load(path)
    m.signed_distance(np.zeros((10, 3)))  # the distance structure, before the measurement
    pts = np.empty((n, 3), dtype=dtype)
    rng = np.random.default_rng(0)
    lo, hi = m.bounds
    for k in range(0, n, 1 << 20):
        pts[k:k + (1 << 20)] = rng.uniform(lo, hi, size=(min(1 << 20, n - k), 3))
    before = _statm_rss()
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")  # reset the peak (VmHWM) to the current RSS
    out = m.signed_distance(pts, return_closest=return_closest, return_face=return_closest)
    peak = _hwm()
    outs = out if isinstance(out, tuple) else (out,)
    out_bytes = sum(o.nbytes for o in outs)
    print(json.dumps({"in": pts.nbytes, "out": out_bytes, "extra": peak - before}))


def memory(data):
    print("\n### Memory of signed_distance on 10 M points (bunny)\n")
    print("| input | outputs | input + outputs | peak RSS growth during the call | peak / (input + outputs) |")
    print("|---|---|---|---|---|")
    for dtype, rc in (("float32", False), ("float64", False), ("float64", True)):
        r = subprocess.run([sys.executable, __file__, "--memory-child", dtype, str(int(rc)),
                            str(data / "stanford-bunny.obj")], capture_output=True, text=True, check=True)
        j = json.loads(r.stdout.strip().splitlines()[-1])
        io_ = j["in"] + j["out"]
        peak = j["in"] + j["extra"]
        label = "distance, closest, face" if rc else "distance"
        print(f"| {dtype} (n, 3): {j['in'] / 1e6:.0f} MB | {label}: {j['out'] / 1e6:.0f} MB | "
              f"{io_ / 1e6:.0f} MB | {j['extra'] / 1e6:.1f} MB | {peak / io_:.3f} |")


def roundtrip(data, cli):
    print("\n### build -> save -> load -> render round trip against the CLI (bunny, depth 8)\n")
    mesh_path = data / "stanford-bunny.obj"
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        m = sdfmo.Mesh.load(mesh_path)
        t = time.perf_counter()
        octree = m.build(8)
        build_s = time.perf_counter() - t
        octree.save(tmp / "py.smo")
        subprocess.run([cli, "build", mesh_path, "--depth", "8", "-o", tmp / "cli.smo"], check=True,
                       capture_output=True)
        same_bytes = (tmp / "py.smo").read_bytes() == (tmp / "cli.smo").read_bytes()
        loaded = sdfmo.Octree.load(tmp / "py.smo")
        rows = []
        for view in range(4):
            img = loaded.render(512, view=view)
            ref = m.render(512, view=view)
            subprocess.run([cli, "render", tmp / "cli.smo", "--size", "512", "--views", "paper",
                            "-o", tmp / "cli.png"], check=True, capture_output=True)
            cli_img = sdfmo.load_png(tmp / f"cli_{view}.png")
            rows.append((view, np.array_equal(img, cli_img), sdfmo.psnr(ref, img), sdfmo.flip(ref, img)))
        print(f"`.smo` bytes equal to `sdfmo build`: **{same_bytes}** ({octree.nbytes} bytes, "
              f"build {build_s:.2f} s from Python)\n")
        print("| view | image equal to `sdfmo render` | PSNR vs the mesh (dB) | FLIP |")
        print("|---|---|---|---|")
        for v, eq, p, f in rows:
            print(f"| {v} | {eq} | {p:.2f} | {f:.4f} |")


def errors():
    import test_errors

    print("\n### Bad inputs\n")
    print("| input | raises | message |")
    print("|---|---|---|")
    for what, call, exc, _ in test_errors.BAD_INPUTS:
        try:
            call()
            raised, msg = "nothing", ""
        except BaseException as e:  # noqa: BLE001
            raised, msg = type(e).__name__, str(e)
            if type(e).__module__ == "sdfmo":
                raised = "sdfmo." + raised
        msg = msg.replace("|", "\\|").replace("\n", " ")
        if len(msg) > 150:
            msg = msg[:147] + "..."
        print(f"| {what} | `{raised}` | {msg} |")


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--memory-child":
        memory_child(sys.argv[4], sys.argv[2], 10_000_000, sys.argv[3] == "1")
        return
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=str(HERE.parents[2].parent / "shared" / "data"))
    ap.add_argument("--cli", default=str(HERE.parents[2] / "target" / "release" / "sdfmo"))
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--ref-points", type=int, default=500)
    ap.add_argument("--only", default="accuracy,speed,sample,memory,roundtrip,errors")
    a = ap.parse_args()
    data = Path(a.data)
    print(f"sdfmo {sdfmo.__version__}, numpy {np.__version__}, Python {sys.version.split()[0]}, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    only = a.only.split(",")
    if "accuracy" in only:
        accuracy(data, a.ref_points)
    if "speed" in only:
        speed(data, a.points)
    if "sample" in only:
        sample(data)
    if "memory" in only:
        memory(data)
    if "roundtrip" in only:
        roundtrip(data, a.cli)
    if "errors" in only:
        errors()


if __name__ == "__main__":
    main()
