"""Queries on meshes built from numpy arrays, against closed-form answers."""

import _thread
import signal
import threading
import time

import numpy as np
import pytest

import sdfmo

# A closed, outward-oriented cube [lo, hi]^3: 8 vertices, 12 triangles.
CUBE_FACES = np.array(
    [
        [0, 1, 3], [0, 3, 2],  # x = lo
        [4, 6, 7], [4, 7, 5],  # x = hi
        [0, 4, 5], [0, 5, 1],  # y = lo
        [2, 3, 7], [2, 7, 6],  # y = hi
        [0, 2, 6], [0, 6, 4],  # z = lo
        [1, 5, 7], [1, 7, 3],  # z = hi
    ]
)


def cube(lo=-0.5, hi=0.5, offset=(0.0, 0.0, 0.0)):
    v = np.array([[x, y, z] for x in (lo, hi) for y in (lo, hi) for z in (lo, hi)], dtype=np.float64)
    return sdfmo.Mesh(v + np.asarray(offset), CUBE_FACES)


def box_sdf(p, half=0.5):
    """Exact signed distance to the axis-aligned cube of half-size `half` at the origin."""
    q = np.abs(p) - half
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=-1)
    inside = np.minimum(q.max(axis=-1), 0.0)
    return outside + inside


def test_cube_topology_and_arrays():
    m = cube()
    assert m.is_watertight
    assert m.component_count == 1
    assert m.auto_sign == "pseudonormal"
    assert m.vertices.dtype == np.float32 and m.vertices.shape == (8, 3)
    assert m.faces.dtype == np.int64 and np.array_equal(m.faces, CUBE_FACES)
    np.testing.assert_array_equal(m.bounds, [[-0.5] * 3, [0.5] * 3])
    assert (m.vertex_count, m.face_count) == (8, 12)
    assert "12 faces" in repr(m)


@pytest.mark.parametrize("sign", ["auto", "pseudonormal", "winding"])
def test_signed_distance_of_a_cube_is_exact(sign):
    rng = np.random.default_rng(1)
    p = rng.uniform(-1.5, 1.5, size=(5000, 3))
    d = cube().signed_distance(p, sign=sign)
    assert d.dtype == np.float32 and d.shape == (5000,)
    np.testing.assert_allclose(d, box_sdf(p), atol=1e-6)
    assert (d[np.abs(p).max(axis=1) < 0.49] < 0).all()


def test_model_units_in_and_out():
    # A cube of edge 2000 far from the origin: distances come back in the same units.
    scale, off = 1000.0, np.array([5000.0, -3000.0, 250.0])
    m = cube(-scale, scale, off)
    rng = np.random.default_rng(2)
    p_unit = rng.uniform(-1.5, 1.5, size=(2000, 3))
    d = m.signed_distance(p_unit * 2 * scale + off)
    np.testing.assert_allclose(d, box_sdf(p_unit) * 2 * scale, atol=1e-6 * 2 * scale * np.sqrt(3) * 4)
    d, c, f = m.signed_distance(p_unit * 2 * scale + off, return_closest=True, return_face=True)
    # The closest points lie on the cube, in model units.
    rel = (c - off) / scale
    assert np.allclose(np.abs(rel).max(axis=1), 1.0, atol=1e-5)


def test_closest_points_and_faces():
    m = cube()
    p = np.array([[2.0, 0.1, -0.2], [0.1, -0.3, 0.0], [3.0, 3.0, 3.0]])
    d, c, f = m.signed_distance(p, return_closest=True, return_face=True)
    np.testing.assert_allclose(d, [1.5, -0.2, np.sqrt(3 * 2.5**2)], rtol=1e-6)
    np.testing.assert_allclose(c[0], [0.5, 0.1, -0.2], atol=1e-7)
    np.testing.assert_allclose(c[1], [0.1, -0.5, 0.0], atol=1e-7)
    np.testing.assert_allclose(c[2], [0.5, 0.5, 0.5], atol=1e-7)
    assert f.dtype == np.int64
    assert f[0] in (2, 3) and f[1] in (4, 5)
    d2, f2 = m.signed_distance(p, return_face=True)
    np.testing.assert_array_equal(d2, d)
    np.testing.assert_array_equal(f2, f)
    u, cu = m.unsigned_distance(p, return_closest=True)
    np.testing.assert_array_equal(u, np.abs(d))
    np.testing.assert_array_equal(cu, c)


