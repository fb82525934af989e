"""The shared meshes from files: accuracy against the f64 reference, and the octree round trip
against the command-line tool (same .smo bytes, same images)."""

import subprocess

import numpy as np
import pytest

import sdfmo
import reference
from conftest import SHARED_MESHES, run_cli


@pytest.fixture(scope="module")
def meshes(data_dir):
    return {name: sdfmo.Mesh.load(data_dir / name) for name in SHARED_MESHES}


def test_shared_meshes_load_with_their_topology(meshes):
    # The data README's counts (after welding and cleaning) and topology.
    assert meshes["abc5.stl"].face_count == 5080
    assert meshes["abc5.stl"].component_count >= 10
    assert not meshes["abc1.stl"].is_watertight
    assert not meshes["teapot.obj"].is_watertight
    assert meshes["teapot.obj"].auto_sign == "winding"
    for name, m in meshes.items():
        lo, hi = m.bounds
        assert (hi > lo).all(), name
        assert m.faces.max() < m.vertex_count, name


@pytest.mark.parametrize("name", SHARED_MESHES)
def test_distance_matches_the_f64_reference(meshes, name):
    m = meshes[name]
    pts, diag = reference.query_points(m, 60, seed=11)
    ref, ref_face = reference.unsigned_distance(m, pts)
    d, face = m.signed_distance(pts, return_face=True)
    u = m.unsigned_distance(pts)
    # Within 1e-6 of the bounding-box diagonal (model units in and out).
    err = np.abs(np.abs(d.astype(np.float64)) - ref) / diag
    assert err.max() <= 1e-6, (name, err.max())
    np.testing.assert_array_equal(np.abs(d), u)
    # The face found is a closest one (ties allowed).
    assert (np.abs(np.linalg.norm(
        m.signed_distance(pts, return_closest=True)[1] - pts, axis=1) - ref) / diag <= 1e-6).all()
    # Sign: the exact winding number away from the surface (closed parts and open sheets alike
    # are inside where w > 1/2 for these meshes' orientation).
    w = reference.winding_number(m, pts)
    far = (ref > 0.01 * diag) & (np.abs(w - 0.5) > 0.2)
    agree = np.mean((d[far] < 0) == (w[far] > 0.5))
    assert agree >= 0.95, (name, agree)


