"""NGLOD (Takikawa et al., CVPR 2021) written from its paper, in PyTorch, on our protocol.

What is implemented (see docs/results/nglod.md for what was measured with it):

- A sparse octree of the surface: LOD k (k = 1..5) is the level of resolution 2^(k+1) in the
  root cube [-1, 1]^3 (4^3 .. 64^3, as NGLOD's base LOD 2 with 5 LODs; the SDFMultiOctree
  paper compares its depths 7-10 with LODs 2-5). A cell of level k is kept when it may touch
  the surface: the exact unsigned distance from its centre is at most its half-diagonal (a
  superset of the cells the surface passes through), tested top-down (children of kept cells).
- Learned feature vectors (32 floats) at the distinct corners of the kept cells of each level,
  trilinearly interpolated (a corner that belongs to no kept cell counts as zero), summed over
  the levels 1..k.
- One decoder per LOD: [summed features (32), position (3)] -> 128 (ReLU) -> 1.
- Training: samples of our exact signed distance (`sdfmo.sample_sdf` on the mesh normalised
  into the root cube exactly as the octree builder does): uniform in the padded bounding box,
  near the surface (surface points plus Gaussian noise), on the surface; L2 loss summed over
  the LODs; Adam.
- Rendering: a sphere tracer over the octree of the rendered LOD k (cells that are not kept
  are skipped, a Chebyshev distance map over the level's grid makes the skip larger than one
  cell where it can), the SDF of LOD k inside kept cells, normals from the network's gradient,
  the paper protocol's camera and lambert shading (white albedo, light normalize(1,1,1) of
  intensity 2/3, ambient 0.25, two-sided, black background, 8-bit).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time

import numpy as np
import torch
import torch.nn.functional as F

import sdfmo

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))  # benches/peers
from peerio import atomic_write  # noqa: E402

FEATURE_DIM = 32
HIDDEN = 128
NUM_LODS = 5  # LOD k has resolution 2 ** (k + 1), k = 1..NUM_LODS
MARGIN = 0.05


def lod_res(k: int) -> int:
    return 2 ** (k + 1)


# --------------------------------------------------------------------------------------------
# Mesh, normalised as the builder does (crates/sdfmo-mesh Normalization::for_bounds, margin 0.05)
# --------------------------------------------------------------------------------------------


def load_normalised(path: str) -> sdfmo.Mesh:
    mesh = sdfmo.Mesh.load(path)
    b = mesh.bounds.astype(np.float32)
    longest = np.float32((b[1] - b[0]).max())
    target = np.float32(2.0) * (np.float32(1.0) - np.float32(MARGIN))
    scale = target / longest if longest > 0 else np.float32(1.0)
    center = (b[0] + b[1]) * np.float32(0.5)
    v = ((mesh.vertices - center) * scale).astype(np.float32)
    return sdfmo.Mesh(v, mesh.faces)


# --------------------------------------------------------------------------------------------
# Sparse octree
# --------------------------------------------------------------------------------------------


def build_octree(mesh: sdfmo.Mesh, threads: int) -> list[np.ndarray]:
    """Kept cells per level 1..NUM_LODS, each an (n, 3) int64 array of cell coordinates."""
    levels = []
    res = lod_res(1)
    cand = np.stack(np.meshgrid(*[np.arange(res)] * 3, indexing="ij"), -1).reshape(-1, 3)
    for k in range(1, NUM_LODS + 1):
        res = lod_res(k)
        h = 2.0 / res
        centres = (-1.0 + (cand + 0.5) * h).astype(np.float32)
        d = mesh.unsigned_distance(centres, threads=threads)
        keep = cand[d <= 0.5 * math.sqrt(3.0) * h]
        levels.append(keep)
        if k < NUM_LODS:
            off = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), -1).reshape(-1, 3)
            cand = (keep[:, None, :] * 2 + off[None, :, :]).reshape(-1, 3)
    return levels


def corner_table(cells: np.ndarray, res: int) -> tuple[np.ndarray, int]:
    """Dense lookup (res+1)^3 -> feature row (or -1) for the distinct corners of `cells`."""
    n1 = res + 1
    off = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), -1).reshape(-1, 3)
    corners = (cells[:, None, :] + off[None]).reshape(-1, 3)
    lin = np.unique(corners[:, 0] * n1 * n1 + corners[:, 1] * n1 + corners[:, 2])
    lut = np.full(n1**3, -1, dtype=np.int64)
    lut[lin] = np.arange(len(lin))
    return lut, len(lin)


# --------------------------------------------------------------------------------------------
# Model
# --------------------------------------------------------------------------------------------


class NGLOD(torch.nn.Module):
    def __init__(self, levels: list[np.ndarray]):
        super().__init__()
        self.cells = [torch.from_numpy(c) for c in levels]
        self.features = torch.nn.ParameterList()
        self.luts = []
        for k, cells in enumerate(levels, start=1):
            lut, n = corner_table(cells, lod_res(k))
            self.luts.append(torch.from_numpy(lut))
            self.features.append(torch.nn.Parameter(torch.randn(n, FEATURE_DIM) * 0.01))
        self.decoders = torch.nn.ModuleList(
            [
                torch.nn.Sequential(
                    torch.nn.Linear(FEATURE_DIM + 3, HIDDEN), torch.nn.ReLU(), torch.nn.Linear(HIDDEN, 1)
                )
                for _ in levels
            ]
        )
        off = torch.tensor([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)])
        self.register_buffer("offsets", off, persistent=False)

    def to_device(self, device: str) -> "NGLOD":
        """Moves the parameters and the corner tables (plain tensors, not buffers) to `device`."""
        self.to(device)
        self.luts = [t.to(device) for t in self.luts]
        return self

    def level_feature(self, p: torch.Tensor, k: int) -> torch.Tensor:
        res = lod_res(k)
        x = (p + 1.0) * (0.5 * res)
        i0 = torch.floor(x).clamp(0, res - 1)
        f = (x - i0).clamp(0.0, 1.0)
        i0 = i0.long()
        c = i0[:, None, :] + self.offsets[None]  # (n, 8, 3)
        n1 = res + 1
        rows = self.luts[k - 1][c[..., 0] * (n1 * n1) + c[..., 1] * n1 + c[..., 2]]  # (n, 8)
        o = self.offsets.to(p.dtype)
        w = (f[:, None, :] * o[None] + (1.0 - f[:, None, :]) * (1.0 - o[None])).prod(-1)
        valid = rows >= 0
        w = w * valid.to(w.dtype)
        return F.embedding_bag(rows.clamp(min=0), self.features[k - 1], per_sample_weights=w, mode="sum")

    def forward(self, p: torch.Tensor, lods: list[int]) -> list[torch.Tensor]:
        """SDF of each LOD in `lods` (ascending) at points p (n, 3)."""
        out = []
        s = None
        top = max(lods)
        for k in range(1, top + 1):
            feat = self.level_feature(p, k)
            s = feat if s is None else s + feat
            if k in lods:
                out.append(self.decoders[k - 1](torch.cat([s, p], -1)).squeeze(-1))
        return out

    def sdf(self, p: torch.Tensor, k: int) -> torch.Tensor:
        return self.forward(p, [k])[0]

    # Size accounting: float32 parameters needed to render LOD k.
    def size_bytes(self, k: int) -> dict:
        feats = sum(self.features[j].numel() for j in range(k)) * 4
        decoder = sum(q.numel() for q in self.decoders[k - 1].parameters()) * 4
        # The octree: one child-mask byte per kept cell of the levels 1..k-1 (the internal
        # nodes; the level-k cells are the leaves named by their parents' masks) plus the
        # root's byte. From it the corner tables are rebuilt at load time.
        octree = 1 + sum(len(self.cells[j]) for j in range(k - 1))
        dense = sum(FEATURE_DIM * (lod_res(j) + 1) ** 3 for j in range(1, k + 1)) * 4 + decoder
        return {"features": feats, "decoder": decoder, "octree": octree, "bytes": feats + decoder + octree,
                "dense_bytes": dense}


# --------------------------------------------------------------------------------------------
# Samples
# --------------------------------------------------------------------------------------------


def diag(mesh: sdfmo.Mesh) -> float:
    b = mesh.bounds
    return float(np.linalg.norm(b[1] - b[0]))


def samples(mesh: sdfmo.Mesh, sched: dict, seed: int, threads: int) -> tuple[np.ndarray, np.ndarray]:
    """One epoch's samples: uniform in the padded box, near the surface, on the surface."""
    dg = diag(mesh)
    sig = sched["near_sigma"] / dg  # sample_sdf takes sigmas as fractions of the diagonal
    pu, du = sdfmo.sample_sdf(mesh, sched["n_uniform"], seed=seed * 3 + 0, near_fraction=0.0,
                              padding=sched["padding"], threads=threads)
    pn, dn = sdfmo.sample_sdf(mesh, sched["n_near"], seed=seed * 3 + 1, near_fraction=1.0,
                              sigmas=(sig, sig), threads=threads)
    ps, ds = sdfmo.sample_sdf(mesh, sched["n_surface"], seed=seed * 3 + 2, near_fraction=1.0,
                              sigmas=(0.0, 0.0), threads=threads)
    return np.concatenate([pu, pn, ps]), np.concatenate([du, dn, ds])


