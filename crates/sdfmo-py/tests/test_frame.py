"""One coordinate frame in every front-end: Python's points and cameras are model units, as the
command line's are by default (`sdfmo distance`, `sdfmo render --eye`); the same point gives
the same number and the same eye the same image. (The facade's side is
crates/sdfmo-cli/tests/frame.rs.)"""

import json

import numpy as np
import pytest

import sdfmo
from conftest import run_cli as run

# A box far from the origin with a non-trivial scale: [10, 14] x [-3, -1] x [5, 6].
LO, HI = np.array([10.0, -3.0, 5.0]), np.array([14.0, -1.0, 6.0])


def box_mesh():
    v = np.array([[HI[k] if i >> k & 1 else LO[k] for k in range(3)] for i in range(8)], np.float32)
    quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]]
    f = np.array([t for q in quads for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])], np.int64)
    return sdfmo.Mesh(v, f)


def write_obj(mesh, path):
    with open(path, "w") as fh:
        for p in mesh.vertices:
            fh.write("v {} {} {}\n".format(*(float(c) for c in p)))
        for t in mesh.faces:
            fh.write("f {} {} {}\n".format(*(int(i) + 1 for i in t)))


def test_cli_distance_equals_signed_distance(cli, tmp_path):
    mesh = box_mesh()
    obj = tmp_path / "box.obj"
    write_obj(mesh, obj)
    pts = np.array([[12.0, -2.0, 5.5], [12.0, 0.25, 5.5], [9.1, -2.5, 5.25], [13.99, -1.01, 5.999]])
    (tmp_path / "p.xyz").write_text("".join("{!r} {!r} {!r}\n".format(*p) for p in pts.tolist()))
    out = json.loads(run(cli, "distance", obj, "--points", tmp_path / "p.xyz", "--json").stdout)
    assert out["frame"] == "model"
    ours = sdfmo.Mesh.load(str(obj)).signed_distance(pts)
    np.testing.assert_array_equal(np.array(out["distances"], np.float32), ours)
    assert abs(ours[0] + 0.5) < 1e-5 and abs(ours[1] - 1.25) < 1e-5


def test_an_eye_in_model_units_draws_the_cli_image(cli, tmp_path):
    mesh = box_mesh()
    obj = tmp_path / "box.obj"
    write_obj(mesh, obj)
    loaded = sdfmo.Mesh.load(str(obj))
    eye, target = (19.0, 2.0, 12.0), (12.0, -2.0, 5.5)
    cam = ["--eye={},{},{}".format(*eye), "--target={},{},{}".format(*target), "--size=48x32"]
    smo = tmp_path / "box.smo"
    run(cli, "build", obj, "-d", "5", "-o", smo)
    run(cli, "render", smo, *cam, "-o", tmp_path / "octree.png")
    run(cli, "render-mesh", obj, *cam, "-o", tmp_path / "mesh.png")
    octree = sdfmo.Octree.load(str(smo))
    img = octree.render(48, 32, eye=eye, target=target)
    assert (img > 0).any()
    np.testing.assert_array_equal(img, sdfmo.load_png(str(tmp_path / "octree.png")))
    np.testing.assert_array_equal(loaded.render(48, 32, eye=eye, target=target),
                                  sdfmo.load_png(str(tmp_path / "mesh.png")))
    # frame="normalized" takes the root cube's coordinates, as --normalized does.
    n = [float(c) for c in (np.asarray(eye, np.float64) - (LO + HI) / 2) * (1.9 / 4.0)]
    run(cli, "render", smo, "--eye={},{},{}".format(*n), "--normalized", "--size=48x32", "-o", tmp_path / "n.png")
    np.testing.assert_array_equal(octree.render(48, 32, eye=n, frame="normalized"),
                                  sdfmo.load_png(str(tmp_path / "n.png")))


@pytest.mark.parametrize("kw, msg", [({"eye": [1, 2]}, "eye must be 3 numbers"),
                                     ({"target": [1, 2, 3, 4]}, "target must be 3 numbers"),
                                     ({"frame": "world"}, "frame must be")])
def test_bad_camera_arguments_name_themselves(kw, msg):
    with pytest.raises(ValueError, match=msg):
        box_mesh().render(8, **kw)
