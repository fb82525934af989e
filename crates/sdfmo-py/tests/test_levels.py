"""Levels of detail from Python (issue 37): ``Octree.load`` reads files with levels, whole or
cut where a level ends, reports them (``levels``, ``file_levels``) and renders them with
``lod=`` and ``pixel_error=`` as ``sdfmo render --lod`` / ``--pixel-error`` does, the same
pixels. (The facade's side is crates/sdfmo-cli/tests/levels.rs.)"""

import json

import numpy as np
import pytest

import sdfmo
from conftest import run_cli as run


@pytest.fixture(scope="module")
def lod_file(cli, tmp_path_factory):
    """Levels 4..6 of the CLI's demo part, built by ``sdfmo build --lod``; and where each level
    ends (from ``sdfmo info --json``)."""
    path = tmp_path_factory.mktemp("levels") / "demo.lod.smo"
    run(cli, "build", "-d", "6", "--lod", "--coarsest", "4", "-o", path)
    info = json.loads(run(cli, "info", path, "--json").stdout)
    ends = {row["level"]: row["offset"] + row["bytes"] for row in info["levels"]}
    assert sorted(ends) == [4, 5, 6]
    return path, ends


def cli_image(cli, smo, png, *args):
    r = run(cli, "render", smo, "--size", "40x32", "-o", png, "--json", *args)
    return sdfmo.load_png(png), json.loads(r.stdout), r.stderr


def test_every_level_boundary_prefix_draws_the_cli_images(cli, lod_file, tmp_path):
    path, ends = lod_file
    data = path.read_bytes()
    png = tmp_path / "cli.png"
    for finest, end in ends.items():
        cut = tmp_path / f"cut{finest}.smo"
        cut.write_bytes(data[:end])
        octree = sdfmo.Octree.load(cut)
        assert octree.levels == list(range(4, finest + 1))
        assert octree.file_levels == [4, 5, 6]
        assert octree.depth == finest
        assert sdfmo.Octree.from_bytes(data[:end]).levels == octree.levels
        # The default: the finest level held, as the CLI draws it.
        img, j, _ = cli_image(cli, cut, png, "--mode", "normal")
        np.testing.assert_array_equal(octree.render(40, 32, mode="normal"), img)
        assert j["levels"]["held"] == octree.levels
        for k in octree.levels:
            img, j, _ = cli_image(cli, cut, png, "--lod", str(k))
            np.testing.assert_array_equal(octree.render(40, 32, lod=k), img)
            assert j["levels"]["drawn"] == [k]
        for eye in (["--eye=0,0,5", "--normalized"], ["--views", "paper"]):
            png_eye = tmp_path / "pe.png"
            img, _, _ = cli_image(cli, cut, png_eye, "--pixel-error", "1.5", "--mode", "depth",
                                  *eye)
            if eye[0] == "--views":
                img = sdfmo.load_png(tmp_path / "pe_2.png")
                mine = octree.render(40, 32, view=2, mode="depth", pixel_error=1.5)
            else:
                mine = octree.render(40, 32, eye=(0, 0, 5), frame="normalized", mode="depth",
                                     pixel_error=1.5)
            np.testing.assert_array_equal(mine, img)
        # What `save` writes is the file of the levels held: it loads whole, the same images.
        again = tmp_path / f"again{finest}.smo"
        octree.save(again)
        whole = sdfmo.Octree.load(again)
        assert whole.levels == whole.file_levels == octree.levels
        assert octree.to_bytes() == again.read_bytes() and octree.nbytes == len(octree.to_bytes())
        np.testing.assert_array_equal(whole.render(24, lod=4), octree.render(24, lod=4))
    # The whole file is itself, byte for byte.
    assert sdfmo.Octree.load(path).to_bytes() == data


def test_level_errors_name_what_is_held(cli, lod_file, tmp_path):
    path, ends = lod_file
    data = path.read_bytes()
    cut = tmp_path / "cut5.smo"
    cut.write_bytes(data[: ends[5]])
    octree = sdfmo.Octree.load(cut)
    with pytest.raises(ValueError, match=r"level 6 is not in the data: it holds levels 4\.\.=5"):
        octree.render(16, lod=6)
    with pytest.raises(ValueError, match="lod must be a level in 0..=16, got 40"):
        octree.render(16, lod=40)
    with pytest.raises(ValueError, match="exclude each other"):
        octree.render(16, lod=4, pixel_error=1.0)
    for bad in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="pixel error must be finite and > 0"):
            octree.render(16, pixel_error=bad)
    with pytest.raises(TypeError, match="pixel_error"):
        octree.render(16, pixel_error="1")
    # Mesh.render has no levels.
    mesh = sdfmo.Mesh(np.eye(3, dtype=np.float32), np.array([[0, 1, 2]]))
    with pytest.raises(TypeError, match="lod"):
        mesh.render(16, lod=1)
    # Cut inside level 6 (9 bytes past level 5's end; levels start 8-byte aligned).
    inside = data[: ends[5] + 9]
    with pytest.raises(sdfmo.FormatError, match="end inside level 6"):
        sdfmo.Octree.from_bytes(inside)
    cut.write_bytes(inside)
    with pytest.raises(sdfmo.FormatError, match="end inside level 6"):
        sdfmo.Octree.load(cut)
    # A file without levels: its one level, no pixel error.
    flat = tmp_path / "flat.smo"
    run(cli, "build", "-d", "5", "-o", flat)
    o = sdfmo.Octree.load(flat)
    assert o.levels == o.file_levels == [5]
    np.testing.assert_array_equal(o.render(16, lod=5), o.render(16))
    with pytest.raises(ValueError, match="it holds level 5 only"):
        o.render(16, lod=4)
    with pytest.raises(ValueError, match="has no levels of detail"):
        o.render(16, pixel_error=1.0)


def test_levels_of_bricks_load_as_their_levels(cli, lod_file, tmp_path):
    """A format-4.1 file (``sdfmo build --lod --format 3``) and each of its level-boundary
    prefixes load from a path and from bytes with the levels of the 2.0 file, and render alike."""
    path, _ = lod_file
    v4 = tmp_path / "demo.v4.smo"
    run(cli, "build", "-d", "6", "--lod", "--coarsest", "4", "--format", "3", "-o", v4)
    info = json.loads(run(cli, "info", v4, "--json").stdout)
    assert info["version"] == "4.1 (levels of bricks)"
    data = v4.read_bytes()
    two = sdfmo.Octree.load(path)
    for row in info["levels"]:
        k = row["level"]
        cut = data[: row["offset"] + row["bytes"]]
        octree = sdfmo.Octree.from_bytes(cut)
        assert octree.levels == list(range(4, k + 1))
        assert octree.file_levels == [4, 5, 6]
        np.testing.assert_array_equal(octree.render(40, 32, lod=k), two.render(40, 32, lod=k))
    assert sdfmo.Octree.load(v4).levels == [4, 5, 6]