# --------------------------------------------------------------------------------------------
# Sphere tracer on the paper protocol
# --------------------------------------------------------------------------------------------

LIGHT = torch.tensor([1.0, 1.0, 1.0]) / math.sqrt(3.0)


def paper_camera(view: int, size: int) -> tuple[torch.Tensor, torch.Tensor]:
    theta = 2.0 * math.pi * view / 4.0
    eye = np.array([3.0 * math.sin(theta), 0.0, 3.0 * math.cos(theta)], dtype=np.float64)
    fwd = -eye / np.linalg.norm(eye)
    upv = np.array([0.0, 1.0, 0.0])
    right = np.cross(fwd, upv)
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    tanh = math.tan(math.radians(60.0) / 2.0)
    px = (np.arange(size) + 0.5) / size
    u = (2.0 * px - 1.0) * tanh  # square image: W/H = 1
    v = (1.0 - 2.0 * px) * tanh
    uu, vv = np.meshgrid(u, v, indexing="xy")  # rows = py (v), columns = px (u)
    d = fwd[None, None] + uu[..., None] * right[None, None] + vv[..., None] * up[None, None]
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    o = np.broadcast_to(eye, d.shape)
    return (torch.from_numpy(o.reshape(-1, 3).astype(np.float32)),
            torch.from_numpy(d.reshape(-1, 3).astype(np.float32)))


