"""Collision detection, compiled.

The refine step: the exact minimum of a posed tool part's signed distance over candidate
triangles (:func:`blisk_cam.core.collision.tri_tree._refine`), each pose's pairs together,
the poses in parallel (rayon, the GIL released). The part's distance is the numpy one
operation for operation; the edges' golden-section searches stop within 1e-9 mm of their
minimum, and a pair skipped by its pose's bound returns a value above the pose's minimum, as
in numpy: the poses' minima agree within 1e-9 mm.

The whole detection (:func:`detect`): the walk of every part over every obstacle group's
triangle tree (``_TriTree.candidates``, the same bounds and beams, level by level over a
chunk of poses as numpy steps it), then the ranking and refine of ``CollisionScene._chunk``,
the chunks (numpy's) in parallel: the same collision status per pose, clearances within
1e-9 mm."""

from __future__ import annotations

import numpy as np

from .backend import extension

__all__ = ["available", "build_tree", "build_tree_available", "collision_tree", "detect",
           "detect_available", "refine_pairs", "tree_arrays", "tree_normals"]


def available() -> bool:
    """Whether the compiled refine runs."""
    ext = extension()
    return ext is not None and hasattr(ext, "refine_pairs")


def refine_pairs(part, A, B, C, nrm, ok, tip, axis, pose, ub, threads: int):
    """(best (k,) mm, where (k, 3) mm, ub (m,) lowered): ``part`` the part's floats (see
    ``tri_tree._part_spec``), triangles A, B, C and unit normals ``nrm`` (k, 3), ``ok`` (k,)
    bool (a usable normal), the poses ``tip``, ``axis`` (k, 3) of the pairs, ``pose`` (k,)
    their pose ids into ``ub`` (m,), the poses' upper bounds."""
    c = np.ascontiguousarray
    return extension().refine_pairs(
        [float(x) for x in part], *(c(x, dtype=np.float64) for x in (A, B, C, nrm)),
        c(ok, dtype=np.bool_), c(tip, dtype=np.float64), c(axis, dtype=np.float64),
        c(pose, dtype=np.int64), c(ub, dtype=np.float64), max(1, int(threads)))


def detect_available() -> bool:
    """Whether the compiled detection (tree walk and refine in one call) runs."""
    ext = extension()
    return ext is not None and hasattr(ext, "collision_detect")


def build_tree_available() -> bool:
    """Whether the compiled triangle-tree build (:func:`build_tree`) runs."""
    ext = extension()
    return ext is not None and hasattr(ext, "collision_tree_build")


def build_tree(V, F, threads: int):
    """``tri_tree._TriTree`` built compiled (the Morton sort and gathers in parallel on
    ``threads`` threads, the GIL released): V (n, 3) float mm, F (m, 3) int triangles
    (indices into V). Returns (the compiled tree — what :func:`collision_tree` makes of the
    numpy build's arrays, bit for bit —, order (m,) int64 the triangles' Morton order)."""
    c = np.ascontiguousarray
    return extension().collision_tree_build(c(V, dtype=np.float64), c(F, dtype=np.int64),
                                            max(1, int(threads)))


def tree_arrays(tree):
    """A compiled tree's arrays: ([centroids (m, 3), radii (m,), A, B, C (m, 3), unit normals
    (m, 3), ok (m,)], levels [(centre (q, 3), radius (q,), representative (q, 3), half-sizes
    (q, 3))] root first) — ``_TriTree``'s, for comparing the two builds."""
    return extension().collision_tree_arrays(tree)


def tree_normals(tree, T):
    """The unit normals (k, 3) of a compiled tree's triangles T (k,) (Morton order)."""
    return extension().collision_tree_normals(tree, np.ascontiguousarray(T, dtype=np.int64))


def collision_tree(levels, cen, rad, A, B, C, nrm, ok):
    """The compiled copy of a triangle tree's arrays (``tri_tree._TriTree``): ``levels``
    [(centre (q, 3), radius (q,), representative (q, 3), half-sizes (q, 3))] root first,
    the triangles' centroids, radii, corners, unit normals and usable-normal flags."""
    c = np.ascontiguousarray
    f8 = np.float64
    lv = [(c(x, dtype=f8), c(r, dtype=f8), c(p, dtype=f8), c(h, dtype=f8))
          for x, r, p, h in levels]
    return extension().CollisionTree(lv, c(cen, dtype=f8), c(rad, dtype=f8), c(A, dtype=f8),
                                     c(B, dtype=f8), c(C, dtype=f8), c(nrm, dtype=f8),
                                     c(ok, dtype=np.bool_))


def detect(trees, parts, plan, queries, m: int, chunk: int, cap: float, safety: float,
           threads: int):
    """``CollisionScene._chunk`` over m poses in chunks of ``chunk``, compiled (the chunks
    in parallel on ``threads`` threads, the GIL released): ``trees`` the compiled trees, one
    per obstacle group; ``parts`` [(part floats, rmax mm)]; ``plan`` per part its [(group,
    first copy)]; ``queries`` per group (tips (c·m, 3), axes (c·m, 3), c), each chunk's rows
    a copy-major block. Returns (clearance (m,) mm, ids (m, 5) int64 = group, part, query
    row, copy, triangle — −1 where nothing is within the cap —, point (m, 3) mm in the
    tree's frame)."""
    c = np.ascontiguousarray
    f8 = np.float64
    return extension().collision_detect(
        list(trees), [([float(x) for x in s], float(r)) for s, r in parts],
        [[(int(g), int(f)) for g, f in p] for p in plan],
        [(c(t, dtype=f8), c(a, dtype=f8), int(n)) for t, a, n in queries], int(m), int(chunk),
        float(cap), float(safety), max(1, int(threads)))
