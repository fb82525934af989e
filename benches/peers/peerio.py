"""Files the peer scripts (nglod/, openvdb/) write and read, in one place.

Each peer script puts this folder on `sys.path` and imports from here, so that every output is
written the same way: atomically (a temporary in the destination's folder, renamed over it),
world-readable like any file a user writes (mkstemp's 0600 would make committed data private).
"""

from __future__ import annotations

import json
import os
import tempfile


def atomic_write(path: str, data: bytes | str) -> None:
    """Writes `data` (str as UTF-8) to `path` atomically, creating its folder."""
    if isinstance(data, str):
        data = data.encode()
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=d, prefix=".tmp-")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def pyplot():
    """matplotlib.pyplot on the file-only Agg backend (no display needed), imported on first use
    so that scripts that draw nothing do not need matplotlib."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: str, dpi: int) -> None:
    """Saves `fig` as a PNG at `path` atomically (see `atomic_write`) and closes it."""
    import io

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    pyplot().close(fig)
    atomic_write(path, buf.getvalue())


def load(path: str):
    """A JSON file."""
    with open(path) as f:
        return json.load(f)


def stem_of(path: str) -> str:
    """A mesh file's name without its extension, made safe as a file and table name."""
    s = os.path.splitext(os.path.basename(path))[0]
    return "".join(c if c.isalnum() or c in "_.-" else "_" for c in s)
