"""Step 4 of the swept cutter's "fast" method, compiled: the golden-section search of each
(point, move) pair's bracket (:func:`blisk_cam.core.verify.sweep._golden_pairs`), every
point's pairs stepped together with numpy's pruning after each step, the points in parallel
(rayon, the GIL released). The cutter's distance is ``Cutter.signed_distance_rz`` operation
for operation; sin and cos are the platform's (libm), so a value may differ from numpy's in
the last bits and a bracket then close on the other side: the minima agree within the
search's tolerance (far below 1e-9 mm at a smooth minimum)."""

from __future__ import annotations

import math

import numpy as np

from .backend import extension

__all__ = ["available", "cutter_profile", "golden_pairs"]


def available() -> bool:
    """Whether the compiled search runs (the extension is installed, built with it, and not
    switched off)."""
    ext = extension()
    return ext is not None and hasattr(ext, "golden_pairs")


def golden_pairs(profile, q, u, scal, lo, hi, xtol: float, threads: int):
    """(best (kc,) mm, pair index achieving it (kc,) int64 or −1): ``profile`` the 17 floats
    (e, f, r, h, B, S, T, sin/cos of the arc's sector bounds, tan α, cos β, sin β); ``q``
    (m,) the point of each pair, sorted; ``u`` (kc,) the points' bests so far; ``scal`` the
    nine (m,) columns (za, zb, Ta, Tb, n0, m2, L2, φ, D); ``lo``, ``hi`` (m,) the brackets;
    ``xtol`` mm."""
    c = np.ascontiguousarray
    return extension().golden_pairs(
        [float(x) for x in profile], c(q, dtype=np.int64), c(u, dtype=np.float64),
        [c(x, dtype=np.float64) for x in scal], c(lo, dtype=np.float64),
        c(hi, dtype=np.float64), float(xtol), max(1, int(threads)))


def cutter_profile(cutter):
    """The 17 constants of ``cutter.signed_distance_rz`` (a ``tool.cutter.Cutter``) for the
    compiled kernels, the very floats it computes them from."""
    g = cutter._g
    B, S, T = g["B"], g["S"], g["T"]
    return (cutter.e, cutter.f, cutter.r, cutter.h, *B, *S, *T, math.sin(g["th_lo"]),
            math.cos(g["th_lo"]), math.sin(g["th_hi"]), math.cos(g["th_hi"]),
            math.tan(cutter.alpha), math.cos(cutter.beta), math.sin(cutter.beta))
