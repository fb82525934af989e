"""Collects what run.sh measured into results.json (the sweep's row schema) and docs/results/nglod.md.

Every number written comes from the files under OUT (the training logs, render timings,
`sdfmo compare` outputs, SDF checks) and the sweep's results.json; nothing is typed in.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # benches/peers
from peerio import atomic_write, load, pyplot, save_figure  # noqa: E402

LODS = [2, 3, 4, 5]


def collect(out: str) -> dict:
    models = {}
    for d in sorted(glob.glob(os.path.join(out, "models", "*"))):
        stem = os.path.basename(d)
        rj = os.path.join(d, "images", "render.json")
        need = [rj, os.path.join(d, "sdfcheck.json")] + [os.path.join(d, "images", f"compare_lod{k}_{v}.json")
                                                         for k in LODS for v in range(4)]
        missing = [p for p in need if not os.path.exists(p)]
        if missing:
            print(f"report.py: {stem} left out (not finished: {os.path.relpath(missing[0], out)} missing)", file=sys.stderr)
            continue
        m = {"train": load(os.path.join(d, "model.train.json")), "render": load(rj), "lods": {}}
        for k in LODS:
            cmp = [load(os.path.join(d, "images", f"compare_lod{k}_{v}.json")) for v in range(4)]
            psnrs = [c["psnr"] for c in cmp]
            flips = [c["flip"] for c in cmp]
            m["lods"][k] = {
                "psnr_views": psnrs,
                "flip_views": flips,
                "psnr": None if any(p is None for p in psnrs) else statistics.fmean(psnrs),
                "flip": statistics.fmean(flips),
                "render_ms_views": m["render"]["render_ms_views"][str(k)],
                "render_cpu_ms_views": m["render"]["render_cpu_ms_views"][str(k)],
                "size": m["render"]["sizes"][str(k)],
            }
        sc = os.path.join(d, "sdfcheck.json")
        m["sdfcheck"] = load(sc) if os.path.exists(sc) else None
        tj = os.path.join(d, "timing.json")
        m["timing"] = load(tj) if os.path.exists(tj) else None
        pc = os.path.join(d, "paper_cost.json")
        m["paper_cost"] = load(pc) if os.path.exists(pc) else None
        gp = os.path.join(d, "gap.train.json")
        m["gap"] = load(gp) if os.path.exists(gp) else None
        models[stem] = m
    if not models:
        sys.exit(f"report.py: no rendered model under {out}/models")
    return models


def rows_of(models: dict) -> list[dict]:
    rows = []
    for stem, m in models.items():
        for k in LODS:
            r = m["lods"][k]
            rows.append({
                "model": stem, "method": "nglod", "depth": k + 5, "lod": k,
                "psnr": r["psnr"], "flip": r["flip"], "bytes": r["size"]["bytes"],
                "build_ms": m["train"]["train_s"] * 1000.0,
                "render_ms": statistics.fmean(r["render_ms_views"]),
                "psnr_views": r["psnr_views"], "flip_views": r["flip_views"],
            })
    return rows


def sweep_rows(sweep: dict) -> dict:
    return {(r["model"], r["method"], r["depth"]): r for r in sweep["rows"]}


def f(x, nd=2):
    if x is None:
        return "∞"
    return f"{x:.{nd}f}"


def mb(b):
    return f"{b / 1e6:.3f}"


def comparable(m: dict, target: int) -> int:
    """The LOD whose size is closest to `target` bytes (in log ratio)."""
    return min(LODS, key=lambda k: abs(math.log(m["lods"][k]["size"]["bytes"] / target)))


def not_smaller(m: dict, target: int):
    ks = [k for k in LODS if m["lods"][k]["size"]["bytes"] >= target]
    return min(ks) if ks else None


def plot_curve(m: dict, stem: str, path: str) -> None:
    plt = pyplot()
    ep = m["train"]["epochs"]
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    x = [e["epoch"] for e in ep]
    for j in range(len(ep[0]["loss_per_lod"])):
        ax[0].semilogy(x, [e["loss_per_lod"][j] for e in ep], label=f"LOD {j + 1}")
    ax[0].set_xlabel("epoch")
    ax[0].set_ylabel("training L2 loss (mean per sample)")
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"{stem}: loss per LOD")
    pe = [e for e in ep if "psnr_view0" in e]
    for k in LODS:
        ax[1].plot([e["epoch"] for e in pe], [e["psnr_view0"][str(k)] for e in pe], marker="o", label=f"LOD {k}")
    ax[1].set_xlabel("epoch")
    ax[1].set_ylabel("PSNR (dB), view 0 at 256²")
    ax[1].legend(fontsize=8)
    ax[1].set_title(f"{stem}: PSNR vs epoch")
    fig.tight_layout()
    save_figure(fig, path, dpi=90)


def samples_per_epoch(sched: dict) -> int:
    return sched["n_uniform"] + sched["n_near"] + sched["n_surface"]


def plot_gap(m: dict, stem: str, path: str) -> None:
    """PSNR (view 0, 256²) per LOD against samples seen: the short run and the gap run."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for run, style, label in ((m["gap"], "-", "long run"), (m["train"], "--", "short run")):
        per = samples_per_epoch(run["schedule"])
        pe = [e for e in run["epochs"] if "psnr_view0" in e]
        for j, k in enumerate(LODS):
            ax.semilogx([e["epoch"] * per for e in pe], [e["psnr_view0"][str(k)] for e in pe], style,
                        marker="o", ms=3, color=colors[j % len(colors)], label=f"LOD {k}, {label}")
    pc = m.get("paper_cost")
    if pc:
        ax.axvline(samples_per_epoch(pc["schedule"]) * pc["schedule"]["epochs"], color="k", lw=0.8, ls=":")
        ax.text(samples_per_epoch(pc["schedule"]) * pc["schedule"]["epochs"], ax.get_ylim()[0], " paper schedule",
                rotation=90, va="bottom", fontsize=8)
    ax.set_xlabel("training samples seen")
    ax.set_ylabel("PSNR (dB), view 0 at 256²")
    ax.set_title(f"{stem}: training length against quality")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    save_figure(fig, path, dpi=90)


