"""f64 brute-force references for the tests and docs/results/python.md: the exact distance to
a triangle mesh (Ericson's closest point on a triangle, every triangle) and the exact
generalised winding number (van Oosterom & Strackee's solid angle, every triangle).

Both take the mesh's own float32 vertices widened to float64, so they measure the query, not
the loader. O(points x triangles): use a few hundred points.
"""

import numpy as np


def triangles_f64(mesh):
    """The corners of every triangle as three float64 arrays of shape (m, 3)."""
    v = mesh.vertices.astype(np.float64)
    f = mesh.faces
    return v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]


def _dot(x, y):
    return np.einsum("ij,ij->i", x, y)


def closest_on_triangles(p, a, b, c):
    """Closest point to p (3,) on each triangle (a, b, c: (m, 3)); Ericson's regions."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = p - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = p - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    vc = d1 * d4 - d3 * d2
    vb = d5 * d2 - d1 * d6
    va = d3 * d6 - d5 * d4
    with np.errstate(divide="ignore", invalid="ignore"):
        v_ab = d1 / (d1 - d3)
        w_ac = d2 / (d2 - d6)
        w_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        denom = 1.0 / (va + vb + vc)
        v_f, w_f = vb * denom, vc * denom
    conds = [
        (d1 <= 0) & (d2 <= 0),
        (d3 >= 0) & (d4 <= d3),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0),
        (d6 >= 0) & (d5 <= d6),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0),
    ]
    choices = [
        a,
        b,
        a + v_ab[:, None] * ab,
        c,
        a + w_ac[:, None] * ac,
        b + w_bc[:, None] * (c - b),
    ]
    face = a + v_f[:, None] * ab + w_f[:, None] * ac
    out = face.copy()
    # np.select picks the first true condition: apply in reverse so earlier ones win.
    for cond, ch in reversed(list(zip(conds, choices))):
        out[cond] = ch[cond]
    return out


def unsigned_distance(mesh, points):
    """Exact unsigned distance (float64) and closest triangle of each point, brute force."""
    a, b, c = triangles_f64(mesh)
    pts = np.asarray(points, dtype=np.float64)
    dist = np.empty(len(pts))
    face = np.empty(len(pts), dtype=np.int64)
    for i, p in enumerate(pts):
        q = closest_on_triangles(p, a, b, c)
        d2 = np.sum((q - p) ** 2, axis=1)
        k = int(np.nanargmin(d2))
        dist[i] = np.sqrt(d2[k])
        face[i] = k
    return dist, face


def winding_number(mesh, points):
    """Exact generalised winding number (float64) of each point, brute force."""
    a0, b0, c0 = triangles_f64(mesh)
    pts = np.asarray(points, dtype=np.float64)
    out = np.empty(len(pts))
    for i, p in enumerate(pts):
        a, b, c = a0 - p, b0 - p, c0 - p
        la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, b, c))
        num = _dot(a, np.cross(b, c))
        den = la * lb * lc + _dot(a, b) * lc + _dot(b, c) * la + _dot(c, a) * lb
        out[i] = np.sum(2.0 * np.arctan2(num, den)) / (4.0 * np.pi)
    return out


def query_points(mesh, n, seed):
    """n points: half near the surface (vertices plus noise of 1 % of the diagonal), half
    uniform in the bounding box padded by 10 %."""
    rng = np.random.default_rng(seed)
    lo, hi = mesh.bounds.astype(np.float64)
    diag = float(np.linalg.norm(hi - lo))
    v = mesh.vertices.astype(np.float64)
    near = v[rng.integers(0, len(v), n // 2)] + rng.normal(scale=0.01 * diag, size=(n // 2, 3))
    pad = 0.1 * (hi - lo).max()
    uni = rng.uniform(lo - pad, hi + pad, size=(n - n // 2, 3))
    return np.concatenate([near, uni]), diag