def test_dtypes_layouts_and_shapes_give_the_same_values():
    rng = np.random.default_rng(3)
    p64 = rng.uniform(-1, 1, size=(1000, 3))
    p32 = p64.astype(np.float32)
    m = cube()
    ref = m.signed_distance(p32)
    np.testing.assert_array_equal(m.signed_distance(np.asfortranarray(p32)), ref)
    np.testing.assert_array_equal(m.signed_distance(p32.astype(np.float64)), ref)
    np.testing.assert_array_equal(m.signed_distance(p32.astype(np.float16).astype(np.float32)),
                                  m.signed_distance(p32.astype(np.float16)))
    # A strided view (every other point) and a list.
    np.testing.assert_array_equal(m.signed_distance(p32[::2]), ref[::2])
    np.testing.assert_array_equal(m.signed_distance(p32[:3].tolist()), ref[:3])
    # Grids: (..., 3) in, (...) out.
    g = p32[:999].reshape(9, 111, 3)
    np.testing.assert_array_equal(m.signed_distance(g), ref[:999].reshape(9, 111))
    d, c, f = m.signed_distance(g, return_closest=True, return_face=True)
    assert d.shape == (9, 111) and c.shape == (9, 111, 3) and f.shape == (9, 111)
    assert m.signed_distance(np.zeros((0, 3))).shape == (0,)
    # Read-only inputs are fine (nothing is written to them).
    ro = p32.copy()
    ro.flags.writeable = False
    np.testing.assert_array_equal(m.signed_distance(ro), ref)


def test_threads_do_not_change_the_values():
    rng = np.random.default_rng(4)
    p = rng.uniform(-1, 1, size=(100_000, 3))
    m = cube()
    one = m.signed_distance(p, threads=1)
    np.testing.assert_array_equal(one, m.signed_distance(p, threads=2))
    np.testing.assert_array_equal(one, m.signed_distance(p))
    np.testing.assert_array_equal(m.winding_number(p, threads=1), m.winding_number(p, threads=3))


def test_winding_number_and_contains():
    m = cube()
    p = np.array([[0.0, 0.0, 0.0], [0.4, -0.4, 0.1], [2.0, 0.0, 0.0], [0.0, 0.0, -0.7]])
    w = m.winding_number(p)
    assert w.dtype == np.float32
    np.testing.assert_allclose(w, [1, 1, 0, 0], atol=1e-4)
    inside = m.contains(p)
    assert inside.dtype == np.bool_
    assert inside.tolist() == [True, True, False, False]


def test_open_sheet_uses_the_winding_number():
    # One square sheet in the y = 0 plane (open, not watertight).
    v = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], dtype=np.float32)
    m = sdfmo.Mesh(v, [[0, 2, 1], [0, 3, 2]])
    assert not m.is_watertight and m.auto_sign == "winding"
    d = m.unsigned_distance([[0.0, 0.25, 0.0], [0.0, -0.5, 0.0], [3.0, 0.0, 0.0]])
    np.testing.assert_allclose(d, [0.25, 0.5, 2.0], rtol=1e-6)


