"""Trains several NGLOD models at once on one GPU: one batched model, CUDA-graph steps.

`nglod.py train` trains one model with batch 512; on a GPU each of the paper schedule's 244,250
Adam steps is then a few hundred tiny kernel launches, so the run is bound by the launch rate,
not by the GPU. Here M models (different meshes, or the same mesh with different seeds) are laid
side by side in one module and stepped together:

- each model keeps its own octree, corner features, decoders, seed, initialisation (built by
  `nglod.NGLOD` under `torch.manual_seed(seed)`, exactly as `nglod.py train --seed` does), its own
  samples per epoch (`nglod.samples` with the same seeds) and its own Adam state;
- the features of one LOD are the rows of all models concatenated (each model's corner table
  offset to its rows), the decoders batched matrices (M, 35, 128) and (M, 128, 1);
- the step's loss is the sum over models of each model's summed per-LOD L2 loss, whose gradient
  with respect to one model's parameters is that model's own; Adam is elementwise. So each model
  follows the schedule `nglod.py train` would, except for floating-point summation order and the
  random stream of the batch permutation (drawn on the GPU);
- the full batches of an epoch replay one CUDA graph of forward, backward and Adam (capturable);
  the epoch's last, partial batch runs eagerly on the same parameters and optimiser state.

Writes, per model, PREFIX.pt and PREFIX.train.json in the formats of `nglod.py train` (the JSON
adds `trained_by`, `device`, `models_in_batch`, `graph`), so run.sh and report.py take them as
they are.

    python batched.py --schedule JSON --threads 14 --device cuda \\
        --model abc8.stl:0:out/models/abc8/model --model abc8.stl:1:out/seeds/abc8-s1/model ...
"""

from __future__ import annotations

import argparse
import concurrent.futures
import io
import json
import os
import time

import numpy as np
import torch

import nglod as N