def test_loading_errors_name_the_file(data_dir, tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        sdfmo.Mesh.load(tmp_path / "missing.stl")
    assert "missing.stl" in str(e.value)
    with pytest.raises(IsADirectoryError):
        sdfmo.Mesh.load(tmp_path)
    bad = tmp_path / "bad.obj"
    bad.write_text("v 0 0 0\nv 1 0 0\nf 1 2 9\n")
    with pytest.raises(sdfmo.MeshError) as e:
        sdfmo.Mesh.load(bad)
    assert "bad.obj" in str(e.value) and isinstance(e.value, ValueError)
    cut = tmp_path / "cut.stl"
    cut.write_bytes((data_dir / "abc8.stl").read_bytes()[:1000])
    with pytest.raises(sdfmo.MeshError):
        sdfmo.Mesh.load(cut)


def test_octree_round_trip_equals_the_cli(meshes, data_dir, cli, tmp_path):
    mesh_path = data_dir / "abc8.stl"
    m = meshes["abc8.stl"]
    octree = m.build(6, threads=2)
    stats = octree.stats
    assert stats["depth"] == 6 and stats["bytes"] == octree.nbytes and stats["voxels"] > 0
    assert "build_ms" in stats and sum(stats["voxels_per_leaf"]) == stats["leaves"]
    # Same bytes as `sdfmo build`, whatever the thread count.
    out = tmp_path / "cli.smo"
    subprocess.run([cli, "build", mesh_path, "--depth", "6", "-o", out], check=True,
                   capture_output=True)
    cli_bytes = out.read_bytes()
    assert octree.to_bytes() == cli_bytes
    assert m.build(6, threads=1).to_bytes() == cli_bytes
    # Save, load, render: the same image as `sdfmo render`.
    mine = tmp_path / "py.smo"
    octree.save(mine)
    assert mine.read_bytes() == cli_bytes
    loaded = sdfmo.Octree.load(mine)
    assert loaded.stats["voxels"] == stats["voxels"] and "build_ms" not in loaded.stats
    for mode in ("lambert", "normal"):
        img = loaded.render(96, mode=mode)
        assert img.shape == (96, 96, 3) and img.dtype == np.uint8
        png = tmp_path / f"cli_{mode}.png"
        subprocess.run([cli, "render", out, "--size", "96", "--mode", mode, "-o", png],
                       check=True, capture_output=True)
        np.testing.assert_array_equal(img, sdfmo.load_png(png))
    # The mesh reference image, as `sdfmo render-mesh`.
    ref = m.render(96)
    png = tmp_path / "cli_mesh.png"
    subprocess.run([cli, "render-mesh", mesh_path, "--size", "96", "-o", png], check=True,
                   capture_output=True)
    np.testing.assert_array_equal(ref, sdfmo.load_png(png))
    # psnr / flip as `sdfmo compare`.
    img = loaded.render(96)
    p, f = sdfmo.psnr(ref, img), sdfmo.flip(ref, img)
    assert 15 < p < 60 and 0 < f < 0.5
    assert sdfmo.psnr(img, img) == float("inf") and sdfmo.flip(img, img) == 0.0
    cmp = subprocess.run([cli, "compare", png, tmp_path / "cli_lambert.png", "--json"],
                         check=True, capture_output=True, text=True)
    import json
    j = json.loads(cmp.stdout)
    assert j["psnr"] == pytest.approx(p, rel=1e-9)
    assert j["flip"] == pytest.approx(f, rel=1e-6)


def test_octree_distance_is_the_stored_field(meshes):
    m = meshes["abc8.stl"]
    octree = m.build(7)
    pts, diag = reference.query_points(m, 400, seed=3)
    exact = m.signed_distance(pts)
    stored = octree.distance(pts)
    known = ~np.isnan(stored)
    assert known.sum() > 20
    # Near the surface the stored field follows the exact one within about a voxel.
    voxel = (2.0 / 2**7) / octree.stats["scale"]
    near = known & (np.abs(exact) < voxel)
    assert near.sum() > 10
    assert np.abs(stored[near] - exact[near]).max() < 2 * voxel
    # Outside the root cube: NaN.
    assert np.isnan(octree.distance([[1e6, 0, 0]]))[0]


def test_octree_distance_is_nan_beyond_the_documented_band(meshes):
    # Octree.distance documents its band: NaN at every point farther than 1.78 * cell_size
    # from the surface (a leaf cell's diagonal grown by a quantisation step on each side), and
    # finite at 99.7 % of the points within 0.1 * cell_size on the teapot.
    m = meshes["teapot.obj"]
    rng = np.random.default_rng(5)
    surface, _ = sdfmo.sample_sdf(m, 20000, seed=2, near_fraction=1.0, sigmas=(0.0, 0.0))
    dirs = rng.normal(size=surface.shape)
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    for depth, bits, bound in [(6, 8, 1.7793), (7, 16, 1.7324)]:
        octree = m.build(depth, bits=bits)
        h = octree.cell_size
        assert h == pytest.approx(2.0 / (2**depth * octree.stats["scale"]), rel=1e-12)
        pts = surface + dirs * (h * rng.uniform(0.0, 4.0, size=(len(surface), 1)))
        d = octree.distance(pts)
        true = m.unsigned_distance(pts) / h
        finite = np.isfinite(d)
        assert (true[finite] <= bound).all(), true[finite].max()
        assert (true > bound).sum() > 1000
        # The band is about a cell wide, not less: some points past one cell are finite.
        assert (finite & (true > 1.0)).sum() > 50
        near = true < 0.1
        assert near.sum() > 500
        assert finite[near].mean() >= 0.99, finite[near].mean()


def test_corrupt_octree_files_raise_format_error(meshes, tmp_path):
    data = meshes["abc8.stl"].build(5).to_bytes()
    for name, bad in [
        ("truncated", data[: len(data) // 2]),
        ("flipped", data[:100] + bytes([data[100] ^ 0xFF]) + data[101:]),
        ("empty", b""),
        ("magic", b"NOTSMO" + data[6:]),
    ]:
        p = tmp_path / f"{name}.smo"
        p.write_bytes(bad)
        with pytest.raises(sdfmo.FormatError):
            sdfmo.Octree.load(p)
        with pytest.raises(sdfmo.FormatError):
            sdfmo.Octree.from_bytes(bad)
    with pytest.raises(FileNotFoundError):
        sdfmo.Octree.load(tmp_path / "none.smo")


def test_fitted_corners_and_levels_equal_the_cli(meshes, data_dir, cli, tmp_path):
    """``Mesh.build(fit_corners=True)`` and ``Mesh.build(coarsest=...)`` write the bytes of
    ``sdfmo build --fit-corners`` and ``sdfmo build --lod --coarsest``."""
    mesh_path = data_dir / "abc5.stl"
    m = meshes["abc5.stl"]
    exact = m.build(6)
    fitted = m.build(6, fit_corners=True)
    out = tmp_path / "fit.smo"
    run_cli(cli, "build", mesh_path, "--depth", "6", "--fit-corners", "-o", out)
    assert fitted.to_bytes() == out.read_bytes()
    # The same leaves and voxels, other corner values.
    for key in ("leaves", "voxels", "surface_voxels", "bytes"):
        assert fitted.stats[key] == exact.stats[key], key
    assert fitted.to_bytes() != exact.to_bytes()

    levels = m.build(6, coarsest=4, fit_corners=True)
    assert levels.levels == levels.file_levels == [4, 5, 6]
    assert levels.stats["depth"] == 6 and levels.stats["voxels"] == fitted.stats["voxels"]
    out = tmp_path / "levels.smo"
    run_cli(cli, "build", mesh_path, "--depth", "6", "--lod", "--coarsest", "4", "--fit-corners",
            "-o", out)
    assert levels.to_bytes() == out.read_bytes()
    np.testing.assert_array_equal(levels.render(32, lod=6), fitted.render(32))
    for bad in (0, 7, -1, 300):
        with pytest.raises(ValueError, match=f"coarsest must be in 1..=6 \\(the depth\\), got {bad}"):
            m.build(6, coarsest=bad)