def skip_grid(cells: np.ndarray, res: int) -> torch.Tensor:
    """Chebyshev distance (in cells) of each cell of the level's grid to the nearest kept cell."""
    occ = torch.zeros((1, 1, res, res, res))
    c = torch.from_numpy(cells)
    occ[0, 0, c[:, 0], c[:, 1], c[:, 2]] = 1.0
    dist = torch.full((res, res, res), res + 1, dtype=torch.int64)
    dist[occ[0, 0] > 0] = 0
    cur = occ
    for i in range(1, res + 1):
        nxt = F.max_pool3d(cur, 3, stride=1, padding=1)
        new = (nxt[0, 0] > 0) & (cur[0, 0] == 0)
        dist[new] = i
        cur = nxt
        if bool((cur > 0).all()):
            break
    return dist


@torch.no_grad()
def trace(model: NGLOD, k: int, o: torch.Tensor, d: torch.Tensor, skip: torch.Tensor,
          cone: float, max_steps: int = 128) -> tuple[torch.Tensor, torch.Tensor]:
    """Sphere traces rays (o, d) against LOD k; returns (hit mask, t).

    A ray hits where |f| < cone * t (a quarter of the pixel's footprint at that distance).
    """
    res = lod_res(k)
    h = 2.0 / res
    n = o.shape[0]
    inv = 1.0 / torch.where(d.abs() < 1e-12, torch.full_like(d, 1e-12), d)
    ta = (-1.0 - o) * inv
    tb = (1.0 - o) * inv
    t0 = torch.minimum(ta, tb)
    t1 = torch.maximum(ta, tb)
    tn = t0.max(-1).values.clamp(min=0.0)
    tf = t1.min(-1).values
    t = tn + 1e-6
    hit = torch.zeros(n, dtype=torch.bool, device=o.device)
    idx = torch.nonzero(tn < tf).squeeze(-1)
    for _ in range(max_steps):
        if idx.numel() == 0:
            break
        oo, dd, tt = o[idx], d[idx], t[idx]
        p = oo + tt[:, None] * dd
        cf = (p + 1.0) * (0.5 * res)
        ci = torch.floor(cf).long()
        inside = ((ci >= 0) & (ci < res)).all(-1)
        cic = ci.clamp(0, res - 1)
        cheb = skip[cic[:, 0], cic[:, 1], cic[:, 2]]
        occ = inside & (cheb == 0)
        step = torch.zeros_like(tt)
        done_hit = torch.zeros_like(inside)
        if bool(occ.any()):
            sd = model.sdf(p[occ], k)
            step[occ] = sd
            done_hit[occ] = sd.abs() < cone * tt[occ]
        emp = inside & ~occ
        if bool(emp.any()):
            pe, de, ce = p[emp], dd[emp], cic[emp].to(p.dtype)
            lo = -1.0 + ce * h
            bound = torch.where(de > 0, lo + h, lo)
            ie = inv[idx][emp]
            texit = ((bound - pe) * ie).min(-1).values.clamp(min=0.0)
            far = (cheb[emp] - 1).clamp(min=0).to(p.dtype) * h
            step[emp] = torch.maximum(texit, far) + 1e-5
        t[idx] = tt + step
        hit[idx[done_hit]] = True
        t[idx[done_hit]] = tt[done_hit]
        keep = inside & ~done_hit
        idx = idx[keep]
    return hit, t


