"""The greedy forward step of :func:`blisk_cam.core.paths.sampling.forward_step_indices`,
compiled (same arithmetic, operation for operation: the kept points are the numpy
reference's to the last bit)."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["forward_step"]


def forward_step(P, C, tol_p: float, tol_c: float, old_trace=None, unchanged_to=None):
    """Kept indices of the greedy forward step over the CC points ``P`` (k, 3) and the centres
    ``C`` (k, 3), mm, tolerances ``tol_p`` and ``tol_c`` mm; None when the numpy kernels run.

    ``old_trace`` (k, 3) int64 and ``unchanged_to`` (k + 1,) int64 (changed points before
    each index): the searches of the last call on the same polyline, reused where their
    points did not change. Returns (keep (q,) int64, trace (k, 3) int64: first step,
    outcome and farthest end tested of each search start, −1 elsewhere).
    """
    ext = extension()
    if ext is None:
        return None
    P = np.ascontiguousarray(P, dtype=np.float64)
    C = np.ascontiguousarray(C, dtype=np.float64)
    if old_trace is not None:
        old_trace = np.ascontiguousarray(old_trace, dtype=np.int64)
        unchanged_to = np.ascontiguousarray(unchanged_to, dtype=np.int64)
    return ext.forward_step(P, C, float(tol_p), float(tol_c), old_trace, unchanged_to)