class Batched(torch.nn.Module):
    """M NGLOD models as one module whose forward takes points of shape (M, B, 3)."""

    def __init__(self, singles: list[N.NGLOD], device: str):
        super().__init__()
        self.m = len(singles)
        self.features = torch.nn.ParameterList()
        self.luts = []
        self.row_offsets = []
        self.lut_base = []
        for k in range(1, N.NUM_LODS + 1):
            feats, luts, offs, o = [], [], [], 0
            for s in singles:
                f = s.features[k - 1].detach()
                lut = s.luts[k - 1].clone()
                lut[lut >= 0] += o
                feats.append(f)
                luts.append(lut)
                offs.append(o)
                o += f.shape[0]
            offs.append(o)
            n1 = N.lod_res(k) + 1
            self.features.append(torch.nn.Parameter(torch.cat(feats).to(device)))
            self.luts.append(torch.cat(luts).to(device))
            self.row_offsets.append(offs)
            self.lut_base.append((torch.arange(self.m, device=device) * n1**3)[:, None, None])

        def stack(get):
            return torch.nn.ParameterList(
                [torch.nn.Parameter(torch.stack([get(s.decoders[k]) for s in singles]).to(device))
                 for k in range(N.NUM_LODS)])

        # nn.Linear computes x @ W.T + b; stored here as W.T so that baddbmm applies it.
        self.w1 = stack(lambda d: d[0].weight.detach().t().contiguous())  # (M, 35, 128)
        self.b1 = stack(lambda d: d[0].bias.detach()[None, :])  # (M, 1, 128)
        self.w2 = stack(lambda d: d[2].weight.detach().t().contiguous())  # (M, 128, 1)
        self.b2 = stack(lambda d: d[2].bias.detach()[None, :])  # (M, 1, 1)
        off = torch.tensor([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], device=device)
        self.register_buffer("offsets", off, persistent=False)

    def level_feature(self, p: torch.Tensor, k: int) -> torch.Tensor:
        """`nglod.NGLOD.level_feature` for every model at once: (M, B, 3) -> (M, B, 32)."""
        res = N.lod_res(k)
        x = (p + 1.0) * (0.5 * res)
        i0 = torch.floor(x).clamp(0, res - 1)
        f = (x - i0).clamp(0.0, 1.0)
        i0 = i0.long()
        c = i0[:, :, None, :] + self.offsets[None, None]  # (M, B, 8, 3)
        n1 = res + 1
        rows = self.luts[k - 1][c[..., 0] * (n1 * n1) + c[..., 1] * n1 + c[..., 2] + self.lut_base[k - 1]]
        o = self.offsets.to(p.dtype)
        w = (f[:, :, None, :] * o + (1.0 - f[:, :, None, :]) * (1.0 - o)).prod(-1)  # (M, B, 8)
        w = w * (rows >= 0).to(w.dtype)
        # index_select, not embedding_bag: its backward is an atomic index_add, which a CUDA
        # graph captures (embedding_bag's backward sorts the indices).
        feats = self.features[k - 1].index_select(0, rows.clamp(min=0).reshape(-1))
        return (feats.view(*rows.shape, N.FEATURE_DIM) * w[..., None]).sum(2)

    def forward(self, p: torch.Tensor) -> list[torch.Tensor]:
        """SDF of every LOD 1..5 of every model: a list of (M, B)."""
        out, s = [], None
        for k in range(1, N.NUM_LODS + 1):
            feat = self.level_feature(p, k)
            s = feat if s is None else s + feat
            h = torch.baddbmm(self.b1[k - 1], torch.cat([s, p], -1), self.w1[k - 1]).relu()
            out.append(torch.baddbmm(self.b2[k - 1], h, self.w2[k - 1]).squeeze(-1))
        return out

    def losses(self, p: torch.Tensor, d: torch.Tensor) -> torch.Tensor:
        """Per-LOD, per-model L2 loss (mean over each model's batch): (5, M)."""
        return torch.stack([((q - d) ** 2).mean(1) for q in self.forward(p)])

    def single_state(self, m: int) -> dict:
        """Model m's parameters as a `nglod.NGLOD` state dict (on the CPU)."""
        st = {}
        for j in range(N.NUM_LODS):
            a, b = self.row_offsets[j][m], self.row_offsets[j][m + 1]
            st[f"features.{j}"] = self.features[j][a:b].detach().cpu().clone()
            st[f"decoders.{j}.0.weight"] = self.w1[j][m].detach().t().cpu().contiguous()
            st[f"decoders.{j}.0.bias"] = self.b1[j][m, 0].detach().cpu().clone()
            st[f"decoders.{j}.2.weight"] = self.w2[j][m].detach().t().cpu().contiguous()
            st[f"decoders.{j}.2.bias"] = self.b2[j][m, 0].detach().cpu().clone()
        return st