def test_ray_intersect():
    m = cube()
    o = np.array([[-3.0, 0.1, 0.2], [-3.0, 2.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 5.0]])
    d = np.array([[2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
    t, f = m.ray_intersect(o, d)
    assert t.dtype == np.float32 and f.dtype == np.int64
    np.testing.assert_allclose(t[[0, 2, 3]], [1.25, 0.5, 4.5], rtol=1e-6)
    assert t[1] == np.inf and f[1] == -1
    assert f[0] in (0, 1) and f[3] in (10, 11)
    # t_max cuts hits off.
    t2, f2 = m.ray_intersect(o, d, t_max=1.0)
    assert t2[0] == np.inf and t2[2] == pytest.approx(0.5)
    # Model units: a scaled, moved cube.
    big = cube(-100, 100, (1000, 0, 0))
    t, f = big.ray_intersect([[700.0, 0, 0]], [[1.0, 0, 0]])
    assert t[0] == pytest.approx(200.0, rel=1e-6)


def test_clean_welds_a_triangle_soup():
    v = cube().vertices[CUBE_FACES.reshape(-1)]
    soup = sdfmo.Mesh(v, np.arange(36).reshape(12, 3))
    assert not soup.is_watertight and soup.component_count == 12
    welded = sdfmo.Mesh(v, np.arange(36).reshape(12, 3), clean=True)
    assert welded.is_watertight and welded.vertex_count == 8


def test_sample_sdf_is_deterministic_and_exact():
    m = cube()
    p, d = sdfmo.sample_sdf(m, 50_000, seed=7)
    assert p.shape == (50_000, 3) and p.dtype == np.float32
    assert d.shape == (50_000,) and d.dtype == np.float32
    p1, d1 = sdfmo.sample_sdf(m, 50_000, seed=7, threads=1)
    np.testing.assert_array_equal(p, p1)
    np.testing.assert_array_equal(d, d1)
    p2, _ = sdfmo.sample_sdf(m, 50_000, seed=8)
    assert not np.array_equal(p, p2)
    # The distances are the mesh's own, bit for bit, and exact.
    np.testing.assert_array_equal(d, m.signed_distance(p))
    np.testing.assert_allclose(d, box_sdf(p.astype(np.float64)), atol=1e-6)
    # 95 % near the surface: two noise scales of 0.025 and 0.0079 of the diagonal.
    diag = np.sqrt(3.0)
    near = np.abs(d[:47_500])
    for parity, sigma in ((0, 0.025), (1, 0.0079)):
        rms = np.sqrt(np.mean(near[parity::2] ** 2))
        assert 0.7 * sigma * diag < rms < 1.3 * sigma * diag, (parity, rms)
    # 5 % uniform in the box padded by 0.1 of the extent.
    uni = p[47_500:]
    assert np.abs(uni).max() <= 0.6 + 1e-6 and np.abs(uni).max() > 0.55
    # Parameters.
    p, d = sdfmo.sample_sdf(m, 1000, near_fraction=0.0, padding=0.0, seed=1)
    assert np.abs(p).max() <= 0.5
    p, d = sdfmo.sample_sdf(m, 0)
    assert p.shape == (0, 3)


def uv_sphere(n_lat=100, n_lon=200, r=1.0):
    """A closed, outward UV sphere: poles plus (n_lat - 1) rings of n_lon vertices."""
    th = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    t, p = np.meshgrid(th, ph, indexing="ij")
    ring = np.stack([np.sin(t) * np.cos(p), np.cos(t), np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    v = np.concatenate([[[0, 1, 0]], ring, [[0, -1, 0]]]) * r
    idx = lambda i, j: 1 + i * n_lon + (j % n_lon)  # noqa: E731
    f = []
    for j in range(n_lon):
        f.append([0, idx(0, j + 1), idx(0, j)])
        f.append([len(v) - 1, idx(n_lat - 2, j), idx(n_lat - 2, j + 1)])
        for i in range(n_lat - 2):
            a, b, c, d = idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1)
            f += [[a, b, d], [a, d, c]]
    return sdfmo.Mesh(v, np.array(f))


def test_uv_sphere_is_a_closed_sphere():
    m = uv_sphere(20, 40)
    assert m.is_watertight and m.auto_sign == "pseudonormal"
    d = m.signed_distance([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    assert -1.0 < d[0] < -0.95 and 0.99 < d[1] <= 1.0 + 1e-6


def test_calls_release_the_gil():
    # A long query in a thread; the main thread keeps running Python meanwhile.
    m = uv_sphere()
    p = np.random.default_rng(5).uniform(-2, 2, size=(200_000, 3)).astype(np.float32)
    done = []
    t = threading.Thread(target=lambda: done.append(m.signed_distance(p, threads=1)))
    t.start()
    ticks = 0
    start = time.perf_counter()
    while t.is_alive():
        ticks += 1
        time.sleep(0.001)
    elapsed = time.perf_counter() - start
    t.join()
    assert done and done[0].shape == (200_000,)
    # With the GIL held the loop would not run at all until the call returned.
    assert elapsed < 0.05 or ticks > 10, (elapsed, ticks)


@pytest.fixture
def python_handles_ctrl_c():
    """Python's own SIGINT handler for the test: a process started with SIGINT ignored (a
    background job of a non-interactive shell) inherits that, and `interrupt_main` then does
    nothing at all, as Ctrl-C would not either."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_ctrl_c_interrupts_a_long_call(python_handles_ctrl_c):
    m = uv_sphere()
    p = np.random.default_rng(6).uniform(-2, 2, size=(5_000_000, 3)).astype(np.float32)
    m.signed_distance(p[:10])  # the BVH, outside the timed call
    timer = threading.Timer(0.3, _thread.interrupt_main)
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        m.signed_distance(p, threads=1)
    elapsed = time.perf_counter() - start
    timer.join()
    # Stopped within a chunk of the signal, long before the 5 M points (about 30 s) were done.
    assert elapsed < 2.0, elapsed
    # The mesh is still usable afterwards.
    assert m.signed_distance(p[:3]).shape == (3,)


def test_ctrl_c_interrupts_a_build(python_handles_ctrl_c):
    m = uv_sphere()
    m.build(3)  # warm up (thread pool, first allocations)
    timer = threading.Timer(0.2, _thread.interrupt_main)
    start = time.perf_counter()
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        # Depth 9 on one thread took 4.5 s on the loaded 2-core machine, depth 10 costs about
        # four times that; Ctrl-C stops it between phases and chunks of corners or leaves (the
        # subdivision phase, 1.2 s of the depth-9 build, has no check and runs to its end).
        m.build(10, threads=1)
    elapsed = time.perf_counter() - start
    timer.join()
    assert elapsed < 15.0, elapsed
    assert m.build(4).stats["depth"] == 4
