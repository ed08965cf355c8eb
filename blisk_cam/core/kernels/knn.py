"""The k nearest points within a bound, compiled (a k-d tree of our own: parry has no
k-nearest query on points). Rows whose k-th and (k + 1)-th nearest are at the same distance
are flagged: scipy's ``cKDTree`` chooses among them by its traversal, so the caller asks it
for those rows; every other row holds scipy's set of k."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["available", "point_tree", "nearest_k", "points_within"]


def available() -> bool:
    """Whether the compiled k-d tree runs (the extension is installed and not switched
    off)."""
    ext = extension()
    return ext is not None and hasattr(ext, "PointTree")


def point_tree(points, threads: int = 1):
    """The compiled k-d tree of ``points`` (n, 3) mm, built on ``threads`` threads; None when
    the numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    return ext.PointTree(np.ascontiguousarray(points, dtype=np.float64), max(1, int(threads)))


def nearest_k(tree, queries, k: int, bound: float, threads: int, ties=None,
              in_order: bool = False):
    """(q, k) int64: the k nearest points of each query (q, 3) closer than ``bound`` mm
    (squared distances below ``bound²``, summed as scipy sums them), −1 where fewer, by
    (distance, id), on ``threads`` threads with the GIL released. ``ties``: a function
    answering the rows (r, 3) whose k-th and (k + 1)-th nearest are at the same distance
    (the caller's scipy query: it makes the choice among them), (r, k) int64.
    ``in_order``: the queries come in path order, each near the one before (the tree then
    walks them in packets of consecutive ones where the installed kernels can: the same
    answers, found sooner)."""
    Q = np.ascontiguousarray(queries, dtype=np.float64)
    if in_order and getattr(tree, "PACKETS", False):
        ids, tie = tree.query(Q, int(k), float(bound), max(1, int(threads)), packets=True)
    else:
        ids, tie = tree.query(Q, int(k), float(bound), max(1, int(threads)))
    if ties is not None and np.any(tie):
        ids[tie] = ties(Q[tie])
    return ids


def points_within(tree, queries, bound: float, threads: int):
    """(q,) bool: a point of ``tree`` lies closer than ``bound`` mm to each query (q, 3)
    (squared distance below ``bound²``, summed as scipy sums it: scipy's
    ``isfinite(query(k=1, distance_upper_bound=bound)[0])``), on ``threads`` threads with
    the GIL released; None when the numpy kernels run."""
    ext = extension()
    if ext is None:
        return None
    Q = np.ascontiguousarray(queries, dtype=np.float64)
    return ext.points_within(tree, Q, float(bound), max(1, int(threads)))