def normals(model: NGLOD, k: int, p: torch.Tensor) -> torch.Tensor:
    out = []
    for s in range(0, p.shape[0], 65536):
        q = p[s:s + 65536].clone().requires_grad_(True)
        with torch.enable_grad():
            sd = model.sdf(q, k)
            (g,) = torch.autograd.grad(sd.sum(), q)
        out.append(g)
    g = torch.cat(out) if out else torch.zeros((0, 3), device=p.device)
    return g / g.norm(dim=-1, keepdim=True).clamp(min=1e-12)


def render(model: NGLOD, k: int, view: int, size: int, skip: torch.Tensor, chunk: int = 1 << 20) -> np.ndarray:
    dev = model.offsets.device
    o, d = (x.to(dev) for x in paper_camera(view, size))
    cone = 0.25 * 2.0 * math.tan(math.radians(30.0)) / size
    img = torch.zeros(o.shape[0], dtype=torch.uint8, device=dev)
    light = LIGHT.to(dev)
    skip = skip.to(dev)
    for s in range(0, o.shape[0], chunk):
        oc, dc = o[s:s + chunk], d[s:s + chunk]
        hit, t = trace(model, k, oc, dc, skip, cone)
        hi = torch.nonzero(hit).squeeze(-1)
        if hi.numel() == 0:
            continue
        p = oc[hi] + t[hi, None] * dc[hi]
        nrm = normals(model, k, p)
        flip = (nrm * dc[hi]).sum(-1) > 0
        nrm[flip] = -nrm[flip]
        val = 0.25 + (2.0 / 3.0) * (nrm @ light).clamp(min=0.0)
        img[s + hi] = torch.round(val.clamp(0.0, 1.0) * 255.0).to(torch.uint8)
    g = img.reshape(size, size).cpu().numpy()
    return np.repeat(g[:, :, None], 3, axis=2).copy()


# --------------------------------------------------------------------------------------------
# Commands
# --------------------------------------------------------------------------------------------


def save_png_atomic(path: str, img: np.ndarray) -> None:
    d = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-", suffix=".png")
    os.close(fd)
    sdfmo.save_png(tmp, img)
    os.replace(tmp, path)


