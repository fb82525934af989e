"""Every bad input, and the exception it raises (the table of docs/results/python.md is
printed from BAD_INPUTS by scripts/measure.py)."""

import inspect
import re
import sys

import numpy as np
import pytest

import sdfmo

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
MESH = sdfmo.Mesh(V, F)
P = np.zeros((4, 3))
IMG = np.zeros((8, 8, 3), np.uint8)


def nan_points():
    p = np.zeros((5, 3))
    p[3, 1] = np.nan
    return p


# (description, call, exception, text the message must contain)
BAD_INPUTS = [
    ("vertices of shape (4, 2)", lambda: sdfmo.Mesh(V[:, :2], F), ValueError, "shape"),
    ("vertices of dtype int", lambda: sdfmo.Mesh(V.astype(int), F), ValueError, "dtype"),
    ("vertices with a NaN", lambda: sdfmo.Mesh(np.where(V == 1, np.nan, V), F), ValueError, "vertices[1]"),
    ("vertices with an inf", lambda: sdfmo.Mesh(np.where(V == 1, np.inf, V), F), ValueError, "not finite"),
    ("face index out of range", lambda: sdfmo.Mesh(V, F + 1), ValueError, "faces[1, 2] = 4"),
    ("negative face index", lambda: sdfmo.Mesh(V, F - 1), ValueError, "faces[0, 0] = -1"),
    ("faces of dtype float", lambda: sdfmo.Mesh(V, F.astype(float)), ValueError, "integers"),
    ("faces of shape (4, 4)", lambda: sdfmo.Mesh(V, np.zeros((4, 4), int)), ValueError, "shape"),
    ("no faces", lambda: sdfmo.Mesh(V, np.zeros((0, 3), int)), ValueError, "at least one"),
    ("a mesh of one point", lambda: sdfmo.Mesh(np.ones((4, 3)), F), ValueError, "extent 0"),
    ("a mesh of zero-area triangles", lambda: sdfmo.Mesh(V * [1, 0, 0], F), ValueError, "zero area"),
    ("points of shape (4, 2)", lambda: MESH.signed_distance(P[:, :2]), ValueError, "(..., 3)"),
    ("points of dtype int", lambda: MESH.signed_distance(P.astype(int)), ValueError, "dtype int64"),
    ("points of dtype complex", lambda: MESH.signed_distance(P.astype(complex)), ValueError, "complex"),
    ("points of dtype object", lambda: MESH.signed_distance(np.array([[None] * 3])), ValueError, "dtype object"),
    ("points as a scalar", lambda: MESH.signed_distance(1.0), ValueError, "shape"),
    ("points with a NaN", lambda: MESH.signed_distance(nan_points()), ValueError, "points[3]"),
    ("points with a NaN (unsigned)", lambda: MESH.unsigned_distance(nan_points()), ValueError, "points[3]"),
    ("points with a NaN (winding)", lambda: MESH.winding_number(nan_points()), ValueError, "points[3]"),
    ("points with a NaN (octree)", lambda: MESH.build(3).distance(nan_points()), ValueError, "points[3]"),
    ("unknown sign", lambda: MESH.signed_distance(P, sign="normal"), ValueError, "sign must be"),
    ("threads=0", lambda: MESH.signed_distance(P, threads=0), ValueError, "threads"),
    ("threads=-2", lambda: MESH.unsigned_distance(P, threads=-2), ValueError, "threads"),
    ("rays of different shapes", lambda: MESH.ray_intersect(P, P[:2]), ValueError, "same shape"),
    ("zero ray direction", lambda: MESH.ray_intersect(P, np.zeros((4, 3))), ValueError, "directions[0] is zero"),
    ("NaN ray origin", lambda: MESH.ray_intersect(nan_points(), np.ones((5, 3))), ValueError, "origins[3]"),
    ("negative t_max", lambda: MESH.ray_intersect(P, np.ones((4, 3)), t_max=-1), ValueError, "t_max"),
    ("depth 0", lambda: MESH.build(0), ValueError, "depth"),
    ("depth 17", lambda: MESH.build(17), ValueError, "depth"),
    ("max_voxels 0", lambda: MESH.build(4, max_voxels=0), ValueError, "max_voxels"),
    ("unknown method", lambda: MESH.build(4, method="dense"), ValueError, "method"),
    ("bits 12", lambda: MESH.build(4, bits=12), ValueError, "bits"),
    ("max_memory too small", lambda: MESH.build(9, max_memory=1000), MemoryError, "budget"),
    ("render width 0", lambda: MESH.render(0), ValueError, "width"),
    ("render too large", lambda: MESH.render(32768, 8193), ValueError, "at most 32768 per side and 268435456 pixels"),
    ("unknown render mode", lambda: MESH.render(8, mode="phong"), ValueError, "mode"),
    ("view 4", lambda: MESH.render(8, view=4), ValueError, "view"),
    ("shadows in mask mode", lambda: MESH.render(8, mode="mask", shadows=True), ValueError, "lambert"),
    ("eye == target", lambda: MESH.render(8, eye=(0, 0, 0), target=(0, 0, 0)), ValueError,
     "the same point (0, 0, 0) (frame=\"model\")"),
    ("fov 180", lambda: MESH.render(8, fov=180), ValueError, "fov"),
    ("sample_sdf n < 0", lambda: sdfmo.sample_sdf(MESH, -1), ValueError, "n must be"),
    ("sample_sdf near_fraction 2", lambda: sdfmo.sample_sdf(MESH, 10, near_fraction=2), ValueError, "near_fraction"),
    ("sample_sdf sigma NaN", lambda: sdfmo.sample_sdf(MESH, 10, sigmas=(np.nan, 0.1)), ValueError, "sigmas[0]"),
    ("psnr of different sizes", lambda: sdfmo.psnr(IMG, IMG[:4]), ValueError, "sizes differ"),
    ("psnr of float images", lambda: sdfmo.psnr(IMG.astype(float), IMG), ValueError, "uint8"),
    ("flip of (h, w) images", lambda: sdfmo.flip(IMG[..., 0], IMG[..., 0]), ValueError, "(h, w, 3)"),
    ("Mesh.load of a missing file", lambda: sdfmo.Mesh.load("/nonexistent/x.stl"), FileNotFoundError, "x.stl"),
    ("Mesh.load of a directory", lambda: sdfmo.Mesh.load("/"), IsADirectoryError, "/"),
    ("Mesh.load of a device", lambda: sdfmo.Mesh.load("/dev/zero"), OSError, "/dev/zero"),
    ("Octree.load of a missing file", lambda: sdfmo.Octree.load("/nonexistent/x.smo"), FileNotFoundError, "x.smo"),
    ("Octree.from_bytes of junk", lambda: sdfmo.Octree.from_bytes(b"junk" * 40), sdfmo.FormatError, ""),
    ("Octree.save into a directory", lambda: MESH.build(3).save("/"), OSError, "/"),
    ("Octree.save as .bin", lambda: MESH.build(3).save("/tmp/x.bin"), ValueError, "must end in .smo"),
    ("save_png as .jpg", lambda: sdfmo.save_png("/tmp/x.jpg", IMG), ValueError, "must end in .png"),
    ("Octree.save into a missing folder", lambda: MESH.build(3).save("/nonexistent/dir/x.smo"), FileNotFoundError, "x.smo"),
    ("load_png of a missing file", lambda: sdfmo.load_png("/nonexistent/x.png"), FileNotFoundError, "x.png"),
    ("Octree.from_bytes of a str", lambda: sdfmo.Octree.from_bytes("junk"), TypeError, "bytes-like object"),
    ("Octree.from_bytes of a strided array", lambda: sdfmo.Octree.from_bytes(np.zeros(64, np.uint8)[::2]),
     TypeError, "not C-contiguous"),
]


