"""sdfmo: exact signed distance from triangle meshes, DeepSDF-style SDF samples, and sparse
multi-voxel SDF octrees (build, save, load, render), from numpy.

The Python face of sdf-multioctree (https://github.com/sdf-multioctree/sdf-multioctree).
Everything takes and returns model units; every long call releases the GIL and stops on
Ctrl-C with KeyboardInterrupt.

>>> import numpy as np, sdfmo
>>> mesh = sdfmo.Mesh.load("part.stl")                      # doctest: +SKIP
>>> sdf = mesh.signed_distance(np.random.rand(1000, 3))     # doctest: +SKIP
>>> points, sdf = sdfmo.sample_sdf(mesh, 500_000, seed=1)   # doctest: +SKIP
>>> octree = mesh.build(8)                                  # doctest: +SKIP
>>> image = octree.render(512)                              # doctest: +SKIP

Names:

- ``Mesh``: a triangle mesh (``Mesh(vertices, faces)``, ``Mesh.load(path)``) with
  ``signed_distance``, ``unsigned_distance``, ``winding_number``, ``contains``,
  ``ray_intersect``, ``build`` and ``render``.
- ``Octree``: the packed octree (``Octree.load``, ``save``, ``stats``, ``distance``,
  ``render``).
- ``RenderOptions``: the camera, mode and shading of a render, for both ``render`` methods
  (``options=``).
- ``sample_sdf(mesh, n, seed=...)``: training samples and their signed distances.
- ``psnr(a, b)``, ``flip(a, b)``: image metrics; ``load_png``, ``save_png``: 8-bit RGB PNGs.
- ``FormatError``: a corrupt or unsupported ``.smo`` file. ``MeshError``: a mesh file that
  cannot be parsed. Both are ``ValueError`` subclasses; files that cannot be read raise
  ``OSError`` subclasses, bad arguments ``ValueError``.
"""

from ._sdfmo import (
    FormatError,
    Mesh,
    MeshError,
    Octree,
    RenderOptions,
    __version__,
    flip,
    load_png,
    psnr,
    save_png,
    sample_sdf,
)

__all__ = [
    "FormatError",
    "Mesh",
    "MeshError",
    "Octree",
    "RenderOptions",
    "__version__",
    "flip",
    "load_png",
    "psnr",
    "save_png",
    "sample_sdf",
]
