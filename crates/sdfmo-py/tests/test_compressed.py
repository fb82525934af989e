"""The compressed container from Python: ``Octree.load`` and ``Octree.from_bytes`` read what
``sdfmo build --compress`` writes as the same octree, and ``save(compress=...)`` writes a file
the CLI reads back the same."""

import json

import numpy as np
import pytest

import sdfmo
from conftest import run_cli as run


@pytest.mark.parametrize("lod", [False, True])
def test_compressed_files_load_and_render_as_the_plain_ones(cli, tmp_path, lod):
    extra = ["--lod", "--coarsest", "4"] if lod else []
    plain, packed = tmp_path / "plain.smo", tmp_path / "packed.smo"
    run(cli, "build", "-d", "6", "-o", plain, *extra)
    run(cli, "build", "-d", "6", "-o", packed, "--compress", *extra)
    assert packed.stat().st_size * 4 < plain.stat().st_size
    a, b = sdfmo.Octree.load(plain), sdfmo.Octree.load(packed)
    # The same octree: the same bytes of the .smo, the same levels and pixels.
    assert a.to_bytes() == b.to_bytes()
    assert a.levels == b.levels
    assert np.array_equal(a.render(48, 40), b.render(48, 40))
    for data in (packed.read_bytes(), bytearray(packed.read_bytes())):
        assert sdfmo.Octree.from_bytes(data).to_bytes() == a.to_bytes()


def test_save_compressed_round_trips_through_the_cli(cli, tmp_path):
    plain = tmp_path / "plain.smo"
    run(cli, "build", "-d", "6", "-o", plain)
    octree = sdfmo.Octree.load(plain)
    out = tmp_path / "out.smo"
    octree.save(out, compress=3)
    assert out.read_bytes()[:4] == b"\x89SMZ"
    assert sdfmo.Octree.load(out).to_bytes() == plain.read_bytes()
    info = json.loads(run(cli, "info", out, "--json").stdout)
    assert info["compressed"] is True and info["stored_bytes"] == out.stat().st_size
    for bad in (0, 23):
        with pytest.raises(ValueError, match="zstd level 1..=22"):
            octree.save(tmp_path / "bad.smo", compress=bad)
    assert not (tmp_path / "bad.smo").exists()


def test_a_damaged_compressed_file_is_a_format_error(cli, tmp_path):
    packed = tmp_path / "packed.smo"
    run(cli, "build", "-d", "5", "-o", packed, "--compress")
    data = bytearray(packed.read_bytes())
    data[len(data) // 2] ^= 0xFF
    with pytest.raises(sdfmo.FormatError):
        sdfmo.Octree.from_bytes(bytes(data))
    with pytest.raises(sdfmo.FormatError):
        sdfmo.Octree.from_bytes(bytes(data[:100]))


@pytest.mark.parametrize("compress", [False, True])
def test_a_format_3_file_is_read_in_place(cli, tmp_path, compress):
    # A 3.0 file is kept as its bricks (its own bytes, a fraction of the 1.x file's), with the
    # distances, images and counts of the 1.x build.
    v1, v3, plain = tmp_path / "v1.smo", tmp_path / "v3.smo", tmp_path / "plain.smo"
    run(cli, "build", "-d", "6", "-o", v1)
    run(cli, "build", "-d", "6", "--format", "3", "-o", v3, *(["--compress"] if compress else []))
    run(cli, "build", "-d", "6", "--format", "3", "-o", plain)
    assert v3.read_bytes()[:10] != v1.read_bytes()[:10]
    a, b = sdfmo.Octree.load(v1), sdfmo.Octree.load(v3)
    assert b.to_bytes() == plain.read_bytes()
    assert b.nbytes == len(plain.read_bytes()) < a.nbytes
    b.save(tmp_path / "again.smo")
    assert (tmp_path / "again.smo").read_bytes() == plain.read_bytes()
    for key in ("depth", "bits", "nodes", "leaves", "voxels", "surface_voxels", "center", "scale"):
        assert a.stats[key] == b.stats[key], key
    assert np.array_equal(a.render(48, 32), b.render(48, 32))
    assert np.array_equal(a.render(48, 32, mode="depth"), b.render(48, 32, mode="depth"))
    points = np.random.default_rng(34).uniform(-1.2, 1.2, size=(2000, 3)).astype(np.float32)
    # (Points outside the octree are NaN in both.)
    assert np.array_equal(a.distance(points), b.distance(points), equal_nan=True)
    for data in (v3.read_bytes(), bytearray(v3.read_bytes())):
        assert np.array_equal(
            sdfmo.Octree.from_bytes(data).distance(points), a.distance(points), equal_nan=True
        )
    damaged = bytearray(v3.read_bytes())
    damaged[len(damaged) // 2] ^= 0xFF
    with pytest.raises(sdfmo.FormatError):
        sdfmo.Octree.from_bytes(damaged)
