"""Which kernels run: the compiled extension ``blisk_cam_kernels`` when it is installed (the
only module importing it), else the numpy reference with one warning line on stderr.

``BLISK_CAM_KERNELS=numpy`` in the environment forces the numpy kernels (no warning: the
user chose them); :func:`numpy_only` does the same inside a block (tests comparing the two
backends on the same inputs).
"""

from __future__ import annotations

import contextlib
import os
import sys

try:
    import blisk_cam_kernels as _ext  # optional: the compiled kernels (kernels/ at the root)
except ImportError as _exc:
    _ext, _why = None, str(_exc)
else:
    _why = ""

__all__ = ["backend_name", "extension", "kernel", "numpy_only", "ENV"]

#: the environment variable that picks the backend (``numpy`` forces it; anything else or
#: unset: the compiled kernels when installed)
ENV = "BLISK_CAM_KERNELS"

_loaded = None  # (module or None, why not) once resolved
_forced_numpy = 0  # depth of numpy_only blocks


def _load():
    global _loaded
    if _loaded is None:
        if os.environ.get(ENV, "").strip().lower() == "numpy":
            _loaded = (None, f"{ENV}=numpy")
        elif _ext is None:
            _loaded = (None, _why)
            print(f"blisk_cam: compiled kernels not available ({_why}); running the numpy "
                  "kernels (same results, slower)", file=sys.stderr)
        else:
            _loaded = (_ext, "")
    return _loaded


def extension():
    """The compiled module, or None when the numpy kernels run."""
    if _forced_numpy:
        return None
    return _load()[0]


def kernel(name: str):
    """The compiled function ``name``, or None when the numpy kernels run or the installed
    extension is older than it (the wrappers then fall back to their numpy reference)."""
    ext = extension()
    return getattr(ext, name, None) if ext is not None else None


def backend_name() -> str:
    """``"compiled 0.1.0"`` (the extension's ``VERSION``) or ``"numpy"``."""
    ext = extension()
    return "numpy" if ext is None else f"compiled {ext.VERSION}"


@contextlib.contextmanager
def numpy_only():
    """Within the block (in every thread), the numpy kernels run whatever is installed."""
    global _forced_numpy
    _forced_numpy += 1
    try:
        yield
    finally:
        _forced_numpy -= 1


def pool_identity(threads: int) -> int | None:
    """An opaque number naming the worker pool a compiled kernel called from this thread with
    ``threads`` workers runs on (equal numbers: the same pool), or None on the numpy
    backend. Python threads that ask for one worker each (:func:`..runtime.map_chunks`'s
    chunks) get pools of their own, so their kernels run side by side."""
    ext = extension()
    return None if ext is None or not hasattr(ext, "pool_identity") else int(
        ext.pool_identity(int(threads)))
