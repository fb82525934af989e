"""Issue 32: every failure of the package is a Python exception (MemoryError, ValueError,
OSError, KeyboardInterrupt), never an abort or a panic; thread counts are bounded and pools
are not leaked. The cases that need a memory limit or a signal run in a child interpreter, so
that an abort (the old behaviour) fails the test instead of killing pytest."""

import os
import struct
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import sdfmo

V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
MESH = sdfmo.Mesh(V, F)
P = np.array([[0.1, 0.2, 0.3], [2.0, 0.5, -1.0], [0.25, 0.25, 0.25]])

# Runs first in every child: the package imported, its thread pools started (under an
# address-space limit a pool that starts later may not get its stacks), and `limit(extra)`
# to cap the address space at what the process maps now plus `extra` bytes.
PRELUDE = textwrap.dedent(
    """
    import os, resource, sys, time
    import numpy as np
    import sdfmo
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    MESH = sdfmo.Mesh(V, F)
    sdfmo.sample_sdf(MESH, 20000)
    MESH.signed_distance(np.zeros((20000, 3)))

    def limit(extra):
        with open("/proc/self/status") as f:
            vm = next(int(l.split()[1]) * 1024 for l in f if l.startswith("VmSize:"))
        resource.setrlimit(resource.RLIMIT_AS, (vm + extra, resource.RLIM_INFINITY))

    def expect(exc, call):
        try:
            call()
        except exc as e:
            print("raised", type(e).__name__, e)
            sys.stdout.flush()
            return
        print("no exception")
        sys.exit(3)
    """
)


def run_child(body, timeout=120):
    """Runs PRELUDE + body in a fresh interpreter; returns (returncode, stdout + stderr)."""
    r = subprocess.run(
        [sys.executable, "-c", PRELUDE + textwrap.dedent(body)],
        capture_output=True,
        text=True,
        timeout=timeout,
    )
    return r.returncode, r.stdout + r.stderr


def expect_raised(body, exc_name, text=""):
    code, out = run_child(body)
    # A negative code is a signal: SIGABRT (-6) was the old answer to a failed allocation.
    assert code == 0, f"exit {code}:\n{out}"
    assert f"raised {exc_name}" in out, out
    assert text in out, out


needs_linux = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="RLIMIT_AS and /proc are Linux's"
)


@needs_linux
def test_sample_sdf_under_an_address_space_limit_raises_memory_error():
    # 50 M points: numpy's arrays (800 MB) fit under the limit, the sampler's own 600 MB do
    # not. Before issue 32 the sampler's `vec!` aborted the interpreter (SIGABRT).
    expect_raised(
        """
        limit(1000 << 20)
        expect(MemoryError, lambda: sdfmo.sample_sdf(MESH, 50_000_000))
        # The interpreter is still usable.
        assert sdfmo.sample_sdf(MESH, 1000)[0].shape == (1000, 3)
        """,
        "MemoryError",
        "sample points",
    )


@needs_linux
def test_mesh_from_arrays_under_an_address_space_limit_raises_memory_error():
    expect_raised(
        """
        v = np.random.default_rng(1).random((20_000_000, 3), dtype=np.float32)
        f = np.zeros((1, 3), np.int64)
        f[0] = (0, 1, 2)
        limit(100 << 20)
        expect(MemoryError, lambda: sdfmo.Mesh(v, f))
        """,
        "MemoryError",
        "vertices",
    )


@needs_linux
def test_octree_file_under_an_address_space_limit_raises_memory_error(tmp_path):
    # A 1 GiB sparse file whose header declares 1 GiB: reading it needs 1 GiB, refused by the
    # limit as a MemoryError (the read used to abort).
    path = tmp_path / "big.smo"
    good = MESH.build(3).to_bytes()
    head = bytearray(good[:128])
    head[56:64] = struct.pack("<Q", 1 << 30)
    with open(path, "wb") as f:
        f.write(head)
        f.truncate(1 << 30)
    expect_raised(
        f"""
        limit(256 << 20)
        expect(MemoryError, lambda: sdfmo.Octree.load({str(path)!r}))
        """,
        "MemoryError",
        "allocate",
    )