@pytest.mark.parametrize("what,call,exc,text", BAD_INPUTS, ids=[b[0] for b in BAD_INPUTS])
def test_bad_input_raises_its_exception(what, call, exc, text):
    with pytest.raises(exc) as e:
        call()
    assert type(e.value) is exc or (exc is OSError and isinstance(e.value, OSError)), type(e.value)
    assert text in str(e.value), str(e.value)


def test_exception_classes():
    assert issubclass(sdfmo.FormatError, ValueError)
    assert issubclass(sdfmo.MeshError, ValueError)
    assert sdfmo.FormatError.__module__ == "sdfmo"
    assert sdfmo.FormatError.__doc__


def test_every_public_name_has_a_docstring():
    for name in sdfmo.__all__:
        if name == "__version__":
            continue
        obj = getattr(sdfmo, name)
        assert obj.__doc__ and len(obj.__doc__) > 20, name
        if not isinstance(obj, type):
            continue
        for attr, value in vars(obj).items():
            if attr.startswith("_"):
                continue
            assert value.__doc__, f"{name}.{attr}"


def test_keyword_options_keep_pythons_errors_and_signatures():
    # build, sample_sdf and RenderOptions declare their keyword-only options in their PyO3
    # signatures (a hand-written **kwargs parser before): unknown or mistyped keywords fail as
    # Python's own argument checks do, and help() / inspect.signature show every option and its
    # default. render passes the keywords it does not declare to RenderOptions.
    # A value of the wrong type: PyO3 (0.30) names the argument in a note of the TypeError
    # ("while processing 'x'", shown under the message), which needs Python >= 3.11.
    def naming(name):
        return f"while processing '{name}'" if sys.version_info >= (3, 11) else ""

    cases = [
        (lambda: MESH.render(8, colour="red"), "RenderOptions.__new__() got an unexpected keyword argument 'colour'"),
        (lambda: MESH.build(3).render(8, shadow=True), "unexpected keyword argument 'shadow'"),
        (lambda: MESH.build(4, method=1), naming("method")),
        (lambda: MESH.build(4, depth_max=5), "build() got an unexpected keyword argument 'depth_max'"),
        (lambda: sdfmo.sample_sdf(MESH, 10, seeds=1), "sample_sdf() got an unexpected keyword argument 'seeds'"),
        (lambda: sdfmo.sample_sdf(MESH, 10, sigmas="big"), naming("sigmas")),
        (lambda: MESH.render(8, 8, "mask"), ""),  # keyword-only, as before
    ]
    for call, text in cases:
        with pytest.raises(TypeError, match=re.escape(text) or None):
            call()
    keyword_only = inspect.Parameter.KEYWORD_ONLY
    for function, name, default in [
        (sdfmo.RenderOptions, "mode", None),
        (sdfmo.Mesh.render, "options", None),
        (sdfmo.Octree.render, "pixel_error", None),
        (sdfmo.Mesh.build, "max_memory", None),
        (sdfmo.sample_sdf, "near_fraction", 0.95),
    ]:
        parameter = inspect.signature(function).parameters[name]
        assert (parameter.kind, parameter.default) == (keyword_only, default), (function, name)
    # The options still arrive: another mode gives another image.
    lambert = MESH.render(16, view=1, threads=1)
    mask = MESH.render(16, mode="mask", view=1, threads=1)
    assert lambert.shape == mask.shape == (16, 16, 3)
    assert not np.array_equal(lambert, mask)