def cmd_train(a) -> None:
    torch.set_num_threads(a.threads)
    torch.manual_seed(a.seed)
    sched = json.loads(a.schedule)
    mesh = load_normalised(a.mesh)
    t_oct = time.perf_counter()
    levels = build_octree(mesh, a.threads)
    t_oct = time.perf_counter() - t_oct
    model = NGLOD(levels)
    opt = torch.optim.Adam(model.parameters(), lr=sched["lr"])
    lods = list(range(1, NUM_LODS + 1))
    log = {"schedule": sched, "threads": a.threads, "torch": torch.__version__, "octree_s": t_oct,
           "cells": [len(c) for c in levels], "corners": [int(f.shape[0]) for f in model.features],
           "epochs": []}
    curve_ref = None
    if a.curve_ref:
        curve_ref = sdfmo.load_png(a.curve_ref)
        curve_skip = {k: skip_grid(levels[k - 1], lod_res(k)) for k in range(2, NUM_LODS + 1)}
    pts = sdf = None
    t_train = time.perf_counter()
    for ep in range(sched["epochs"]):
        e0 = time.perf_counter()
        c0 = time.process_time()
        if pts is None or ep % sched["resample_every"] == 0:
            p_np, d_np = samples(mesh, sched, a.seed * 100003 + ep, a.threads)
            pts, sdf = torch.from_numpy(p_np), torch.from_numpy(d_np)
        e1 = time.perf_counter()
        perm = torch.randperm(pts.shape[0])
        tot = np.zeros(NUM_LODS)
        nb = 0
        bs = sched["batch"]
        for s in range(0, pts.shape[0], bs):
            b = perm[s:s + bs]
            preds = model(pts[b], lods)
            losses = [((q - sdf[b]) ** 2).mean() for q in preds]
            loss = sum(losses)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            tot += np.array([float(x.detach()) for x in losses])
            nb += 1
        e2 = time.perf_counter()
        rec = {"epoch": ep + 1, "loss_per_lod": (tot / nb).tolist(), "loss": float(tot.sum() / nb),
               "sample_s": e1 - e0, "step_s": e2 - e1, "cpu_s": time.process_time() - c0, "steps": nb,
               "loadavg_1min": os.getloadavg()[0]}  # how shared the cores were (wall times depend on it)
        if curve_ref is not None and ((ep + 1) % a.curve_every == 0 or ep + 1 == sched["epochs"]):
            rec["psnr_view0"] = {}
            for k in range(2, NUM_LODS + 1):
                img = render(model, k, 0, curve_ref.shape[0], curve_skip[k])
                rec["psnr_view0"][str(k)] = sdfmo.psnr(curve_ref, img)
        log["epochs"].append(rec)
        print(f"[{os.path.basename(a.mesh)}] epoch {ep + 1}/{sched['epochs']} loss {rec['loss']:.3e} "
              f"(sample {e1 - e0:.1f} s, {nb} steps {e2 - e1:.1f} s)"
              + (f" psnr {rec['psnr_view0']}" if "psnr_view0" in rec else ""), flush=True)
    log["train_s"] = time.perf_counter() - t_train
    log["train_cpu_s"] = sum(e["cpu_s"] for e in log["epochs"])
    buf = __import__("io").BytesIO()
    torch.save({"state": model.state_dict(), "levels": levels}, buf)
    atomic_write(a.out + ".pt", buf.getvalue())
    atomic_write(a.out + ".train.json", json.dumps(log, indent=1).encode())


def load_model(path: str, device: str = "cpu") -> NGLOD:
    ck = torch.load(path, weights_only=False, map_location="cpu")
    model = NGLOD(ck["levels"])
    model.load_state_dict(ck["state"])
    model.eval()
    return model.to_device(device)


def sync(device: str) -> None:
    """Waits for the device's queued work, so that a wall-clock time covers it."""
    if device.startswith("cuda"):
        torch.cuda.synchronize()


def device_name(device: str) -> str:
    """What the frames ran on, for the JSON: the GPU's name, or "cpu"."""
    return torch.cuda.get_device_name() if device.startswith("cuda") else "cpu"