class Trainer:
    """The batched model, its Adam, and the step: a CUDA graph for full batches where possible."""

    def __init__(self, model: Batched, sched: dict, device: str, use_graph: bool):
        self.model = model
        self.device = device
        self.bs = sched["batch"]
        self.params = list(model.parameters())
        cuda = device.startswith("cuda")
        self.opt = torch.optim.Adam(self.params, lr=sched["lr"], capturable=cuda)
        self.acc = torch.zeros(N.NUM_LODS, model.m, device=device)
        self.graph = None
        self.graph_error = None
        if cuda and use_graph:
            try:
                self._capture()
            except Exception as e:  # noqa: BLE001 - any capture failure falls back to eager steps
                self.graph_error = f"{type(e).__name__}: {e}"
                self.graph = None
                self._reset()

    def _step(self, p: torch.Tensor, d: torch.Tensor) -> None:
        losses = self.model.losses(p, d)
        losses.sum().backward()
        self.opt.step()
        self.acc.add_(losses.detach())

    def eager_step(self, p: torch.Tensor, d: torch.Tensor) -> None:
        self.opt.zero_grad(set_to_none=True)
        self._step(p, d)

    def _reset(self) -> None:
        """Parameters back to their initial values, Adam state and loss sums to zero."""
        with torch.no_grad():
            for q, q0 in zip(self.params, self.initial):
                q.copy_(q0)
            for st in self.opt.state.values():
                for v in st.values():
                    if torch.is_tensor(v):
                        v.zero_()
        self.acc.zero_()

    def _capture(self) -> None:
        m = self.model.m
        self.initial = [q.detach().clone() for q in self.params]  # first: _reset needs it
        self.static_p = torch.zeros(m, self.bs, 3, device=self.device)
        self.static_d = torch.zeros(m, self.bs, device=self.device)
        # Warm-up steps on a side stream (PyTorch's whole-network capture recipe): they update
        # the parameters, which _reset puts back, so the schedule's steps are all counted.
        s = torch.cuda.Stream()
        s.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(s):
            for _ in range(3):
                self.eager_step(self.static_p, self.static_d)
        torch.cuda.current_stream().wait_stream(s)
        self.opt.zero_grad(set_to_none=True)
        g = torch.cuda.CUDAGraph()
        with torch.cuda.graph(g):
            self._step(self.static_p, self.static_d)
        self.graph = g
        self._reset()

    def step(self, p: torch.Tensor, d: torch.Tensor) -> None:
        if self.graph is not None and p.shape[1] == self.bs:
            self.static_p.copy_(p)
            self.static_d.copy_(d)
            self.graph.replay()
        else:
            self.eager_step(p, d)