@needs_linux
def test_mesh_file_under_an_address_space_limit_raises_memory_error(tmp_path):
    # A real binary STL of 2 M triangles (100 MB): loading it needs several times the file.
    path = tmp_path / "big.stl"
    n = 2_000_000
    rec = np.zeros(n, dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rng = np.random.default_rng(2)
    rec["v"] = rng.random((n, 3, 3), dtype=np.float32)
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", n))
        f.write(rec.tobytes())
    expect_raised(
        f"""
        limit(150 << 20)
        expect(MemoryError, lambda: sdfmo.Mesh.load({str(path)!r}))
        """,
        "MemoryError",
    )


@needs_linux
def test_render_and_build_under_an_address_space_limit_raise_memory_error():
    # A 16384^2 image needs 805 MB of RGB alone; a depth-12 build of the tetrahedron some
    # hundreds of MB. Both allocate inside the library (infallibly): the package asks for the
    # address space first.
    expect_raised(
        """
        limit(300 << 20)
        expect(MemoryError, lambda: MESH.render(16384))
        expect(MemoryError, lambda: MESH.build(12))
        print(MESH.render(64).shape)
        """,
        "MemoryError",
        "(64, 64, 3)",
    )


def test_sample_sdf_of_10_12_points_is_refused_before_allocating():
    # Before issue 32: a PanicException from rust-numpy's allocation.
    with pytest.raises(MemoryError, match="needs 28000000000000 bytes"):
        sdfmo.sample_sdf(MESH, 10**12)


@pytest.mark.parametrize(
    "kwargs,text",
    [
        (dict(sigmas=(1e39, 0.01)), "finite in float32"),
        (dict(sigmas=(0.01, 1e38)), "overflow float32"),
        (dict(padding=1e39), "finite in float32"),
        (dict(padding=1e20), "overflow float32"),
    ],
)
def test_overflowing_sigmas_are_a_value_error(kwargs, text):
    # Before issue 32 sigmas=(1e39, ...) passed the float64 check and hit the sampler's
    # assertion on its float32 value (a PanicException); sigmas or a padding that put points
    # beyond float32's range gave infinite points.
    wide = sdfmo.Mesh(V * 10, F)
    with pytest.raises(ValueError, match=text):
        sdfmo.sample_sdf(wide, 100, **kwargs)
    # Large but within range is fine.
    p, d = sdfmo.sample_sdf(wide, 100, sigmas=(1e6, 1e6), padding=1e6)
    assert np.isfinite(p).all() and np.isfinite(d).all()


def test_points_too_far_for_float32_are_a_value_error():
    # Before issue 32: inf distances and NaN winding numbers for points beyond about 1e19
    # (the CLI's `distance` refused them already).
    far = np.array([[0.1, 0.1, 0.1], [1e20, 0, 0]])
    for call in (MESH.signed_distance, MESH.unsigned_distance, MESH.winding_number, MESH.contains):
        with pytest.raises(ValueError, match=r"points\[1\] = .* is too far from the mesh"):
            call(far)
    with pytest.raises(ValueError, match=r"origins\[1\]"):
        MESH.ray_intersect(far, np.ones((2, 3)))
    assert np.isfinite(MESH.signed_distance([[1e17, 0, 0]])).all()


def test_big_endian_arrays_are_read_as_their_values():
    # Before issue 32: "TypeError: argument 'points': ... cannot be converted".
    d = MESH.signed_distance(P)
    for dtype in (">f8", ">f4"):
        assert np.array_equal(MESH.signed_distance(P.astype(dtype)), MESH.signed_distance(P.astype(dtype[1:])))
    assert np.allclose(MESH.signed_distance(P.astype(">f8")), d)
    m = sdfmo.Mesh(V.astype(">f4"), F.astype(">i8"))
    assert np.array_equal(m.signed_distance(P), d)
    m = sdfmo.Mesh(V.astype(">f8"), F.astype(">u4"))
    assert np.array_equal(m.signed_distance(P), d)
    t, face = MESH.ray_intersect(P.astype(">f8"), np.ones((3, 3), ">f4"))
    assert np.array_equal(face, MESH.ray_intersect(P, np.ones((3, 3)))[1])


def test_an_unsigned_face_index_is_reported_as_its_value():
    # Before issue 32 every index went through int64: 2^64 - 1 was reported as -1.
    f = F.astype(np.uint64)
    f[2, 1] = 2**64 - 1
    with pytest.raises(ValueError, match=r"faces\[2, 1\] = 18446744073709551615 is out of range"):
        sdfmo.Mesh(V, f)
    f[2, 1] = 4
    with pytest.raises(ValueError, match=r"faces\[2, 1\] = 4 is out of range"):
        sdfmo.Mesh(V, f)


def test_a_mesh_wider_than_float32_is_a_value_error(tmp_path):
    # Before issue 32 the extent overflowed, the normalisation fell back to scale 1 and the
    # distances were wrong (no error).
    far = np.array([[-3e38, 0, 0], [3e38, 0, 0], [0, 3e38, 0], [0, 0, 3e38]], np.float32)
    with pytest.raises(ValueError, match="wider than f32"):
        sdfmo.Mesh(far, F)
    path = tmp_path / "far.stl"
    with open(path, "wb") as f:
        f.write(b"\0" * 80 + struct.pack("<I", 1))
        f.write(struct.pack("<12fH", 0, 0, 0, -3e38, 0, 0, 3e38, 0, 0, 0, 3e38, 0, 0))
    with pytest.raises(sdfmo.MeshError, match="wider than f32"):
        sdfmo.Mesh.load(path)


def thread_count():
    return len(os.listdir("/proc/self/task"))


@needs_linux
def test_thread_counts_are_bounded_and_pools_not_kept():
    # Before issue 32: threads=10**6 started a million threads (a minute), and one pool per
    # distinct count was kept forever (822 threads alive after calls with 1..40).
    cores = len(os.sched_getaffinity(0))
    d = MESH.signed_distance(P)
    assert np.array_equal(MESH.signed_distance(P, threads=10**6), d)
    for n in range(1, 41):
        assert np.array_equal(MESH.signed_distance(P, threads=n), d)
        MESH.render(8, threads=n)
    # The calling thread, rayon's global pool (one per core) and at most two cached pools
    # (each at most one thread per core), with room for pytest's and numpy's own threads.
    assert thread_count() <= 1 + 3 * cores + 8, (thread_count(), cores)


def expect_ctrl_c_stops(call, after, within, setup=""):
    """`call` (an expression) in a child that sends itself SIGINT `after` s in (after `setup`)
    raises KeyboardInterrupt within `within` s of its start."""
    expect_raised(
        f"""
        import signal, threading
        # Python turns SIGINT into KeyboardInterrupt only if it was not ignored at start-up,
        # and a job started in the background by a shell without job control (`cmd &`, as a
        # CI runner may) inherits SIGINT ignored: install the handler explicitly.
        signal.signal(signal.SIGINT, signal.default_int_handler)
        {setup}
        threading.Timer({after}, os.kill, (os.getpid(), signal.SIGINT)).start()
        t = time.monotonic()
        expect(KeyboardInterrupt, lambda: {call})
        took = time.monotonic() - t
        print(f"interrupted after {{took:.2f}} s")
        assert took < {within}, took
        """,
        "KeyboardInterrupt",
    )


@needs_linux
def test_ctrl_c_stops_a_long_octree_render():
    # Before issue 32 `render` ran to its end (minutes for this one) and only then raised.
    expect_ctrl_c_stops("octree.render(4096, ao=64)", 0.5, 5, setup="octree = MESH.build(6)")


@needs_linux
def test_ctrl_c_stops_a_long_mesh_render():
    expect_ctrl_c_stops("MESH.render(4096, ao=64)", 0.5, 5)


@needs_linux
def test_ctrl_c_stops_sample_sdf_while_it_draws():
    # Before issue 32 the drawing of the points ran to its end first: 30 M points were
    # interrupted 3.0 s after the start (signal at 0.3 s) on the 2-core machine, 10 M in 1.1 s.
    expect_ctrl_c_stops("sdfmo.sample_sdf(MESH, 30_000_000)", 0.3, 1.5)