def cmd_render(a) -> None:
    """Renders LODs × views; times each frame (interleaved: views outer, LODs inner)."""
    torch.set_num_threads(a.threads)
    model = load_model(a.model, a.device)
    lods = [int(x) for x in a.lods.split(",")]
    skips = {k: skip_grid(model.cells[k - 1].numpy(), lod_res(k)).to(a.device) for k in lods}
    if a.device != "cpu":  # one untimed frame: kernel compilation and allocator warm-up
        render(model, lods[0], 0, 64, skips[lods[0]])
    times = {k: [] for k in lods}
    cpu = {k: [] for k in lods}
    os.makedirs(a.out_dir, exist_ok=True)
    for v in range(4):
        for k in lods:
            t = time.perf_counter()
            c = time.process_time()
            img = render(model, k, v, a.size, skips[k])
            sync(a.device)
            times[k].append((time.perf_counter() - t) * 1000.0)
            cpu[k].append((time.process_time() - c) * 1000.0)
            save_png_atomic(os.path.join(a.out_dir, f"nglod_lod{k}_{v}.png"), img)
            print(f"  LOD {k} view {v}: {times[k][-1]:.0f} ms", flush=True)
    res = {"threads": a.threads, "size": a.size, "device": device_name(a.device),
           "render_ms_views": {str(k): times[k] for k in lods},
           "render_cpu_ms_views": {str(k): cpu[k] for k in lods},
           "sizes": {str(k): model.size_bytes(k) for k in lods}}
    atomic_write(os.path.join(a.out_dir, "render.json"), json.dumps(res, indent=1).encode())


