"""Type stubs of the compiled module ``sdfmo._sdfmo`` (re-exported by ``sdfmo``)."""

import os
from typing import Any, List, Literal, Optional, Sequence, Tuple, Union, final, overload

import numpy as np
import numpy.typing as npt
from typing_extensions import Buffer

__all__ = [
    "Mesh",
    "Octree",
    "RenderOptions",
    "sample_sdf",
    "psnr",
    "flip",
    "load_png",
    "save_png",
    "FormatError",
    "MeshError",
    "__version__",
]
__version__: str

_Path = Union[str, "os.PathLike[str]"]
_Points = npt.ArrayLike
_Sign = Literal["auto", "pseudonormal", "winding"]
_Mode = Literal["lambert", "mask", "depth", "normal"]
_F32 = npt.NDArray[np.float32]
_I64 = npt.NDArray[np.int64]
_U8 = npt.NDArray[np.uint8]
# What `signed_distance` and `unsigned_distance` return: the distances, then the closest points
# (`return_closest`) and the faces (`return_face`) when asked for.
_Distances = Union[_F32, Tuple[_F32, _F32], Tuple[_F32, _I64], Tuple[_F32, _F32, _I64]]

class FormatError(ValueError):
    """A ``.smo`` file that is truncated, corrupt, of an unknown version or inconsistent."""

class MeshError(ValueError):
    """A mesh file that is not a readable OBJ, glTF/GLB or STL file."""

@final
class RenderOptions:
    """How to render an image (camera, mode, shading), for ``Mesh.render`` and
    ``Octree.render`` as ``options=``; the same keywords given to ``render`` make one."""

    def __new__(
        cls,
        *,
        mode: Optional[_Mode] = None,
        view: int = 0,
        eye: Optional[Sequence[float]] = None,
        target: Optional[Sequence[float]] = None,
        fov: Optional[float] = None,
        frame: Literal["model", "normalized"] = "model",
        shadows: Optional[bool] = None,
        ao: Optional[int] = None,
    ) -> "RenderOptions": ...
    @property
    def mode(self) -> _Mode: ...
    @property
    def view(self) -> int: ...
    @property
    def eye(self) -> Optional[Tuple[float, float, float]]: ...
    @property
    def target(self) -> Optional[Tuple[float, float, float]]: ...
    @property
    def fov(self) -> Optional[float]: ...
    @property
    def frame(self) -> Literal["model", "normalized"]: ...
    @property
    def shadows(self) -> bool: ...
    @property
    def ao(self) -> int: ...

@final
class Mesh:
    """A triangle mesh in model units, with exact distance queries."""

    def __new__(cls, vertices: npt.ArrayLike, faces: npt.ArrayLike, *, clean: bool = False) -> "Mesh":
        """A mesh from ``vertices`` ``(n, 3)`` floats and ``faces`` ``(m, 3)`` integers;
        ``ValueError`` for a degenerate one (zero extent, or every triangle of zero area)."""
    @staticmethod
    def load(path: _Path) -> "Mesh":
        """Loads an OBJ, glTF/GLB or STL file (welded and cleaned)."""
    @property
    def vertices(self) -> _F32:
        """The vertices, float32 ``(n, 3)``."""
    @property
    def faces(self) -> _I64:
        """The triangles, int64 ``(m, 3)``."""
    @property
    def bounds(self) -> _F32:
        """``[min, max]``, float32 ``(2, 3)``."""
    @property
    def is_watertight(self) -> bool:
        """No boundary and no non-manifold edge."""
    @property
    def component_count(self) -> int:
        """Connected components through shared edges."""
    @property
    def vertex_count(self) -> int:
        """Number of vertices."""
    @property
    def face_count(self) -> int:
        """Number of triangles."""
    @property
    def auto_sign(self) -> Literal["pseudonormal", "winding"]:
        """The sign method ``sign="auto"`` uses on this mesh."""
    @overload
    def signed_distance(
        self,
        points: _Points,
        *,
        sign: _Sign = "auto",
        return_closest: Literal[False] = False,
        return_face: Literal[False] = False,
        threads: Optional[int] = None,
    ) -> _F32: ...
    @overload
    def signed_distance(
        self,
        points: _Points,
        *,
        sign: _Sign = "auto",
        return_closest: bool = False,
        return_face: bool = False,
        threads: Optional[int] = None,
    ) -> _Distances:
        """Exact signed distance (negative inside), model units."""
    @overload
    def unsigned_distance(
        self,
        points: _Points,
        *,
        return_closest: Literal[False] = False,
        return_face: Literal[False] = False,
        threads: Optional[int] = None,
    ) -> _F32: ...
    @overload
    def unsigned_distance(
        self,
        points: _Points,
        *,
        return_closest: bool = False,
        return_face: bool = False,
        threads: Optional[int] = None,
    ) -> _Distances:
        """Exact unsigned distance, model units."""
    def winding_number(self, points: _Points, *, threads: Optional[int] = None) -> _F32:
        """Generalised winding number at each point."""
    def contains(self, points: _Points, *, sign: _Sign = "auto", threads: Optional[int] = None) -> npt.NDArray[np.bool_]:
        """``signed_distance(points) < 0``."""
    def ray_intersect(
        self,
        origins: _Points,
        directions: _Points,
        *,
        t_max: float = ...,
        threads: Optional[int] = None,
    ) -> Tuple[_F32, _I64]:
        """First hit ``(t, face)`` of each ray; ``inf`` and -1 on a miss."""
    def build(
        self,
        depth: int,
        *,
        method: Literal["multi", "svo"] = "multi",
        max_voxels: int = 8,
        bits: Literal[8, 16] = 8,
        sign: _Sign = "auto",
        fit_corners: bool = False,
        coarsest: Optional[int] = None,
        threads: Optional[int] = None,
        max_memory: Optional[int] = None,
    ) -> "Octree":
        """Builds the sparse SDF octree (with ``coarsest``: levels ``coarsest..=depth``)."""
    def render(
        self,
        width: int = 1024,
        height: Optional[int] = None,
        *,
        options: Optional[RenderOptions] = None,
        threads: Optional[int] = None,
        **kwargs: Any,
    ) -> _U8:
        """Ray traces the mesh (the reference image), uint8 of shape ``(height, width, 3)``:
        ``render(640, 480).shape == (480, 640, 3)``. ``options``, or its keywords here."""

