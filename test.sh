#!/usr/bin/env bash
# The tests, as the README gives them: the Rust workspace, then the Python package (a venv in
# target/py-venv with maturin, numpy, pytest and mypy, whose stubtest checks the stubs; the
# wheel built from crates/sdfmo-py in the dev profile, which shares target/debug with the Rust
# tests; pytest against the installed wheel and the CLI binary the Rust tests built). Arguments go to `cargo test`.
# PYTHON picks the interpreter (default python3, >= 3.9).
set -euo pipefail
cd "$(dirname "$0")"

cargo test --workspace "$@"

PYTHON="${PYTHON:-python3}"
VENV=target/py-venv
if [ ! -x "$VENV/bin/python" ]; then
    if ! "$PYTHON" -m venv "$VENV" 2> /dev/null; then
        # Debian and Ubuntu ship venv apart from Python.
        if [ "$(id -u)" = 0 ] && command -v apt-get > /dev/null; then
            rm -rf "$VENV"
            DEBIAN_FRONTEND=noninteractive apt-get update -qq
            DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends python3-venv
            "$PYTHON" -m venv "$VENV"
        else
            echo "test.sh: '$PYTHON -m venv' failed: install Python's venv module (Debian: python3-venv)" >&2
            exit 1
        fi
    fi
fi
if ! "$VENV/bin/python" -c 'import maturin, numpy, pytest, mypy' 2> /dev/null; then
    "$VENV/bin/python" -m pip install -q --disable-pip-version-check 'maturin>=1.9.4,<2' numpy pytest 'mypy>=1.11'
fi
rm -rf target/py-wheels
"$VENV/bin/maturin" build --quiet --profile dev -m crates/sdfmo-py/Cargo.toml -o target/py-wheels
"$VENV/bin/python" -m pip install -q --disable-pip-version-check --force-reinstall --no-deps target/py-wheels/sdf_multioctree-*.whl
SDFMO_CLI="$PWD/target/debug/sdfmo" "$VENV/bin/python" -m pytest -q -p no:cacheprovider crates/sdfmo-py/tests