def test_a_degenerate_mesh_is_refused_where_it_is_made():
    # Before issue 37 a mesh of one point (or of triangles without area) was accepted and
    # answered every query: sample_sdf returned zeros, only build refused it. Now the builder's
    # own check (BuildError::DegenerateMesh) runs where the Mesh is made.
    point = np.ones((4, 3))
    with pytest.raises(ValueError, match="degenerate mesh: the bounding box has extent 0"):
        sdfmo.Mesh(point, F)
    # Cleaning drops every degenerate triangle first, as Mesh.load does.
    with pytest.raises(ValueError, match="no triangles"):
        sdfmo.Mesh(point, F, clean=True)
    line = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], np.float64)
    with pytest.raises(ValueError, match="degenerate mesh: every triangle has zero area"):
        sdfmo.Mesh(line, F)
    # One triangle with area is enough: the others may be degenerate.
    m = sdfmo.Mesh(np.vstack([V, [[5, 5, 5]]]), np.vstack([F, [[4, 4, 4]]]))
    assert m.face_count == 5


def test_outputs_must_carry_their_formats_extension(tmp_path):
    # Before issue 37 save_png("x.jpg") and Octree.save("x.bin") wrote PNG and .smo bytes under
    # those names, where the CLI refuses them; now the same rule (sdfmo_io::check_output), the
    # CLI's message with the parameter's name.
    with pytest.raises(ValueError) as e:
        sdfmo.save_png(tmp_path / "x.jpg", IMG)
    assert str(e.value) == f"{tmp_path / 'x.jpg'}: path must end in .png (the format follows the extension)"
    octree = MESH.build(3)
    with pytest.raises(ValueError, match=r"x\.bin: path must end in \.smo \(the format follows"):
        octree.save(tmp_path / "x.bin")
    with pytest.raises(ValueError, match=r"must end in \.smo"):
        octree.save(tmp_path / "noext")
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    # Any case, as the CLI.
    sdfmo.save_png(tmp_path / "x.PNG", IMG)
    octree.save(tmp_path / "x.Smo")
    assert sdfmo.Octree.load(tmp_path / "x.Smo").to_bytes() == octree.to_bytes()
    # A directory is still the file system's refusal, checked first as the CLI does.
    with pytest.raises(IsADirectoryError):
        octree.save(tmp_path)


def test_from_bytes_takes_any_bytes_like_object():
    # Before issue 37 from_bytes(bytearray(...)) was a TypeError: only bytes were taken.
    data = MESH.build(4).to_bytes()
    a = np.frombuffer(data, np.uint8)
    for obj in [data, bytearray(data), memoryview(data), memoryview(bytearray(data)), a, a.copy(),
                a.copy().view(np.int8), memoryview(data).cast("B", (len(data) // 4, 4))]:
        assert sdfmo.Octree.from_bytes(obj).to_bytes() == data, type(obj)
    # A writable buffer is copied: changing it afterwards does not change the octree.
    buf = bytearray(data)
    octree = sdfmo.Octree.from_bytes(buf)
    buf[:] = bytes(len(buf))
    assert octree.to_bytes() == data
    with pytest.raises(sdfmo.FormatError):
        sdfmo.Octree.from_bytes(bytearray())


def test_image_sizes_are_said_in_numpys_order():
    # Before issue 37 the message said "reference is 8×8, test is 8×4" (width × height) for
    # arrays of shape (8, 8, 3) and (4, 8, 3).
    with pytest.raises(ValueError) as e:
        sdfmo.psnr(IMG, IMG[:4])
    assert str(e.value) == (
        "image sizes differ: reference has shape (8, 8, 3), test (4, 8, 3) (height, width, channels)"
    )
    assert MESH.render(6, 4).shape == (4, 6, 3)
