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

__all__ = ["available", "boxes_available", "cutter_profile", "fast_search", "fast_search_boxes",
           "golden_pairs", "leaf_boxes", "search_available"]


def available() -> bool:
    """Whether the compiled search runs (the extension is installed, built with it, and not
    switched off)."""
    ext = extension()
    return ext is not None and hasattr(ext, "golden_pairs")


def _search_revision(ext) -> int:
    """The calling convention of the installed ``fast_search`` and ``fast_search_boxes``
    (2: the tables as one tuple, :func:`_tables`; an extension built before reads 1 and
    the numpy steps run)."""
    return getattr(ext, "SWEPT_SEARCH_REVISION", 1)


def search_available() -> bool:
    """Whether the compiled steps 1–4 run (see :func:`fast_search`)."""
    ext = extension()
    return ext is not None and hasattr(ext, "fast_search") and _search_revision(ext) >= 2


def _tables(tab):
    """The segment and leaf tables of ``tab`` (a SweptCutter or a SweptForest) as the
    compiled search takes them, one tuple: lt, la (NC · (B + 1), 3) mm, ls (NC, B) int64,
    lphi, ldt (NC, B), ta, tb, k, b (ns, 3), chord_ok (ns,) bool; C-contiguous."""
    c = np.ascontiguousarray
    f8 = np.float64
    B = tab._ls.shape[1]
    return (c(tab._lt, dtype=f8).reshape(-1, 3), c(tab._la, dtype=f8).reshape(-1, 3),
            c(tab._ls, dtype=np.int64).reshape(-1, B), c(tab._lphi, dtype=f8).reshape(-1, B),
            c(tab._ldt, dtype=f8).reshape(-1, B), c(tab.ta, dtype=f8), c(tab.tb, dtype=f8),
            c(tab._k, dtype=f8), c(tab._b, dtype=f8), c(tab._chord_ok, dtype=np.bool_))


def fast_search(cutter, tab, Pc, u, arg, q, leaf, slack, xtol: float, delta: float,
                threads: int):
    """Steps 1–4 of the swept cutter's fast method (``verify.sweep._fast_search``), compiled:
    per point its candidate leaves' chord and motion bounds, the exact pose values, the
    convexity brackets and the golden-section search, the points in parallel (the GIL
    released); the arithmetic of the numpy steps operation for operation. ``tab`` holds the
    segment and leaf tables (a SweptCutter or a SweptForest); ``q`` (n,) sorted. Returns
    (u (k,) mm, arg (k,) int64)."""
    c = np.ascontiguousarray
    f8 = np.float64
    return extension().fast_search(
        [float(x) for x in cutter_profile(cutter)], c(Pc, dtype=f8), c(u, dtype=f8),
        c(arg, dtype=np.int64), c(q, dtype=np.int64), c(leaf, dtype=np.int64),
        c(slack, dtype=f8), _tables(tab), float(xtol), float(delta), max(1, int(threads)))


def boxes_available() -> bool:
    """Whether the compiled candidate search runs (see :func:`fast_search_boxes`; an
    extension built before :func:`leaf_boxes` took member starts and pieces does not)."""
    ext = extension()
    return (ext is not None and hasattr(ext, "fast_search_boxes")
            and getattr(ext, "LEAF_BOXES_REVISION", 1) >= 2 and _search_revision(ext) >= 2)


def leaf_boxes(lo, hi, starts=None, pieces: int = 1):
    """The compiled trees of the leaves' boxes ``lo``, ``hi`` (NC · pieces, 3) mm (``pieces``
    boxes per leaf, in a row, together bounding the volume the cutter sweeps along the
    leaf's moves); ``starts`` (M,), optional: the first leaf of each member of a forest,
    ascending from 0 (a tree per member: a point's query walks its member's leaves only; the
    same leaves are found)."""
    c = np.ascontiguousarray
    lo, hi = c(lo, dtype=np.float64), c(hi, dtype=np.float64)
    if starts is None and pieces == 1:
        return extension().LeafBoxes(lo, hi)
    if starts is None:
        starts = np.zeros(1, np.int64)
    return extension().LeafBoxes(lo, hi, c(starts, dtype=np.int64), int(pieces))


def fast_search_boxes(cutter, tab, boxes, Pc, u, arg, slack, cl_lo, cl_hi, xtol: float,
                      delta: float, threads: int):
    """:func:`fast_search` with each point's candidate leaves found by the compiled tree
    ``boxes`` (:func:`leaf_boxes`) among the leaves ``cl_lo .. cl_hi`` (k,) of its member:
    every leaf whose box comes within the point's bound ``u``. A superset of the leaves the
    numpy trees list; a leaf beyond the bound holds no move within it, so the result is the
    same. Returns (u (k,) mm, arg (k,) int64)."""
    c = np.ascontiguousarray
    f8, i8 = np.float64, np.int64
    return extension().fast_search_boxes(
        [float(x) for x in cutter_profile(cutter)], c(Pc, dtype=f8), c(u, dtype=f8),
        c(arg, dtype=i8), c(slack, dtype=f8), boxes, c(cl_lo, dtype=i8), c(cl_hi, dtype=i8),
        _tables(tab), float(xtol), float(delta), max(1, int(threads)))


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


def pose_bound_available() -> bool:
    """Whether the compiled :func:`pose_bound` runs."""
    ext = extension()
    return ext is not None and hasattr(ext, "pose_bound")


def pose_bound(cutter, Pc, seg, ta, aa, threads: int):
    """``SweptCutter._upper_bound``'s last step compiled: each point of ``Pc`` (k, 3) against
    the cutter posed at the tip ``ta`` and axis ``aa`` of each of its segments ``seg`` (k, kk)
    (numpy's indexing), ``Cutter.signed_distance``'s floats; the minimum per point and the
    last listed segment reaching it, as ``bvh.group_argmin``. Returns (u (k,) mm, arg (k,)
    int64)."""
    c = np.ascontiguousarray
    return extension().pose_bound(
        [float(x) for x in cutter_profile(cutter)], c(Pc, dtype=np.float64),
        c(seg, dtype=np.int64), c(ta, dtype=np.float64), c(aa, dtype=np.float64),
        max(1, int(threads)))
