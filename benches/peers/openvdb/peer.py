"""Driver of the OpenVDB / NanoVDB peer (issue 33): references, the build/convert/render/compare
matrix, the interleaved timing of ours and theirs, the hard cases. Called by run.sh; every output
is written atomically under OUT and reused on a rerun (a finished step is skipped).

    peer.py matrix  --out OUT --sdfmo BIN --vdbpeer BIN MODEL...
    peer.py timing  --out OUT --sdfmo BIN --vdbpeer BIN MODEL...
    peer.py hard    --out OUT --sdfmo BIN --vdbpeer BIN
    peer.py intersectors --out OUT --sdfmo BIN --vdbpeer BIN MODEL
    peer.py shifted --out OUT --sdfmo BIN --vdbpeer BIN MODEL...
    peer.py unsigned --out OUT --sdfmo BIN --vdbpeer BIN [OPEN_MODEL...]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # benches/peers
from peerio import atomic_write, load, stem_of  # noqa: E402

VARIANTS = ["float", "fp16", "fp8", "fp4", "fpn"]


def log(*a) -> None:
    print(f"[openvdb {time.strftime('%H:%M:%S', time.gmtime())}]", *a, file=sys.stderr, flush=True)


def run_timed(cmd: list[str], nice: int) -> dict:
    """Runs cmd (under nice), returns stdout, wall s, CPU s (user + sys of the child) via wait4."""
    full = ["nice", "-n", str(nice)] + cmd if nice else cmd
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as errf:
        p = subprocess.Popen(full, stdout=subprocess.PIPE, stderr=errf)
        out = p.stdout.read()  # stderr goes to a file: no pipe to fill while stdout is read
        _, status, ru = os.wait4(p.pid, 0)  # reap with the child's rusage
        errf.seek(0)
        err = errf.read()
    wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        sys.exit(f"peer.py: {' '.join(cmd)} failed ({p.returncode}): {err.decode(errors='replace')[-2000:]}")
    return {"stdout": out.decode(), "wall_s": wall, "cpu_s": ru.ru_utime + ru.ru_stime}


def sha(path: str) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


class Compare:
    """`sdfmo compare` with a cache keyed by (reference, test image) content: identical images
    (NanoVDB float and Fp16 may render the same pixels) are scored once."""

    def __init__(self, sdfmo: str, cache_path: str, nice: int):
        self.sdfmo, self.path, self.nice = sdfmo, cache_path, nice
        self.cache = load(cache_path) if os.path.exists(cache_path) else {}

    def __call__(self, ref: str, test: str) -> dict:
        key = sha(ref) + ":" + sha(test)
        if key not in self.cache:
            r = run_timed([self.sdfmo, "compare", ref, test, "--json"], self.nice)
            c = json.loads(r["stdout"])
            self.cache[key] = {"psnr": c["psnr"], "flip": c["flip"]}
            atomic_write(self.path, json.dumps(self.cache))
        return dict(self.cache[key], test_sha256=key.split(":")[1])


def references(a, models: list[str]) -> dict:
    refs = {}
    for m in models:
        st = stem_of(m)
        d = os.path.join(a.out, "refs", st)
        if not all(os.path.exists(os.path.join(d, f"reference_{k}.png")) for k in range(4)):
            log(f"{st}: mesh references (sdfmo render-mesh, paper views, {a.size}²)")
            os.makedirs(d, exist_ok=True)
            r = run_timed([a.sdfmo, "render-mesh", m, "-o", os.path.join(d, "tmp.png"), "--views", "paper",
                           "--size", str(a.size), "--threads", str(a.threads), "--json"], a.nice)
            for k in range(4):
                os.replace(os.path.join(d, f"tmp_{k}.png"), os.path.join(d, f"reference_{k}.png"))
            atomic_write(os.path.join(d, "render-mesh.json"), r["stdout"])
        refs[st] = d
    return refs


def loadavg() -> float:
    return os.getloadavg()[0]


def cell(a, cmp: Compare, mesh: str, st: str, depth: int, band: int, refdir: str, variants: list[str],
         unsigned_iso: float | None = None) -> None:
    """Build one (model, depth, band), convert, render every variant, compare; cached. With
    unsigned_iso: OpenVDB's unsigned distance field minus that many voxels (files uband*)."""
    d = os.path.join(a.out, "vdb", st, f"d{depth}")
    os.makedirs(d, exist_ok=True)
    pre = "band" if unsigned_iso is None else "uband"
    extra = [] if unsigned_iso is None else ["--unsigned", str(unsigned_iso)]
    bj = os.path.join(d, f"{pre}{band}.build.json")
    done = os.path.join(d, f"{pre}{band}.done.json")
    if os.path.exists(done) and set(load(done)["variants"]) >= set(variants):
        return
    if not os.path.exists(bj):
        la = loadavg()
        r = run_timed([a.vdbpeer, "build", mesh, "--depth", str(depth), "--band", str(band), "--out", d,
                       "--threads", str(a.threads)] + extra, a.nice)
        b = json.loads(r["stdout"])
        b.update(process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"], loadavg_1min=la)
        atomic_write(bj, json.dumps(b))
        log(f"{st} d{depth} {pre} {band}: built in {b['build_ms']:.0f} ms ({b['build_cpu_ms']:.0f} ms CPU), "
            f".vdb {b['vdb_bytes'] / 1e6:.2f} MB, fp4 {b['nanovdb']['fp4']['file_bytes'] / 1e6:.2f} MB")
    res = {"variants": {}}
    for var in variants:
        rj = os.path.join(d, f"{pre}{band}_{var}.render.json")
        grid = os.path.join(d, f"{pre}{band}_{var}.nvdb")
        if not os.path.exists(rj):
            if not os.path.exists(grid):  # grids were removed after an earlier render: rebuild
                os.remove(bj)
                return cell(a, cmp, mesh, st, depth, band, refdir, variants, unsigned_iso)
            la = loadavg()
            r = run_timed([a.vdbpeer, "render", grid, "--out", os.path.join(d, f"{pre}{band}_{var}"),
                           "--size", str(a.size), "--threads", str(a.threads), "--frames", str(a.frames)], a.nice)
            rr = json.loads(r["stdout"])
            rr.update(process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"], loadavg_1min=la)
            atomic_write(rj, json.dumps(rr))
        rr = load(rj)
        cmps = [cmp(os.path.join(refdir, f"reference_{k}.png"), os.path.join(d, f"{pre}{band}_{var}_{k}.png"))
                for k in range(4)]
        res["variants"][var] = {"render": rr, "compare": cmps}
    res["build"] = load(bj)
    atomic_write(done, json.dumps(res))
    ps = {v: sum(c["psnr"] if c["psnr"] is not None else 99 for c in res["variants"][v]["compare"]) / 4 for v in variants}
    log(f"{st} d{depth} {pre} {band}: PSNR " + ", ".join(f"{v} {p:.2f}" for v, p in ps.items()))
    if not a.keep_grids:
        for f in os.listdir(d):
            if f.startswith(f"{pre}{band}") and (f.endswith(".nvdb") or f.endswith(".vdb")):
                os.remove(os.path.join(d, f))


def matrix(a) -> None:
    models = a.models
    refs = references(a, models)
    cmp = Compare(a.sdfmo, os.path.join(a.out, "compare_cache.json"), a.nice)
    depths = [int(x) for x in a.depths.split(",")]
    bands = [int(x) for x in a.bands.split(",")]
    for depth in depths:  # depth-major: every model at the first depths before the next
        for m in models:
            st = stem_of(m)
            for band in bands:
                cell(a, cmp, m, st, depth, band, refs[st], VARIANTS)


def timing(a) -> None:
    """Ours and theirs interleaved, same threads: build (sdfmo build multi / meshToLevelSet band 3
    and band 1) and view-0 render (multi-octree / NanoVDB float band 3, fp8 and fp4 band 1)."""
    out = os.path.join(a.out, "timing")
    os.makedirs(out, exist_ok=True)
    depths = [int(x) for x in a.timing_depths.split(",")]
    for m in a.models:
        st = stem_of(m)
        for depth in depths:
            tj = os.path.join(out, f"{st}_d{depth}.json")
            if os.path.exists(tj):
                continue
            work = os.path.join(out, "work", st, f"d{depth}")
            os.makedirs(work, exist_ok=True)
            smo = os.path.join(work, "multi.smo")
            rec = {"model": st, "depth": depth, "threads": a.threads, "frames": a.timing_frames,
                   "rounds": a.rounds, "samples": {}}

            def add(key, value):
                rec["samples"].setdefault(key, []).append(value)

            for rnd in range(a.rounds):
                def ours_build():
                    la = loadavg()
                    r = run_timed([a.sdfmo, "build", m, "-d", str(depth), "--method", "multi", "--threads",
                                   str(a.threads), "-o", smo, "--json"], a.nice)
                    j = json.loads(r["stdout"])
                    add("ours_build", {"build_ms": j["build_ms"], "process_wall_ms": r["wall_s"] * 1e3,
                                       "process_cpu_ms": r["cpu_s"] * 1e3, "loadavg_1min": la, "bytes": j["bytes"]})

                def theirs_build(band):
                    def f():
                        la = loadavg()
                        r = run_timed([a.vdbpeer, "build", m, "--depth", str(depth), "--band", str(band), "--out", work,
                                       "--threads", str(a.threads)], a.nice)
                        j = json.loads(r["stdout"])
                        add(f"vdb_build_band{band}", {"build_ms": j["build_ms"], "build_cpu_ms": j["build_cpu_ms"],
                                                      "process_wall_ms": r["wall_s"] * 1e3,
                                                      "process_cpu_ms": r["cpu_s"] * 1e3, "loadavg_1min": la})
                    return f

                def ours_render():
                    la = loadavg()
                    r = run_timed([a.sdfmo, "render", smo, "-o", os.path.join(work, "multi.png"), "--threads",
                                   str(a.threads), "--frames", str(a.timing_frames), "--size", str(a.size), "--json"], a.nice)
                    j = json.loads(r["stdout"])
                    add("ours_render", {"render_ms": j["render_ms"], "process_wall_ms": r["wall_s"] * 1e3,
                                        "process_cpu_ms": r["cpu_s"] * 1e3,
                                        "cpu_ms_per_frame": r["cpu_s"] * 1e3 / a.timing_frames, "loadavg_1min": la})

                def theirs_render(band, var):
                    def f():
                        la = loadavg()
                        r = run_timed([a.vdbpeer, "render", os.path.join(work, f"band{band}_{var}.nvdb"), "--out",
                                       os.path.join(work, f"band{band}_{var}"), "--views", "0", "--threads",
                                       str(a.threads), "--frames", str(a.timing_frames), "--size", str(a.size)], a.nice)
                        j = json.loads(r["stdout"])["views"][0]
                        add(f"vdb_render_band{band}_{var}", {
                            "render_ms": j["render_ms"], "render_cpu_ms": j["render_cpu_ms"],
                            "process_wall_ms": r["wall_s"] * 1e3, "process_cpu_ms": r["cpu_s"] * 1e3,
                            "cpu_ms_per_frame": r["cpu_s"] * 1e3 / a.timing_frames, "loadavg_1min": la})
                    return f

                builds = [ours_build, theirs_build(3), theirs_build(1)]
                renders = [ours_render, theirs_render(3, "float"), theirs_render(1, "fp8"), theirs_render(1, "fp4")]
                if rnd % 2:  # alternate who goes first
                    builds = builds[1:] + builds[:1]
                    renders = renders[1:] + renders[:1]
                # the band-1 build must be the last vdb build before the band-1 renders; band 3's file
                # is rewritten each round too (same content)
                for f in builds:
                    f()
                for f in renders:
                    f()
                log(f"{st} d{depth}: timing round {rnd + 1}/{a.rounds} done (load {loadavg():.1f})")
            rec["date"] = time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())
            atomic_write(tj, json.dumps(rec, indent=1))
            shutil.rmtree(work, ignore_errors=True)


def hard(a) -> None:
    """The hard cases: seeded CAD-like parts (`sdfmo generate-parts`: fins thinner than a voxel,
    blocks over thin gaps, a bent open sheet, each feature its own part) through both."""
    hd = os.path.join(a.out, "hard")
    parts = os.path.join(hd, "parts")
    if not os.path.exists(os.path.join(parts, "manifest.csv")):
        run_timed([a.sdfmo, "generate-parts", "-n", str(a.hard_n), "--seed", "1", "-o", parts], a.nice)
    meshes = sorted(os.path.join(parts, f) for f in os.listdir(parts) if f.endswith(".obj"))
    sweep = os.path.join(hd, "sweep")
    if not os.path.exists(os.path.join(sweep, "results.json")):
        log(f"hard cases: sdfmo sweep over {len(meshes)} generated parts, depths {a.hard_depths}")
        run_timed([a.sdfmo, "sweep", *meshes, "--depths", a.hard_depths.replace(",", ".."), "--size", str(a.size),
                   "--threads", str(a.threads), "-o", sweep + ".tmp"], a.nice)
        if os.path.exists(sweep):
            shutil.rmtree(sweep)
        os.replace(sweep + ".tmp", sweep)
    cmp = Compare(a.sdfmo, os.path.join(a.out, "compare_cache.json"), a.nice)
    lo, hi = (int(x) for x in a.hard_depths.split(","))
    for depth in range(lo, hi + 1):
        for m in meshes:
            st = stem_of(m)
            refdir = os.path.join(sweep, "images", st)
            for band in (1, 3):
                cell(a, cmp, m, st, depth, band, refdir, ["float", "fp8", "fp4"])


def shifted(a) -> None:
    """The same level sets with the index origin at world (-1,-1,-1) (`vdbpeer build --shift`):
    the same lattice, so the same values, but the root cube falls in one of NanoVDB's upper
    internal nodes instead of the eight that meet at index (0,0,0). Sizes of every cell of the
    matrix; at the verification depth (band 1) the float and Fp4 grids are rendered and scored
    too, to check that the images match the unshifted ones."""
    refs = references(a, a.models)
    cmp = Compare(a.sdfmo, os.path.join(a.out, "compare_cache.json"), a.nice)
    for depth in [int(x) for x in a.depths.split(",")]:
        for m in a.models:
            st = stem_of(m)
            d = os.path.join(a.out, "vdb", st, f"d{depth}")
            for band in [int(x) for x in a.bands.split(",")]:
                bj = os.path.join(d, f"sband{band}.build.json")
                verify = depth == a.verify_depth and band == 1
                vj = os.path.join(d, f"sband{band}.verify.json")
                if os.path.exists(bj) and (not verify or os.path.exists(vj)):
                    continue
                os.makedirs(d, exist_ok=True)
                la = loadavg()
                r = run_timed([a.vdbpeer, "build", m, "--depth", str(depth), "--band", str(band), "--out", d,
                               "--threads", str(a.threads), "--shift"], a.nice)
                b = json.loads(r["stdout"])
                b.update(process_wall_s=r["wall_s"], process_cpu_s=r["cpu_s"], loadavg_1min=la)
                if verify:
                    res = {}
                    for var in ("float", "fp4"):
                        rr = json.loads(run_timed([a.vdbpeer, "render", os.path.join(d, f"sband{band}_{var}.nvdb"), "--out",
                                                   os.path.join(d, f"sband{band}_{var}"), "--size", str(a.size),
                                                   "--threads", str(a.threads)], a.nice)["stdout"])
                        res[var] = {"render": rr, "compare": [cmp(os.path.join(refs[st], f"reference_{k}.png"),
                                                                  os.path.join(d, f"sband{band}_{var}_{k}.png")) for k in range(4)]}
                    atomic_write(vj, json.dumps(res))
                atomic_write(bj, json.dumps(b))
                log(f"{st} d{depth} band {band} shifted: .vdb {b['vdb_bytes'] / 1e6:.2f} MB, NanoVDB float "
                    f"{b['nanovdb']['float']['file_bytes'] / 1e6:.2f}, fp4 {b['nanovdb']['fp4']['file_bytes'] / 1e6:.2f} MB")
                for f in os.listdir(d):
                    if f.startswith(f"sband{band}") and (f.endswith(".nvdb") or f.endswith(".vdb")):
                        os.remove(os.path.join(d, f))


def unsigned(a) -> None:
    """OpenVDB's tool for open meshes, meshToUnsignedDistanceField, its shell at 0.5 voxel as the
    surface (band 2): the open models given (the teapot) at the finest two depths, and the
    generated parts at their finest depth."""
    refs = references(a, a.models) if a.models else {}
    cmp = Compare(a.sdfmo, os.path.join(a.out, "compare_cache.json"), a.nice)
    depths = sorted(int(x) for x in a.depths.split(","))[-2:]
    for m in a.models:
        for depth in depths:
            cell(a, cmp, m, stem_of(m), depth, 2, refs[stem_of(m)], ["float", "fp8", "fp4"], unsigned_iso=0.5)
    parts = os.path.join(a.out, "hard", "parts")
    if os.path.isdir(parts):
        hd = max(int(x) for x in a.hard_depths.split(","))
        for f in sorted(os.listdir(parts)):
            if f.endswith(".obj"):
                st = stem_of(f)
                cell(a, cmp, os.path.join(parts, f), st, hd, 2, os.path.join(a.out, "hard", "sweep", "images", st),
                     ["float", "fp8", "fp4"], unsigned_iso=0.5)


def intersectors(a) -> None:
    """The first model at the finest depth, band 3, float: NanoVDB's ZeroCrossing as it is
    (--raw), ZeroCrossing refined on the interpolant (--zc), and the exact cell walk (default)."""
    m = a.models[0]
    st, depth, band = stem_of(m), max(int(x) for x in a.depths.split(",")), 3
    oj = os.path.join(a.out, "intersectors.json")
    if os.path.exists(oj):
        return
    refdir = references(a, [m])[st]
    cmp = Compare(a.sdfmo, os.path.join(a.out, "compare_cache.json"), a.nice)
    d = os.path.join(a.out, "intersectors", st)
    os.makedirs(d, exist_ok=True)
    run_timed([a.vdbpeer, "build", m, "--depth", str(depth), "--band", str(band), "--out", d, "--threads",
               str(a.threads)], a.nice)
    res = {"model": st, "depth": depth, "band": band, "modes": {}}
    for mode, flag in (("zerocrossing-raw", ["--raw"]), ("zerocrossing-refined", ["--zc"]), ("exact", [])):
        r = run_timed([a.vdbpeer, "render", os.path.join(d, f"band{band}_float.nvdb"), "--out", os.path.join(d, mode),
                       "--size", str(a.size), "--threads", str(a.threads)] + flag, a.nice)
        rr = json.loads(r["stdout"])
        cs = [cmp(os.path.join(refdir, f"reference_{k}.png"), os.path.join(d, f"{mode}_{k}.png")) for k in range(4)]
        ps = [c["psnr"] for c in cs]
        res["modes"][mode] = {"psnr": None if None in ps else sum(ps) / 4, "flip": sum(c["flip"] for c in cs) / 4,
                              "render_ms": sum(v["render_ms"] for v in rr["views"]) / 4,
                              "psnr_views": ps}
        log(f"intersector {mode}: {res['modes'][mode]['psnr']:.2f} dB")
    for f in os.listdir(d):
        if f.endswith(".nvdb") or f.endswith(".vdb"):
            os.remove(os.path.join(d, f))
    atomic_write(oj, json.dumps(res, indent=1))


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("cmd", choices=["matrix", "timing", "hard", "intersectors", "unsigned", "shifted"])
    ap.add_argument("--verify-depth", type=int, default=9)
    ap.add_argument("models", nargs="*")
    ap.add_argument("--out", required=True)
    ap.add_argument("--sdfmo", required=True)
    ap.add_argument("--vdbpeer", required=True)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--nice", type=int, default=10)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--frames", type=int, default=1)
    ap.add_argument("--depths", default="9,10,6,7,8")
    ap.add_argument("--bands", default="1,2,3")
    ap.add_argument("--keep-grids", action="store_true")
    ap.add_argument("--timing-depths", default="9,10")
    ap.add_argument("--timing-frames", type=int, default=3)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--hard-n", type=int, default=4)
    ap.add_argument("--hard-depths", default="8,9")
    a = ap.parse_args()
    a.models = [os.path.abspath(m) for m in a.models]
    {"matrix": matrix, "timing": timing, "hard": hard, "intersectors": intersectors, "unsigned": unsigned, "shifted": shifted}[a.cmd](a)


if __name__ == "__main__":
    main()