def parse_model(spec: str) -> tuple[str, int, str]:
    mesh, seed, prefix = spec.split(":", 2)
    return mesh, int(seed), prefix


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--model", action="append", required=True, metavar="MESH:SEED:PREFIX")
    ap.add_argument("--schedule", required=True)
    ap.add_argument("--threads", type=int, required=True, help="sdfmo sampling threads")
    ap.add_argument("--device", default="cuda")
    ap.add_argument("--no-graph", action="store_true", help="eager steps only")
    ap.add_argument("--deadline-s", type=float, default=float("inf"),
                    help="stop after the epoch that would end past this many seconds (recorded)")
    ap.add_argument("--curve-refs", default="", help="comma list PREFIX=REF_PNG: PSNR of view 0 per LOD")
    ap.add_argument("--curve-every", type=int, default=50)
    ap.add_argument("--epochs", type=int, help="override the schedule's epoch count (tests)")
    a = ap.parse_args()
    t_start = time.perf_counter()
    sched = json.loads(a.schedule)
    epochs = a.epochs or sched["epochs"]
    specs = [parse_model(s) for s in a.model]
    meshes, singles, octree_s = {}, [], []
    for mesh_path, seed, _ in specs:
        if mesh_path not in meshes:
            meshes[mesh_path] = N.load_normalised(mesh_path)
        t = time.perf_counter()
        levels = N.build_octree(meshes[mesh_path], a.threads)
        octree_s.append(time.perf_counter() - t)
        torch.manual_seed(seed)  # the initialisation `nglod.py train --seed SEED` draws
        singles.append(N.NGLOD(levels))
    torch.manual_seed(0)
    model = Batched(singles, a.device)
    trainer = Trainer(model, sched, a.device, not a.no_graph)
    print(f"[batched] {model.m} models, graph: {trainer.graph is not None}"
          + (f" ({trainer.graph_error})" if trainer.graph_error else ""), flush=True)
    curve_refs = dict(kv.split("=", 1) for kv in a.curve_refs.split(",") if kv)
    refs = {p: N.sdfmo.load_png(r) for p, r in curve_refs.items()}
    logs = [{"schedule": sched, "threads": a.threads, "torch": torch.__version__, "octree_s": octree_s[i],
             "cells": [len(c) for c in singles[i].cells], "corners": [int(f.shape[0]) for f in singles[i].features],
             "trained_by": "batched.py", "device": N.device_name(a.device), "models_in_batch": model.m,
             "graph": trainer.graph is not None, "graph_error": trainer.graph_error, "seed": specs[i][1],
             "epochs": []} for i in range(model.m)]

    def draw(ep: int) -> list[tuple[np.ndarray, np.ndarray]]:
        return [N.samples(meshes[mp], sched, seed * 100003 + ep, a.threads) for mp, seed, _ in specs]

    pool = concurrent.futures.ThreadPoolExecutor(1)
    nxt = pool.submit(draw, 0)
    bs = sched["batch"]
    t_train = time.perf_counter()
    done = 0
    for ep in range(epochs):
        e0 = time.perf_counter()
        c0 = time.process_time()
        batch = nxt.result()
        if ep + 1 < epochs:
            nxt = pool.submit(draw, ep + 1)  # the next epoch's samples, drawn while this one trains
        e1 = time.perf_counter()
        P = torch.from_numpy(np.stack([b[0] for b in batch])).to(a.device)
        D = torch.from_numpy(np.stack([b[1] for b in batch])).to(a.device)
        perm = torch.argsort(torch.rand(D.shape, device=a.device), dim=1)
        P = P.gather(1, perm[..., None].expand_as(P))
        D = D.gather(1, perm)
        nb = 0
        for s in range(0, D.shape[1], bs):
            trainer.step(P[:, s:s + bs], D[:, s:s + bs])
            nb += 1
        tot = (trainer.acc / nb).cpu().numpy()  # (5, M); waits for the epoch's steps
        trainer.acc.zero_()
        e2 = time.perf_counter()
        load = os.getloadavg()[0]
        for i in range(model.m):
            logs[i]["epochs"].append({"epoch": ep + 1, "loss_per_lod": tot[:, i].tolist(), "loss": float(tot[:, i].sum()),
                                      "sample_wait_s": e1 - e0, "step_s": e2 - e1, "cpu_s": time.process_time() - c0,
                                      "steps": nb, "loadavg_1min": load})
        if refs and ((ep + 1) % a.curve_every == 0 or ep + 1 == epochs):
            for i, (_, _, prefix) in enumerate(specs):
                if prefix not in refs:
                    continue
                one = N.NGLOD([c.numpy() for c in singles[i].cells])
                one.load_state_dict(model.single_state(i))
                one.to_device(a.device).eval()
                ref = refs[prefix]
                ps = {}
                for k in range(2, N.NUM_LODS + 1):
                    skip = N.skip_grid(singles[i].cells[k - 1].numpy(), N.lod_res(k)).to(a.device)
                    ps[str(k)] = N.sdfmo.psnr(ref, N.render(one, k, 0, ref.shape[0], skip))
                logs[i]["epochs"][-1]["psnr_view0"] = ps
        done = ep + 1
        el = time.perf_counter() - t_start
        print(f"[batched] epoch {done}/{epochs} {e2 - e0:.2f} s (wait {e1 - e0:.2f}) loss "
              + " ".join(f"{x:.2e}" for x in tot.sum(0)) + f"  elapsed {el:.0f} s", flush=True)
        if el + (e2 - e0) > a.deadline_s and done < epochs:
            print(f"[batched] deadline: stopping after {done} of {epochs} epochs", flush=True)
            break
    pool.shutdown(cancel_futures=True)
    train_s = time.perf_counter() - t_train
    for i, (_, _, prefix) in enumerate(specs):
        log = logs[i]
        log["train_s"] = train_s
        log["train_cpu_s"] = sum(e["cpu_s"] for e in log["epochs"])
        log["epochs_done"] = done
        if done < sched["epochs"]:
            log["truncated"] = f"{done} of {sched['epochs']} epochs (deadline)"
        os.makedirs(os.path.dirname(os.path.abspath(prefix)), exist_ok=True)
        buf = io.BytesIO()
        torch.save({"state": model.single_state(i), "levels": [c.numpy() for c in singles[i].cells]}, buf)
        N.atomic_write(prefix + ".pt", buf.getvalue())
        N.atomic_write(prefix + ".train.json", json.dumps(log, indent=1).encode())
    print(f"[batched] done: {done} epochs in {train_s:.0f} s", flush=True)


if __name__ == "__main__":
    main()
