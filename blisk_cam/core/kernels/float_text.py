"""Float arrays as JSON text (the paths JSON, :mod:`blisk_cam.core.toolpath.paths_io`),
compiled: the bytes ``json.dumps(a.tolist())`` writes — Python's ``repr`` of each float
(shortest round-trip digits, ties to the even digit), ", " between values, rows as nested
lists — about 3x faster than the lists and the encoder."""

from __future__ import annotations

import numpy as np

from .backend import kernel

__all__ = ["json_float_array"]


def json_float_array(a):
    """The JSON text of the float64 array ``a`` ((k,) or (k, c)), as ``json.dumps(
    a.tolist())`` writes it; None when the numpy kernels run (or a wheel without this
    kernel), or when a value is not finite or ``a`` has another number of dimensions (the
    caller's ``json.dumps`` then takes it, and refuses NaN as before)."""
    fn = kernel("json_float_array")
    if fn is None:
        return None
    return fn(np.ascontiguousarray(a, dtype=np.float64))
