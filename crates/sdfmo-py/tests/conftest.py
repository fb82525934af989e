"""Shared fixtures: the test data directory (``SDFMO_TEST_DATA``, default ``../shared/data``
relative to the workspace root, as the Rust tests resolve it) and the CLI binary."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

WORKSPACE = Path(__file__).resolve().parents[3]
REQUIRE = os.environ.get("SDFMO_REQUIRE_TEST_DATA") == "1"


def _data_dir():
    value = os.environ.get("SDFMO_TEST_DATA", "../shared/data")
    p = Path(value)
    return p if p.is_absolute() else (WORKSPACE / p).resolve()


DATA = _data_dir()
SHARED_MESHES = ["abc1.stl", "abc3.stl", "abc5.stl", "abc8.stl", "stanford-bunny.obj", "teapot.obj"]


def missing(what):
    """Skip, or fail under SDFMO_REQUIRE_TEST_DATA=1 (CI)."""
    if REQUIRE:
        pytest.fail(f"{what} (SDFMO_REQUIRE_TEST_DATA=1)")
    pytest.skip(what)


@pytest.fixture(scope="session")
def data_dir():
    if not (DATA / "abc5.stl").is_file():
        missing(f"no test data in {DATA}: set SDFMO_TEST_DATA")
    return DATA


@pytest.fixture(scope="session")
def cli():
    """The `sdfmo` binary: $SDFMO_CLI, else target/{debug,release}/sdfmo of this workspace."""
    value = os.environ.get("SDFMO_CLI")
    candidates = [Path(value)] if value else [
        WORKSPACE / "target" / "debug" / "sdfmo",
        WORKSPACE / "target" / "release" / "sdfmo",
    ]
    for c in candidates:
        if c.is_file() and os.access(c, os.X_OK):
            return c
    found = shutil.which("sdfmo")
    if found and not value:
        return Path(found)
    missing(f"no sdfmo binary ({', '.join(map(str, candidates))}): set SDFMO_CLI")


def run_cli(cli, *args):
    """Runs the `sdfmo` binary with `args` (paths allowed) and asserts it succeeded; the
    completed process (its stdout holds `--json` output)."""
    r = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r