def cmd_sdfcheck(a) -> None:
    """Held-out points (a seed never used in training): |f_k - d| per LOD."""
    torch.set_num_threads(a.threads)
    sched = json.loads(a.schedule)
    mesh = load_normalised(a.mesh)
    model = load_model(a.model, a.device)
    s = dict(sched)
    s.update(n_uniform=a.n // 5, n_near=2 * a.n // 5, n_surface=2 * a.n // 5)
    p, d = samples(mesh, s, 999_999_937, a.threads)
    kinds = np.array([0] * s["n_uniform"] + [1] * s["n_near"] + [2] * s["n_surface"])
    out = {"n": int(len(d)), "per_lod": {}}
    with torch.no_grad():
        pt = torch.from_numpy(p).to(a.device)
        preds = [torch.cat([model(pt[i:i + 65536], list(range(1, NUM_LODS + 1)))[j]
                            for i in range(0, len(d), 65536)]).cpu() for j in range(NUM_LODS)]
    for k in range(1, NUM_LODS + 1):
        err = np.abs(preds[k - 1].numpy() - d)
        row = {"mean": float(err.mean()), "max": float(err.max())}
        for kind, name in enumerate(["uniform", "near", "surface"]):
            e = err[kinds == kind]
            row[name + "_mean"] = float(e.mean())
            row[name + "_max"] = float(e.max())
        out["per_lod"][str(k)] = row
    atomic_write(a.out, json.dumps(out, indent=1).encode())


def cmd_timepaper(a) -> None:
    """Times the parts of one epoch of a schedule: its sampling, and `--steps` Adam steps at its batch."""
    torch.set_num_threads(a.threads)
    sched = json.loads(a.schedule)
    mesh = load_normalised(a.mesh)
    model = NGLOD(build_octree(mesh, a.threads))
    opt = torch.optim.Adam(model.parameters(), lr=sched["lr"])
    w, c = time.perf_counter(), time.process_time()
    p, d = samples(mesh, sched, 12345, a.threads)
    sample_wall, sample_cpu = time.perf_counter() - w, time.process_time() - c
    pts, sdf = torch.from_numpy(p), torch.from_numpy(d)
    lods = list(range(1, NUM_LODS + 1))
    bs = sched["batch"]
    walls, cpus = [], []
    for i in range(a.steps + 3):
        w, c = time.perf_counter(), time.process_time()
        b = torch.randint(0, pts.shape[0], (bs,))
        loss = sum(((q - sdf[b]) ** 2).mean() for q in model(pts[b], lods))
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        if i >= 3:  # the first steps warm up allocators
            walls.append(time.perf_counter() - w)
            cpus.append(time.process_time() - c)
    n = sched["n_uniform"] + sched["n_near"] + sched["n_surface"]
    steps = math.ceil(n / bs)
    res = {"schedule": sched, "threads": a.threads, "samples_per_epoch": n, "steps_per_epoch": steps,
           "sample_wall_s": sample_wall, "sample_cpu_s": sample_cpu,
           "step_wall_s_median": float(np.median(walls)), "step_cpu_s_median": float(np.median(cpus)),
           "steps_timed": a.steps}
    res["epoch_wall_s"] = sample_wall / sched["resample_every"] + steps * res["step_wall_s_median"]
    res["epoch_cpu_s"] = sample_cpu / sched["resample_every"] + steps * res["step_cpu_s_median"]
    res["total_wall_s"] = res["epoch_wall_s"] * sched["epochs"]
    res["total_cpu_s"] = res["epoch_cpu_s"] * sched["epochs"]
    atomic_write(a.out, json.dumps(res, indent=1).encode())


def cmd_timing(a) -> None:
    """Render time per frame, interleaved: NGLOD LOD k and the octrees (sdfmo) at depth k + 5, view 0."""
    torch.set_num_threads(a.threads)
    model = load_model(a.model)
    mesh = sdfmo.Mesh.load(a.mesh)
    lods = [2, 3, 4, 5]
    skips = {k: skip_grid(model.cells[k - 1].numpy(), lod_res(k)) for k in lods}
    octrees = {(meth, k + 5): mesh.build(k + 5, method=meth, threads=a.threads) for k in lods for meth in ("svo", "multi")}
    res = {"threads": a.threads, "size": a.size, "reps": a.reps, "view": 0, "wall_ms": {}, "cpu_ms": {}}
    def clock(key, fn):
        w, c = time.perf_counter(), time.process_time()
        fn()
        res["wall_ms"].setdefault(key, []).append((time.perf_counter() - w) * 1000.0)
        res["cpu_ms"].setdefault(key, []).append((time.process_time() - c) * 1000.0)
    for _ in range(a.reps):
        for k in lods:
            clock(f"nglod_lod{k}", lambda: render(model, k, 0, a.size, skips[k]))
            for meth in ("svo", "multi"):
                o = octrees[(meth, k + 5)]
                clock(f"{meth}_d{k + 5}", lambda: o.render(a.size, view=0, threads=a.threads))
        print("  timing rep done", flush=True)
    atomic_write(a.out, json.dumps(res, indent=1).encode())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    # Every command runs on an explicit number of threads (no default: the sweep passes its own).
    threads = argparse.ArgumentParser(add_help=False)
    threads.add_argument("--threads", type=int, required=True)
    t = sub.add_parser("train", parents=[threads])
    t.add_argument("mesh")
    t.add_argument("--out", required=True, help="output prefix (writes PREFIX.pt, PREFIX.train.json)")
    t.add_argument("--schedule", required=True, help="JSON: epochs, batch, lr, resample_every, n_uniform, "
                   "n_near, n_surface, near_sigma, padding")
    t.add_argument("--seed", type=int, default=0)
    t.add_argument("--curve-ref", help="reference PNG of view 0: render LODs 2-5 at its size for the curve")
    t.add_argument("--curve-every", type=int, default=1)
    device = argparse.ArgumentParser(add_help=False)
    device.add_argument("--device", default="cpu", help="torch device (cpu, cuda)")
    r = sub.add_parser("render", parents=[threads, device])
    r.add_argument("model")
    r.add_argument("--out-dir", required=True)
    r.add_argument("--lods", default="2,3,4,5")
    r.add_argument("--size", type=int, default=1024)
    c = sub.add_parser("sdfcheck", parents=[threads, device])
    c.add_argument("mesh")
    c.add_argument("model")
    c.add_argument("--schedule", required=True)
    c.add_argument("--n", type=int, default=100000)
    c.add_argument("--out", required=True)
    tp = sub.add_parser("timepaper", parents=[threads])
    tp.add_argument("mesh")
    tp.add_argument("--schedule", required=True)
    tp.add_argument("--steps", type=int, default=30)
    tp.add_argument("--out", required=True)
    ti = sub.add_parser("timing", parents=[threads])
    ti.add_argument("mesh")
    ti.add_argument("model")
    ti.add_argument("--size", type=int, default=1024)
    ti.add_argument("--reps", type=int, default=3)
    ti.add_argument("--out", required=True)
    a = ap.parse_args()
    {"timing": cmd_timing, "train": cmd_train, "render": cmd_render, "sdfcheck": cmd_sdfcheck, "timepaper": cmd_timepaper}[a.cmd](a)


if __name__ == "__main__":
    main()
