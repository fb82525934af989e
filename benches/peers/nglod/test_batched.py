"""batched.py against nglod.py: the batched model is the single models side by side.

    .venv/bin/python -m pytest -q benches/peers/nglod/test_batched.py   (needs torch and sdfmo)

Checks on the CPU, with two meshes and two seeds of one: the same initialisation as
`nglod.py train --seed`, the same SDF per LOD, the same gradients per model (so Adam, which is
elementwise, takes the same steps), and the state dict written back loads into `nglod.NGLOD`.
"""

from __future__ import annotations

import os

import numpy as np
import torch

import batched as B
import nglod as N

DATA = os.environ.get("SDFMO_TEST_DATA", os.path.join(os.path.dirname(__file__), "../../../../shared/data"))


def singles():
    meshes = [N.load_normalised(os.path.join(DATA, f)) for f in ("abc8.stl", "abc5.stl")]
    out = []
    for mesh, seed in ((meshes[0], 0), (meshes[0], 1), (meshes[1], 0)):
        levels = N.build_octree(mesh, 2)
        torch.manual_seed(seed)
        out.append(N.NGLOD(levels))
    return out


def test_forward_and_gradients_match_the_single_models():
    ones = singles()
    model = B.Batched(ones, "cpu")
    gen = torch.Generator().manual_seed(7)
    p = torch.rand(3, 300, 3, generator=gen) * 2.0 - 1.0
    d = torch.rand(3, 300, generator=gen) * 0.1
    preds = model(p)
    for i, one in enumerate(ones):
        ref = one(p[i], [1, 2, 3, 4, 5])
        for k in range(5):
            torch.testing.assert_close(preds[k][i], ref[k], rtol=1e-5, atol=1e-6)
    model.losses(p, d).sum().backward()
    for i, one in enumerate(ones):
        sum(((q - d[i]) ** 2).mean() for q in one(p[i], [1, 2, 3, 4, 5])).backward()
        a, b = model.row_offsets[4][i], model.row_offsets[4][i + 1]
        torch.testing.assert_close(model.features[4].grad[a:b], one.features[4].grad, rtol=1e-4, atol=1e-7)
        torch.testing.assert_close(model.w1[2].grad[i], one.decoders[2][0].weight.grad.t(), rtol=1e-4, atol=1e-7)
        torch.testing.assert_close(model.b2[3].grad[i, 0], one.decoders[3][2].bias.grad, rtol=1e-4, atol=1e-7)


def test_state_round_trips_into_nglod():
    ones = singles()
    model = B.Batched(ones, "cpu")
    for i, one in enumerate(ones):
        fresh = N.NGLOD([c.numpy() for c in one.cells])
        fresh.load_state_dict(model.single_state(i))
        p = torch.rand(50, 3) * 2.0 - 1.0
        for k in (2, 5):
            torch.testing.assert_close(fresh.sdf(p, k), one.sdf(p, k))


def test_a_seed_changes_the_initialisation():
    ones = singles()
    assert not torch.equal(ones[0].features[0], ones[1].features[0])
    assert np.array_equal(ones[0].cells[4].numpy(), ones[1].cells[4].numpy())
