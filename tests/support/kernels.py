"""The guard of the tests that compare the compiled kernels with the numpy reference: they
skip, saying why, when the compiled extension cannot run them (not built, switched off with
``BLISK_CAM_KERNELS=numpy``, or built before the kernel they test)."""

from __future__ import annotations

import pytest

from blisk_cam.core.kernels import backend

__all__ = ["needs_compiled"]


def needs_compiled(*kernels: str, why: str = "only the numpy backend can run"):
    """A ``skipif`` mark for a test of the compiled kernels ``kernels`` (the names the
    extension exports; none: any build of it): skipped when the extension is not installed
    or lacks one of them. ``why`` ends the reason (what the skip means for the test)."""
    ext = backend.extension()
    missing = [k for k in kernels if ext is not None and not hasattr(ext, k)]
    if ext is None:
        reason = ("the compiled kernels are not built/installed (make kernels) or "
                  f"BLISK_CAM_KERNELS=numpy: {why}")
    else:
        reason = (f"the installed compiled kernels were built before {', '.join(missing)} "
                  f"(make kernels): {why}")
    return pytest.mark.skipif(ext is None or bool(missing), reason=reason)
