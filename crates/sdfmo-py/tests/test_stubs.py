"""The type stubs (python/sdfmo/_sdfmo.pyi) against the compiled module, with mypy's stubtest:
every name of either exists in the other, and every function's and method's parameters (names,
kinds, defaults) match ``inspect.signature`` of the module's, which PyO3 derives from the
``#[pyo3(signature = ...)]`` declarations. mypy comes with the test extra (``pip install
.[test]``; ./test.sh installs it)."""

import subprocess
import sys


def test_stubs_match_the_compiled_module():
    # PEP 800's @disjoint_base is left out of the stubs: it is new (typing_extensions 4.15),
    # older type checkers reject it, and @final already says the classes take no subclasses.
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "sdfmo._sdfmo", "--ignore-disjoint-bases"],
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stdout + r.stderr
