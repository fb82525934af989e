#!/usr/bin/env python3
"""Independent reference for `sdfmo info`: mesh numbers computed with trimesh.

Run (creates its own virtualenv at benches/.venv-mesh, ignored by git, on first use):

    python3 benches/peers/mesh_info_trimesh.py ../shared/data/*.{stl,obj,glb} > mesh_info.json

For each file it prints, as one JSON object keyed by file name:
- triangles_raw: faces as trimesh loads them, before any processing;
- two sets of numbers: `trimesh_merge` after trimesh merges vertices by position
  (`merge_vertices`, which rounds coordinates to 1e-8), and `exact_merge` after merging only
  identical f32 coordinates (numpy `unique`), as sdfmo-mesh welds; in both, degenerate
  (`nondegenerate_faces`) and duplicate (`unique_faces`) faces and unreferenced vertices are
  then dropped by trimesh, and:
- vertices, triangles;
- components_shared_edges: connected components of faces joined through any shared edge
  (edges grouped with trimesh's `edges_sorted`, faces joined with scipy's
  connected_components): sdfmo-mesh's definition;
- components_trimesh: trimesh's own definition (`mesh.face_adjacency`, which only joins
  faces across edges shared by exactly two faces: non-manifold edges do not connect);
- boundary_edges (edges in one face), non_manifold_edges (edges in more than two faces),
  watertight (trimesh's `is_watertight`), winding_consistent, bounds.
"""

import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
VENV = os.path.join(os.path.dirname(HERE), ".venv-mesh")


def ensure_venv():
    """Re-runs this script inside its own virtualenv with trimesh installed."""
    try:
        import trimesh  # noqa: F401
        import scipy  # noqa: F401
        return
    except ImportError:
        pass
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        sys.exit("trimesh is missing from %s" % VENV)
    py = os.path.join(VENV, "bin", "python")
    if not os.path.exists(py):
        subprocess.check_call([sys.executable, "-m", "venv", VENV], stdout=sys.stderr)
        subprocess.check_call(
            [py, "-m", "pip", "install", "-q", "-r", os.path.join(HERE, "requirements-mesh.txt")],
            stdout=sys.stderr,
        )
    os.execv(py, [py] + sys.argv)


def metrics(mesh):
    """Topology numbers of a merged trimesh (degenerate/duplicate faces dropped here)."""
    import numpy as np
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    mesh.update_faces(mesh.nondegenerate_faces())
    mesh.update_faces(mesh.unique_faces())
    mesh.remove_unreferenced_vertices()
    f = len(mesh.faces)
    edges = mesh.edges_sorted  # (3F, 2), row i belongs to face i // 3
    uniq, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    face_of_edge = np.arange(len(edges)) // 3
    # Bipartite face-edge graph: faces sharing an edge end up in one component.
    n = f + len(uniq)
    g = coo_matrix((np.ones(len(edges)), (face_of_edge, f + inverse)), shape=(n, n))
    _, labels = connected_components(g, directed=False)
    adj = mesh.face_adjacency
    g2 = coo_matrix((np.ones(len(adj)), (adj[:, 0], adj[:, 1])), shape=(f, f))
    components_trimesh, _ = connected_components(g2, directed=False)
    lo, hi = mesh.bounds
    return {
        "triangles": int(f),
        "vertices": int(len(mesh.vertices)),
        "components_shared_edges": int(len(np.unique(labels[:f]))),
        "components_trimesh": int(components_trimesh),
        "boundary_edges": int((counts == 1).sum()),
        "non_manifold_edges": int((counts > 2).sum()),
        "watertight": bool(mesh.is_watertight),
        "winding_consistent": bool(mesh.is_winding_consistent),
        "bounds": [lo.tolist(), hi.tolist()],
    }


def info(path):
    import numpy as np
    import trimesh

    loaded = trimesh.load(path, force="mesh", process=False)
    v = np.asarray(loaded.vertices)
    faces = np.asarray(loaded.faces)
    # trimesh's own merge: positions rounded to 1e-8 (`merge_vertices`).
    by_position = trimesh.Trimesh(vertices=v, faces=faces, process=False)
    by_position.merge_vertices()
    # Exact merge of identical f32 coordinates (sdfmo-mesh's bit-identical welding; numpy
    # treats -0.0 and +0.0 as equal, as sdfmo-mesh does).
    uniq, inv = np.unique(v.astype(np.float32), axis=0, return_inverse=True)
    exact = trimesh.Trimesh(vertices=uniq, faces=inv.reshape(-1)[faces], process=False)
    return {
        "triangles_raw": int(len(faces)),
        "trimesh_merge": metrics(by_position),
        "exact_merge": metrics(exact),
    }


def main():
    ensure_venv()
    import trimesh

    out = {"tool": "trimesh " + trimesh.__version__, "files": {}}
    for path in sys.argv[1:]:
        out["files"][os.path.basename(path)] = info(path)
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