@final
class Octree:
    """A sparse octree of trilinear signed-distance voxels (``.smo``)."""

    @staticmethod
    def load(path: _Path) -> "Octree":
        """Loads and validates a ``.smo`` file (with levels: whole or cut where a level ends)."""
    @staticmethod
    def from_bytes(data: Buffer) -> "Octree":
        """An octree from the bytes of a ``.smo`` file: any bytes-like object (``bytes``,
        ``bytearray``, ``memoryview``, a C-contiguous numpy array)."""
    def save(self, path: _Path, *, compress: Optional[int] = None) -> None:
        """Writes the ``.smo`` file atomically; ``path`` must end in ``.smo`` (``ValueError``).
        ``compress``: a zstd level 1..=22 writes the compressed container (``Octree.load``
        reads it back as the same octree)."""
    def to_bytes(self) -> bytes:
        """The bytes of the ``.smo`` file."""
    @property
    def depth(self) -> int:
        """Depth of the leaves (the finest level held)."""
    @property
    def levels(self) -> List[int]:
        """The levels held, coarsest first (``[depth]`` without levels of detail)."""
    @property
    def file_levels(self) -> List[int]:
        """The levels of the whole file (more than ``levels`` for a prefix of it)."""
    @property
    def cell_size(self) -> float:
        """Edge of a leaf cell in model units, ``2 / (2**depth * scale)``."""
    @property
    def nbytes(self) -> int:
        """Size of the ``.smo`` file in bytes."""
    @property
    def stats(self) -> dict:
        """Counts, size, transform and (for a fresh build) the builder's statistics."""
    def distance(self, points: _Points, *, threads: Optional[int] = None) -> _F32:
        """Stored signed distance, model units; NaN where no cell is stored: always farther
        than 1.78 * cell_size from the surface (the band's width), and in the cells the
        surface crosses whose stored field does not."""
    def render(
        self,
        width: int = 1024,
        height: Optional[int] = None,
        *,
        options: Optional[RenderOptions] = None,
        lod: Optional[int] = None,
        pixel_error: Optional[float] = None,
        device: Literal["cpu", "gpu"] = "cpu",
        threads: Optional[int] = None,
        **kwargs: Any,
    ) -> _U8:
        """Ray traces the octree (a level, or by pixel error) on the CPU or, ``device="gpu"``,
        the GPU (primary rays only; ``RuntimeError`` without an adapter), uint8 of shape
        ``(height, width, 3)``: ``render(640, 480).shape == (480, 640, 3)``."""

def sample_sdf(
    mesh: Mesh,
    n: int,
    *,
    seed: int = 0,
    near_fraction: float = 0.95,
    sigmas: Tuple[float, float] = ...,
    padding: float = 0.1,
    sign: _Sign = "auto",
    threads: Optional[int] = None,
) -> Tuple[_F32, _F32]:
    """DeepSDF-style samples ``(points (n, 3), sdf (n,))``."""

def psnr(reference: _U8, test: _U8) -> float:
    """PSNR in dB of two uint8 ``(h, w, 3)`` images."""

@overload
def flip(reference: _U8, test: _U8, *, return_map: Literal[False] = False) -> float: ...
@overload
def flip(reference: _U8, test: _U8, *, return_map: Literal[True]) -> Tuple[float, _F32]:
    """Mean LDR-FLIP (0 = identical) of two uint8 ``(h, w, 3)`` images."""

def load_png(path: _Path) -> _U8:
    """Reads a PNG as uint8 ``(h, w, 3)`` RGB."""

def save_png(path: _Path, image: _U8) -> None:
    """Writes a uint8 ``(h, w, 3)`` image as an 8-bit RGB PNG, atomically; ``path`` must end
    in ``.png`` (``ValueError``)."""