def montage(out: str, reference: str, stem: str, path: str) -> None:
    """The reference PNG and LODs 2-5 of view 0 (from run.sh's OUT layout), each downsampled 2x
    (512²), side by side."""
    import sdfmo
    imgs = [sdfmo.load_png(reference)]
    imgs += [sdfmo.load_png(os.path.join(out, "models", stem, "images", f"nglod_lod{k}_0.png")) for k in LODS]
    small = [im.reshape(im.shape[0] // 2, 2, im.shape[1] // 2, 2, 3).mean((1, 3)).round().astype(np.uint8) for im in imgs]
    gap = np.full((small[0].shape[0], 4, 3), 255, np.uint8)
    row = [small[0]]
    for s in small[1:]:
        row += [gap, s]
    tmp = path + ".tmp.png"
    sdfmo.save_png(tmp, np.concatenate(row, axis=1))
    os.replace(tmp, path)


def nglod_rows(results: dict) -> dict:
    """(model, lod) -> NGLOD row of a results.json written by this script."""
    return {(r["model"], r["lod"]): r for r in results["rows"] if r["method"] == "nglod"}


def paper_run_summary(path: str, sr: dict) -> str:
    """The tail of a sentence: what the paper schedule's run (its page's results.json) measured."""
    d = load(path)
    rows = nglod_rows(d)
    parts = []
    for stem, cost in d["nglod"].items():
        cells = []
        for k in LODS:
            r, u = rows[(stem, k)], sr.get((stem, "multi", k + 5))
            cells.append(f"LOD {k} {f(r['psnr'])} dB" + (f" (multi d{k + 5} {f(u['psnr'])})" if u else ""))
        parts.append(f"{stem}, {cost['train_s'] / 3600:.2f} h wall ({(cost.get('train_cpu_s') or float('nan')) / 3600:.2f} h "
                     "CPU): " + ", ".join(cells))
    return ("; the paper's schedule itself was run to the end on " + "; ".join(parts)
            + " ([nglod-paper.md](nglod-paper.md), 1024² protocol, 4 views).")


def compare_runs(w, path: str, models: dict, sched: dict, sr: dict) -> None:
    """This run's NGLOD rows against an earlier run's (another schedule), for the models both ran."""
    other = load(path)
    rows = nglod_rows(other)
    both = [stem for stem in models if stem in other.get("nglod", {})]
    if not both:
        return
    w(f"## This schedule against the earlier `{other['nglod'][both[0]]['schedule'].get('name', 'custom')}` run")
    w("")
    w(f"The earlier run's NGLOD rows are read from `{os.path.relpath(path)}` (produced "
      f"{other['provenance']['date']}); both runs are scored by `sdfmo compare` against the same protocol's mesh "
      "references, 4 views at 1024².")
    w("")
    for stem in both:
        od = other["nglod"][stem]
        osch, m = od["schedule"], models[stem]
        on, tn = samples_per_epoch(osch) * osch["epochs"], samples_per_epoch(sched) * sched["epochs"]
        w(f"**{stem}**: `{osch.get('name', 'custom')}` saw {on:,} samples in {od['train_s']:.0f} s wall "
          f"({od.get('train_cpu_s') or float('nan'):.0f} s CPU); `{sched.get('name', 'custom')}` saw {tn:,} "
          f"({tn / on:.0f}×) in {m['train']['train_s']:.0f} s wall ({m['train'].get('train_cpu_s', float('nan')):.0f} s CPU).")
        w("")
        w(f"| LOD | {osch.get('name')} PSNR | FLIP | {sched.get('name')} PSNR | FLIP | ΔPSNR | multi d k+5 PSNR | multi − {sched.get('name')} |")
        w("|---:|---:|---:|---:|---:|---:|---:|---:|")
        for k in LODS:
            o, r = rows.get((stem, k)), m["lods"][k]
            u = sr.get((stem, "multi", k + 5))
            def gain(hi, lo):  # None (a missing row, or an infinite PSNR) shows as "–"
                return "–" if not hi or not lo or hi["psnr"] is None or lo["psnr"] is None else f"{hi['psnr'] - lo['psnr']:+.2f}"
            earlier = f"{f(o['psnr'])} | {o['flip']:.4f}" if o else "– | –"
            w(f"| {k} | {earlier} | {f(r['psnr'])} | {r['flip']:.4f} | {gain(r, o)} | "
              f"{f(u['psnr']) if u else '–'} | {gain(u, r)} |")
        w("")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", required=True)
    ap.add_argument("--sweep", required=True)
    ap.add_argument("--curve", required=True)
    ap.add_argument("--docs")
    ap.add_argument("--combined")
    ap.add_argument("--rows-only", action="store_true")
    ap.add_argument("--doc", default="nglod", help="writes DOCS/DOC.md and its figures under DOCS/DOC/")
    ap.add_argument("--compare-with", help="results.json of an earlier run (another schedule): a section "
                    "comparing its NGLOD rows with this run's, for the models both ran")
    a = ap.parse_args()

    models = collect(a.out)
    rows = rows_of(models)
    details = {stem: {
        "schedule": m["train"]["schedule"], "threads": m["train"]["threads"], "torch": m["train"]["torch"],
        "cells_per_level": m["train"]["cells"], "corners_per_level": m["train"]["corners"],
        "train_s": m["train"]["train_s"], "train_cpu_s": m["train"].get("train_cpu_s"),
        "sizes": {str(k): m["lods"][k]["size"] for k in LODS},
        "render_threads": m["render"]["threads"],
        "render_ms_views": {str(k): m["lods"][k]["render_ms_views"] for k in LODS},
        "render_cpu_ms_views": {str(k): m["lods"][k]["render_cpu_ms_views"] for k in LODS},
        "sdfcheck": m["sdfcheck"], "paper_cost": m["paper_cost"],
    } for stem, m in models.items()}
    res = {"rows": rows, "nglod": details,
           "provenance": {"date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                          "producer": "benches/peers/nglod/run.sh"}}
    atomic_write(os.path.join(a.out, "results.json"), json.dumps(res, indent=1))
    if a.rows_only or not a.docs:
        return
    sweep = load(os.path.join(a.sweep, "results.json"))

    sr = sweep_rows(sweep)
    sweep_threads = sweep["settings"]["threads"]
    docs = a.docs
    figdir = os.path.join(docs, a.doc)
    os.makedirs(figdir, exist_ok=True)
    curve = a.curve if a.curve in models else next(iter(models))
    plot_curve(models[curve], curve, os.path.join(figdir, f"curve_{curve}.png"))
    if models[curve]["gap"]:
        plot_gap(models[curve], curve, os.path.join(figdir, f"gap_{curve}.png"))
    montage(a.out, os.path.join(a.sweep, "images", curve, "reference_0.png"), curve,
            os.path.join(figdir, f"lods_{curve}_view0.png"))
    atomic_write(os.path.join(figdir, "results.json"), json.dumps(res, indent=1))

    L = []
    w = L.append
    any_m = next(iter(models.values()))
    sched = any_m["train"]["schedule"]
    thr = any_m["render"]["threads"]
    w("# NGLOD against the multi-octree (the paper's Tables 3–5, issue 22)")
    w("")
    name = sched.get("name")
    sched_env = "" if name == "short" else f"NGLOD_SCHEDULE={name if name == 'paper' else repr(json.dumps(sched))} "
    w("*Generated by `" + sched_env + "benches/peers/nglod/run.sh " + " ".join(models) + "` on "
      + res["provenance"]["date"] + "; do not edit by hand (the prose around the numbers is in "
      "`benches/peers/nglod/report.py`).*")
    w("")
    if a.doc != "nglod":  # a run page; the reference comparison is page.py's
        w("*A run page. The reference comparison, NGLOD at its paper's schedule on all five models with seed "
          "spread, is [nglod.md](nglod.md); the claims below hold for this run's schedule only.*")
        w("")
    is_paper = sched.get("name") == "paper"
    loads = [e["loadavg_1min"] for m in models.values() for e in m["train"]["epochs"] if "loadavg_1min" in e]
    if loads:
        load_txt = ("The 1-minute load average of its 2 cores while NGLOD trained was "
                    f"{min(loads):.1f}–{max(loads):.1f} (median {statistics.median(loads):.1f}; NGLOD's own "
                    f"{any_m['train']['threads']} threads make {any_m['train']['threads']:.1f}), "
                    + ("so the cores were its own; " if statistics.median(loads) <= any_m["train"]["threads"] + 0.3
                       else "so other work shared the cores and wall times include it; ")
                    + "CPU times are given beside wall times. ")
    else:  # logs from before the load was recorded (the session of the short run)
        load_txt = ("Other engineers compiled Rust on the same cores (every heavy step ran under `nice -n 19`): "
                    "wall times are inflated several times and vary run to run; CPU times are given beside them. ")
    sched_txt = ("The NGLOD models were trained with **the paper's schedule** (see *Schedule* below). " if is_paper
                 else f"The NGLOD models were trained with the **`{sched.get('name', 'custom')}` schedule**, "
                 "not the paper's (see *Schedule* below): NGLOD's PSNR here is a lower bound on what its full "
                 "schedule reaches. ")
    w("**Read this first.** The numbers below were measured on the project's shared 2-core machine. "
      + load_txt + sched_txt + "Models run: " + ", ".join(models) + "."
      + (" In the sweep but with no finished NGLOD run (not counted anywhere below): "
         + ", ".join(m["model"] for m in sweep["models"] if m["model"] not in models) + "."
         if any(m["model"] not in models for m in sweep["models"]) else ""))
    w("")
    w("## What was run")
    w("")
    w("- NGLOD written from its paper in PyTorch (`benches/peers/nglod/nglod.py`): a sparse octree of the "
      "surface with LOD k at resolution 2^(k+1) (LOD 1–5: 4³ … 64³; a cell is kept when the exact unsigned "
      "distance from its centre is at most its half-diagonal), 32 learned floats at the distinct corners of "
      "the kept cells of each level, trilinearly interpolated and summed over levels 1..k, one decoder per LOD "
      "([features, xyz] → 128 ReLU → 1), L2 loss summed over the 5 LODs, Adam.")
    w("- Training samples: `sdfmo.sample_sdf` on the mesh normalised into [-1, 1]³ exactly as the octree "
      "builder does: uniform in the bounding box padded by 10 % of its longest extent, near the surface "
      "(surface points + Gaussian noise of σ = 0.01 in the normalised frame), and on the surface; fresh "
      "samples every `resample_every` epochs.")
    w("- Rendering: a sphere tracer over the sparse octree of the rendered LOD (cells not kept are skipped "
      "through a Chebyshev distance map of the level's grid), hit when |f| is below a quarter of the pixel's footprint at that distance, at most 128 steps (a ray "
      "still stepping then is a miss), normals "
      "from autograd of the network, the paper protocol (4 views, 1024², fov 60°, lambert, two-sided, black "
      "background, 8-bit). PSNR and FLIP are `sdfmo compare` against the sweep's own mesh references "
      f"(`{os.path.relpath(a.sweep)}/images/MODEL/reference_K.png`), so each cell compares with the sweep's "
      "cell for cell. The octree rows are that `sdfmo sweep` (depths 7–10, 1024², "
      f"{sweep['settings']['threads']} threads), run {sweep['provenance']['date']} on commit "
      f"`{sweep['provenance']['git_commit'][:10]}`.")
    w("- Size: bytes of float32 parameters needed to render LOD k: the features of levels 1..k, decoder k, "
      "and the octree as one child-mask byte per internal node. The paper's NGLOD sizes (0.14 / 0.76 / 5.16 / "
      "38.71 MB at LOD 2–5) match **dense** feature grids ((2^(k+1)+1)³ × 32 floats per level), which the "
      "NGLOD code trains; the `dense MB` column gives that count for comparison.")
    w(f"- Render time: one frame per view and LOD, wall clock of the whole Python tracer, torch with "
      f"{thr} threads, views outer and LODs inner (interleaved), mean over the 4 views. The octree columns "
      f"are the sweep's render times (Rust, {sweep_threads} threads) measured in the same session.")
    w("")
    w("## Schedule")
    w("")
    w("- **Used here** (`" + str(sched.get("name", "custom")) + "`): `" + json.dumps(sched) + "`. Adam on the L2 "
      "loss summed over LODs 1–5; fresh samples (uniform : near : surface as in the JSON) every "
      "`resample_every` epochs.")
    w("- **The paper's** (NGLOD's published recipe as we read it, `NGLOD_SCHEDULE=paper`): 250 epochs, batch 512, "
      "Adam lr 1e-3, 500,000 fresh samples per epoch (100k uniform, 200k near, 200k on the surface). Its cost on this "
      "machine is " + ("measured below (this run)." if is_paper else "extrapolated below from timed steps."))
    if is_paper:
        w("- **Budget.** The issue's two hours of two cores for the five models do not hold this schedule (see its "
          "measured cost below); it asks instead that one model be trained to it to measure what it costs, which is "
          "this run.")
    else:
        w("- **Budget.** The issue asks for the five models in about two hours of two idle cores. Per model that is "
          "about 24 minutes for training, rendering 16 frames of 1024² and comparing; the measured costs below "
          "(training per epoch, render per frame) say what a schedule costs. The `short` schedule was chosen when "
          "the session that first ran it had far less than two idle cores (other engineers compiled Rust "
          "throughout, NGLOD ran at nice 19), to finish at least one model end to end and as many more as time "
          "allowed.")
    w("")

    # Table 3 per model
    w("## Table 3 layout per model (depth d against LOD d − 5)")
    w("")
    for stem, m in models.items():
        w(f"### {stem}")
        w("")
        w("| depth / LOD | NGLOD PSNR | FLIP | MB | dense MB | ms/frame (CPU ms) | SVO PSNR | MB | ms | multi PSNR | FLIP | MB | ms |")
        w("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for k in LODS:
            r = m["lods"][k]
            s = sr.get((stem, "svo", k + 5))
            u = sr.get((stem, "multi", k + 5))
            cells = [f"{k + 5} / {k}", f(r["psnr"]), f"{r['flip']:.4f}", mb(r["size"]["bytes"]),
                     mb(r["size"]["dense_bytes"]),
                     f"{statistics.fmean(r['render_ms_views']):.0f} ({statistics.fmean(r['render_cpu_ms_views']):.0f})"]
            for q in (s,):
                cells += [f(q["psnr"]), mb(q["bytes"]), f"{q['render_ms']:.1f}"] if q else ["–"] * 3
            cells += [f(u["psnr"]), f"{u['flip']:.4f}", mb(u["bytes"]), f"{u['render_ms']:.1f}"] if u else ["–"] * 4
            w("| " + " | ".join(cells) + " |")
        w("")

    inv = [f"{stem} (LOD {k + 1}: {f(m['lods'][k + 1]['psnr'])} dB < LOD {k}: {f(m['lods'][k]['psnr'])} dB)"
           for stem, m in models.items() for k in LODS[:-1]
           if m["lods"][k]["psnr"] is not None and m["lods"][k + 1]["psnr"] is not None
           and m["lods"][k + 1]["psnr"] < m["lods"][k]["psnr"]]
    if inv:
        w("A finer LOD scoring below a coarser one: " + "; ".join(inv) + ". The finest levels have the most "
          "features and each sees the fewest samples, so a short schedule leaves them noisiest (bumps at the "
          "scale of their cells)" + ("." if is_paper else "; the paper's schedule trains them 100× longer."))
        w("")
    w("Why NGLOD's frames take seconds here: the tracer is vectorised PyTorch on the CPU (each of up to "
      "128 steps is a handful of tensor operations over the active rays, plus the network on the rays inside "
      "kept cells). The paper's NGLOD CPU times (719–1623 ms per frame) come from a dedicated implementation; "
      "ours are an upper bound on what NGLOD costs, not a measurement of the best NGLOD renderer.")
    w("")

    # Tables 4 and 5
    def table45(title, pick, note):
        w(title)
        w("")
        w(note)
        w("")
        w("| model | multi d9 PSNR | MB | ms | SVO d9 PSNR | MB | NGLOD LOD | PSNR | MB | ms | ΔPSNR multi − NGLOD | size NGLOD / multi | time NGLOD / multi |")
        w("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        out = []
        for stem, m in models.items():
            u = sr.get((stem, "multi", 9))
            s = sr.get((stem, "svo", 9))
            if not u:
                continue
            k = pick(m, u["bytes"])
            if k is None:
                w(f"| {stem} | {f(u['psnr'])} | {mb(u['bytes'])} | {u['render_ms']:.1f} | "
                  f"{f(s['psnr']) if s else '–'} | {mb(s['bytes']) if s else '–'} | none | – | – | – | – | – | – |")
                continue
            r = m["lods"][k]
            ms = statistics.fmean(r["render_ms_views"])
            dp = None if (u["psnr"] is None or r["psnr"] is None) else u["psnr"] - r["psnr"]
            out.append((stem, k, dp, r["size"]["bytes"] / u["bytes"], ms / u["render_ms"]))
            w(f"| {stem} | {f(u['psnr'])} | {mb(u['bytes'])} | {u['render_ms']:.1f} | "
              f"{f(s['psnr']) if s else '–'} | {mb(s['bytes']) if s else '–'} | {k} | {f(r['psnr'])} | "
              f"{mb(r['size']['bytes'])} | {ms:.0f} | {('+' if dp is not None and dp >= 0 else '') + f(dp)} | "
              f"{r['size']['bytes'] / u['bytes']:.2f} | {ms / u['render_ms']:.0f} |")
        w("")
        return out

    t4 = table45("## Table 4: depth 9 against NGLOD of comparable size",
                 comparable, "NGLOD's LOD whose size is closest (in ratio) to the multi-octree's at depth 9.")
    t5 = table45("## Table 5: depth 9 against NGLOD of not smaller size",
                 not_smaller, "The smallest NGLOD LOD at least as large as the multi-octree at depth 9 "
                 "(\"none\" where even LOD 5 is smaller).")

    w("By the paper's count (dense feature grids, the `dense MB` column) the pairing changes: "
      + "; ".join(
          f"{stem}: comparable LOD {min(LODS, key=lambda k: abs(math.log(m['lods'][k]['size']['dense_bytes'] / sr[(stem, 'multi', 9)]['bytes'])))}"
          + f", not smaller LOD {next((k for k in LODS if m['lods'][k]['size']['dense_bytes'] >= sr[(stem, 'multi', 9)]['bytes']), 'none')}"
          for stem, m in models.items() if (stem, "multi", 9) in sr)
      + ". The tables above use the sparse count, which is what this implementation stores.")
    w("")

    # Claims
    w("## The claims, checked")
    w("")
    n = len(t4)
    wins = [t for t in t4 if t[2] is not None and t[2] > 0]
    w(f"- **Multi-octree PSNR above NGLOD at comparable size: {len(wins)} of {n} models** run "
      f"(of the 5 the issue names; models not run are not counted). ΔPSNR: "
      + ", ".join(f"{t[0]} {('+' if t[2] >= 0 else '') + f(t[2])} dB (LOD {t[1]})" for t in t4 if t[2] is not None) + ".")
    if t5:
        w("- Against NGLOD of not smaller size: multi-octree ahead on "
          f"{sum(1 for t in t5 if t[2] is not None and t[2] > 0)} of {len(t5)} models where such a LOD exists ("
          + ", ".join(f"{t[0]} LOD {t[1]} {('+' if t[2] >= 0 else '') + f(t[2])} dB" for t in t5 if t[2] is not None) + ").")
    if t4:
        w(f"- **Render time** NGLOD / multi-octree at comparable size: "
          + ", ".join(f"{t[0]} {t[4]:.0f}×" for t in t4)
          + f" (median {statistics.median(t[4] for t in t4):.0f}×). Not like for like: a PyTorch tracer "
          f"({thr} threads) against the Rust kernel ({sweep_threads} threads), single frames taken at different "
          "times on the loaded machine; the paper's claim is 10–20× on its own CPU implementations."
          + "".join(f" Measured interleaved on {st} (table below): "
                    + ", ".join(f"LOD {k} / multi d{k + 5} {statistics.median(tm['wall_ms'][f'nglod_lod{k}']) / statistics.median(tm['wall_ms'][f'multi_d{k + 5}']):.0f}×" for k in LODS)
                    + " (wall)." for st, tm in ((st, mm['timing']) for st, mm in models.items() if mm.get('timing'))))
        w(f"- **Size** NGLOD / multi-octree at comparable size: "
          + ", ".join(f"{t[0]} {t[3]:.2f}" for t in t4) + ".")
    nw = []
    for stem, m in models.items():
        for k in LODS:
            r = m["lods"][k]
            for meth in ("svo", "multi"):
                q = sr.get((stem, meth, k + 5))
                if q and r["psnr"] is not None and q["psnr"] is not None and r["psnr"] > q["psnr"]:
                    nw.append(f"{stem} LOD {k} ({f(r['psnr'])} dB, {mb(r['size']['bytes'])} MB) over {meth} d{k + 5} "
                              f"({f(q['psnr'])} dB, {mb(q['bytes'])} MB)")
    smaller_better = []
    for stem, m in models.items():
        for k in LODS:
            r = m["lods"][k]
            for meth in ("svo", "multi"):
                for d in (7, 8, 9, 10):
                    q = sr.get((stem, meth, d))
                    if q and r["psnr"] is not None and q["psnr"] is not None and r["psnr"] >= q["psnr"] \
                            and r["size"]["bytes"] <= q["bytes"]:
                        smaller_better.append(f"{stem} LOD {k} vs {meth} d{d}")
    w("- **Where NGLOD wins.** At the paired depth (LOD k against depth k + 5): "
      + ("; ".join(nw) if nw else "nowhere in these runs") + ". Smaller *and* at least as good as an octree "
      "of any depth 7–10: " + (", ".join(smaller_better) if smaller_better else "no case in these runs") + ".")
    comp = []
    for stem, m in models.items():
        q = min((sr[(stem, meth, 7)] for meth in ("svo", "multi") if (stem, meth, 7) in sr), key=lambda r: r["bytes"], default=None)
        if q:
            r = m["lods"][2]
            comp.append(f"{stem} LOD 2 {mb(r['size']['bytes'])} MB ({f(r['psnr'])} dB) against the smallest octree "
                        f"here, {q['method']} d7, {mb(q['bytes'])} MB ({f(q['psnr'])} dB): {q['bytes'] / r['size']['bytes']:.1f}× smaller")
    smaller_rows = sum(1 for stem, m in models.items() for k in LODS
                       if (stem, "multi", k + 5) in sr and m["lods"][k]["size"]["bytes"] < sr[(stem, "multi", k + 5)]["bytes"])
    all_rows = sum(1 for stem, m in models.items() for k in LODS if (stem, "multi", k + 5) in sr)
    w(f"- **Where NGLOD wins: size.** NGLOD LOD k is smaller than the multi-octree at depth k + 5 in {smaller_rows} of "
      f"{all_rows} rows (sparse count), and it reaches sizes no octree depth here does (extreme compression, as the "
      "paper notes for LOD 2): " + "; ".join(comp) + ". It buys that size with quality.")
    w("")

    # Interleaved timing
    tms = [(stem, m["timing"]) for stem, m in models.items() if m.get("timing")]
    if tms:
        w("## Render time, interleaved (view 0, same machine, same threads)")
        w("")
        for stem, tm in tms:
            w(f"{stem}: {tm['reps']} rounds of [NGLOD LOD k, SVO d k+5, multi d k+5 for k = 2..5], each a 1024² frame of "
              f"view 0, {tm['threads']} threads for torch and for sdfmo (`Octree.render` from Python, the same Rust "
              "renderer as the sweep); median wall ms (median CPU ms) per frame:")
            w("")
            w("| depth / LOD | NGLOD | SVO | multi | NGLOD / multi (wall) | NGLOD / multi (CPU) |")
            w("|---|---:|---:|---:|---:|---:|")
            for k in LODS:
                med = lambda key, kind="wall_ms": statistics.median(tm[kind][key])
                n_, s_, u_ = f"nglod_lod{k}", f"svo_d{k + 5}", f"multi_d{k + 5}"
                w(f"| {k + 5} / {k} | {med(n_):.0f} ({med(n_, 'cpu_ms'):.0f}) | {med(s_):.0f} ({med(s_, 'cpu_ms'):.0f}) | "
                  f"{med(u_):.0f} ({med(u_, 'cpu_ms'):.0f}) | {med(n_) / med(u_):.0f}× | "
                  f"{med(n_, 'cpu_ms') / med(u_, 'cpu_ms'):.0f}× |")
            w("")
        w("The Table 3 render times above are single frames taken as each step ran (the sweep's while other work "
          "shared the cores), so their ratios are noisier than these.")
        w("")

    # A page of the paper schedule's run beside this one (`NGLOD_SCHEDULE=paper`), if there is one.
    paper_json = os.path.join(docs, "nglod-paper", "results.json")
    paper_page = paper_json if a.doc != "nglod-paper" and os.path.exists(paper_json) else None

    # Training curve and cost
    cm = models[curve]
    w(f"## Training curve ({curve})")
    w("")
    w(f"![loss and PSNR per epoch]({a.doc}/curve_{curve}.png)")
    w("")
    ep = cm["train"]["epochs"]
    w(f"{len(ep)} epochs of {ep[0]['steps']} steps (batch {sched['batch']}); PSNR on view 0 at 256² against "
      "the mesh rendered at 256² (the curve's own reference, not the 1024² protocol). Last epochs' summed loss: "
      + ", ".join(f"{e['loss']:.3e}" for e in ep[-3:]) + "; PSNR at the last curve points (LOD 5): "
      + ", ".join(f"{e['psnr_view0']['5']:.2f}" for e in ep if "psnr_view0" in e) + ".")
    w(f"Training took {cm['train']['train_s']:.0f} s wall, {cm['train'].get('train_cpu_s', float('nan')):.0f} s CPU "
      f"(torch {cm['train']['torch']}, {cm['train']['threads']} threads).")
    w("")
    pc = cm["paper_cost"]
    if is_paper:
        tr = cm["train"]
        ep_wall = [e["sample_s"] + e["step_s"] for e in ep]
        w(f"**Cost of the paper's schedule (measured, this run).** {len(ep)} epochs, {sum(e['steps'] for e in ep):,} "
          f"Adam steps of batch {sched['batch']}, {samples_per_epoch(sched) * len(ep):,} samples: "
          f"**{tr['train_s'] / 3600:.2f} h wall, {tr['train_cpu_s'] / 3600:.2f} h CPU** for {curve} at {tr['threads']} "
          f"threads, the curve's renders included. Per epoch: median {statistics.median(ep_wall):.1f} s wall "
          f"(sampling {statistics.median(e['sample_s'] for e in ep):.2f} s of it, in Rust), "
          f"{statistics.median(e['cpu_s'] for e in ep):.1f} s CPU."
          + (f" The extrapolation from {pc['steps_timed']} timed steps (`nglod.py timepaper`, run after training on "
             f"this machine) gives {pc['total_wall_s'] / 3600:.2f} h wall, {pc['total_cpu_s'] / 3600:.2f} h CPU."
             if pc else ""))
        w("")
    elif pc:
        w("**Cost of the paper's schedule (an extrapolation, not a run).** One epoch of the paper schedule "
          f"was timed on {curve}: sampling {pc['samples_per_epoch']:,} points took {pc['sample_wall_s']:.1f} s wall "
          f"({pc['sample_cpu_s']:.1f} s CPU), one Adam step at batch {pc['schedule']['batch']} "
          f"{pc['step_wall_s_median'] * 1000:.0f} ms wall ({pc['step_cpu_s_median'] * 1000:.0f} ms CPU, median of "
          f"{pc['steps_timed']}); {pc['steps_per_epoch']} steps per epoch make an epoch "
          f"{pc['epoch_wall_s']:.0f} s wall ({pc['epoch_cpu_s']:.0f} s CPU) and {pc['schedule']['epochs']} epochs "
          f"**{pc['total_wall_s'] / 3600:.1f} h wall ({pc['total_cpu_s'] / 3600:.1f} h CPU) per model** at "
          f"{pc['threads']} threads on this loaded machine. The session's short schedule used "
          f"{cm['train'].get('train_cpu_s', float('nan')) / pc['total_cpu_s'] * 100:.1f} % of that CPU time.")
        rend_min = sum(sum(cm["lods"][k]["render_cpu_ms_views"]) for k in LODS) / 60000.0
        left = 48.0 - rend_min  # CPU-minutes
        w("")
        w(f"**What the issue's budget allows.** Two hours of two cores for five models is 24 min per model "
          f"(48 CPU-minutes). Rendering the 16 frames took {rend_min:.0f} CPU-minutes on {curve}; the rest, "
          f"{max(left, 0):.0f} CPU-minutes if training used both cores fully, is "
          f"{max(left, 0) * 60 / pc['total_cpu_s'] * 100:.1f} % of the paper schedule's CPU time (measured on this "
          "loaded machine; an idle one would do better, but not by the factor missing): NGLOD's recipe does not "
          "fit the budget on this CPU, so any schedule that does is a shortened one, as here.")
        w("")

    gm = cm["gap"]
    if gm:
        short_n = samples_per_epoch(sched) * len(ep)
        long_ep = gm["epochs"]
        long_n = samples_per_epoch(gm["schedule"]) * len(long_ep)
        w(f"## The gap to the full schedule ({curve})")
        w("")
        w(f"![PSNR against samples seen]({a.doc}/gap_{curve}.png)")
        w("")
        pts = [e for e in long_ep if "psnr_view0" in e]
        at_short = [e for e in pts if e["epoch"] <= len(ep)]
        w(f"{curve} trained a second time with the same schedule for {len(long_ep)} epochs instead of {len(ep)} "
          f"({long_n:,} samples seen instead of {short_n:,}; `NGLOD_GAP_EPOCHS`), its curve recorded every "
          f"{pts[1]['epoch'] - pts[0]['epoch'] if len(pts) > 1 else 1} epochs (view 0 at 256², as above). It took "
          f"{gm['train_s']:.0f} s wall, {gm.get('train_cpu_s', float('nan')):.0f} s CPU.")
        w("")
        short_last = [e for e in ep if "psnr_view0" in e][-1]
        w(f"| LOD | short run, end (epoch {len(ep)}) | long run, epoch {at_short[-1]['epoch'] if at_short else '-'} | long run, end | gain of the longer run |")
        w("|---:|---:|---:|---:|---:|")
        for k in LODS:
            same = at_short[-1]["psnr_view0"][str(k)] if at_short else float("nan")
            end = pts[-1]["psnr_view0"][str(k)]
            w(f"| {k} | {short_last['psnr_view0'][str(k)]:.2f} dB | {same:.2f} dB | {end:.2f} dB | "
              f"{end - short_last['psnr_view0'][str(k)]:+.2f} dB |")
        w("")
        w(f"Summed training loss at the end: short {ep[-1]['loss']:.3e}, long {long_ep[-1]['loss']:.3e}.")
        if pc:
            paper_n = samples_per_epoch(pc["schedule"]) * pc["schedule"]["epochs"]
            w(f"The paper's schedule sees {paper_n:,} samples ({paper_n / long_n:.0f}× the long run, "
              f"{paper_n / short_n:.0f}× the short one) in {pc['steps_per_epoch'] * pc['schedule']['epochs']:,} "
              f"steps of batch {pc['schedule']['batch']}. The table says how far the "
              f"short schedule is from converged over {long_n / short_n:.0f}× its samples"
              + (paper_run_summary(paper_page, sr) if paper_page else
                 f"; the paper's schedule itself is not measured here (about {pc['total_cpu_s'] / 3600:.1f} h of "
                 "CPU per model), and the NGLOD rows above are lower bounds on what NGLOD's recipe reaches."))
        w("")

    if a.compare_with:
        compare_runs(w, a.compare_with, models, sched, sr)

    # SDF check
    w("## SDF check on held-out points")
    w("")
    w("|f_k − d| in the normalised frame (the root cube has edge 2; a depth-9 voxel has edge 0.0039) on points "
      "drawn like the training set with a seed no epoch used (uniform / near / surface = 1 : 2 : 2).")
    w("")
    w("| model | LOD | mean | max | mean on the surface | max on the surface | mean, uniform points |")
    w("|---|---:|---:|---:|---:|---:|---:|")
    for stem, m in models.items():
        if not m["sdfcheck"]:
            continue
        for k in range(1, 6):
            r = m["sdfcheck"]["per_lod"][str(k)]
            w(f"| {stem} | {k} | {r['mean']:.5f} | {r['max']:.4f} | {r['surface_mean']:.5f} | {r['surface_max']:.4f} | {r['uniform_mean']:.5f} |")
    w("")
    w(f"## Renders per LOD ({curve}, view 0)")
    w("")
    w("Left to right: the mesh reference, LOD 2, 3, 4, 5 (1024² frames shown at 512²).")
    w("")
    w(f"![{curve} per LOD]({a.doc}/lods_{curve}_view0.png)")
    w("")
    if a.combined:
        w("## Combined sweep (`sdfmo sweep --extra-rows`)")
        w("")
        for png in ("plot_psnr_vs_size.png", "plot_psnr_vs_render_time.png"):
            src = os.path.join(a.combined, png)
            if os.path.exists(src):
                dst = os.path.join(figdir, png)
                with open(src, "rb") as fsrc:
                    atomic_write(dst, fsrc.read())
                w(f"![{png}]({a.doc}/{png})")
                w("")
        tm = os.path.join(a.combined, "table.md")
        if os.path.exists(tm):
            w(open(tm).read())
    atomic_write(os.path.join(docs, a.doc + ".md"), "\n".join(L) + "\n")


if __name__ == "__main__":
    main()
