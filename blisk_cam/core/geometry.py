"""Geometry kernels shared by the generator and the checker: exact closest points on segments
and triangles, a bounding-volume tree over primitives (boxes + oriented cylinders) with exact
nearest / within-radius queries, and reusable closest-point queries on a :class:`TriMesh`.

* **point → mesh** — exact closest points on the triangles (every candidate triangle is
  tested with an exact point–triangle routine; candidates come from a bounding-volume tree
  whose node bounds are both an axis-aligned box and an oriented cylinder, so pruning is
  exact). The side is decided with the angle-weighted pseudo-normal of the closest feature
  (face, edge or vertex; Bærentzen & Aanæs 2005), which is the correct inside/outside test
  on a closed mesh (on an open one, beyond a boundary it is the side of the nearest face).

Split out of :mod:`.verify` so that the path generator (:mod:`.linking`) never imports the
checker: both use these kernels. Units are mm; numpy/scipy only (no bpy).
"""

from __future__ import annotations

import contextlib
import contextvars
import itertools
import os
import threading
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .mesh import TriMesh

__all__ = [
    "Cancelled",
    "ClosestPoints",
    "MeshDistance",
    "NearestFaces",
    "closest_points",
    "closest_on_segments",
    "closest_on_triangles",
    "cancellable",
    "check_cancel",
    "alongside",
    "map_chunks",
    "map_tasks",
    "parallel",
]

_CHUNK = 2048  # queries per chunk in tree traversals (the frontier stays in cache: 16384
#                 ran 1.5–2× slower on Rotor 37's verify, bench/bench_verify.py)

_FLAT_PAIRS = 8192  # (query, leaf) pairs below which a tree query tests all leaves at once

# packet traversal (:meth:`_Tree.leaf_pairs`): queries per group, levels walked per query at
# the bottom of the tree, fewest queries for which groups are formed
_GROUP, _GROUP_TAIL, _GROUP_MIN = 8, 0, 256

# NearestFaces: circumradius size classes (6, half an octave each)
_NF_CLASSES, _NF_PER_OCTAVE = 6, 2
# threads for chunked queries (set by :func:`parallel`); 1 = run in the calling thread
_WORKERS = contextvars.ContextVar("blisk_cam_geometry_workers", default=1)


def default_workers() -> int:
    """The cores this process may use (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def parallel(workers: int | None):
    """Within the block, chunked queries (:func:`map_chunks`: nearest primitives, pairs within
    a radius, swept-cutter distances) run on ``workers`` threads (None: every core). numpy
    and scipy's k-d tree release the GIL in their loops; each chunk is computed exactly as
    on one thread, so the results do not depend on ``workers``."""
    n = default_workers() if workers is None else max(1, int(workers))
    token = _WORKERS.set(n)
    try:
        yield n
    finally:
        _WORKERS.reset(token)


# the caller's cancel hook (set by :func:`cancellable`): (is-set callable, what is running)
_CANCEL = contextvars.ContextVar("blisk_cam_geometry_cancel", default=None)


class Cancelled(Exception):
    """A long computation stopped because its caller's cancel hook was set (ESC, a new run):
    not an input error; nothing of the computation is returned."""


@contextlib.contextmanager
def cancellable(cancel, what: str = "the computation"):
    """Within the block, :func:`check_cancel` (called by :func:`map_chunks` and
    :func:`map_tasks` before every chunk and task) raises :class:`Cancelled` once ``cancel``
    is set. ``cancel``: None (never), a ``threading.Event`` or a callable returning True to
    stop (polled from the worker threads too, so it must be thread-safe)."""
    if cancel is None:
        yield
        return
    test = getattr(cancel, "is_set", None)
    if test is None:
        if not callable(cancel):
            raise TypeError(f"cancel must be a threading.Event or a callable returning True to "
                            f"stop, got {type(cancel).__name__}")
        test = cancel
    token = _CANCEL.set((test, what))
    try:
        yield
    finally:
        _CANCEL.reset(token)


def check_cancel(hook=None):
    """Raise :class:`Cancelled` if the cancel hook of :func:`cancellable` (or ``hook``, a
    value of it taken in another thread) is set."""
    hook = _CANCEL.get() if hook is None else hook
    if hook is not None and hook[0]():
        raise Cancelled(f"{hook[1]} was cancelled by the caller; no figures were produced")


def map_chunks(fn, k: int, chunk: int):
    """``[fn(s) for s in range(0, k, chunk)]``, on the threads of :func:`parallel` when
    there are several chunks; the cancel hook of :func:`cancellable` is checked before every
    chunk."""
    return _map(fn, range(0, k, chunk), carry_hook=False)


def map_tasks(fn, items):
    """``[fn(x) for x in items]``, on the threads of :func:`parallel` when there are several
    items (independent tasks, e.g. one per pass level). Inside a task :func:`map_chunks`
    runs in its thread only (the pool's threads start from the default context), so the
    tasks are the unit of parallelism; the cancel hook is checked before every task and
    reaches the tasks' own chunks."""
    return _map(fn, items, carry_hook=True)


def alongside(fn):
    """Start ``fn()`` on a thread of its own when :func:`parallel` allows several threads, so
    that a step running on one core (e.g. building surface samples) overlaps the caller's
    next steps; returns a function that waits for ``fn``'s result and returns it (or raises
    its exception). With one thread ``fn`` runs, in the calling thread, when the result is
    asked for — the order of the work is then the caller's. The thread has the caller's
    cancel hook and one worker (its own chunked queries stay on it); ``fn`` must not touch
    what the caller's steps change meanwhile."""
    if _WORKERS.get() < 2:
        return fn
    ctx = contextvars.copy_context()
    ctx.run(_WORKERS.set, 1)
    box = {}

    def run():
        try:
            box["value"] = ctx.run(fn)
        except BaseException as exc:  # handed to the caller by result()
            box["error"] = exc

    thread = threading.Thread(target=run, name="blisk_cam-alongside", daemon=True)
    thread.start()

    def result():
        thread.join()
        if "error" in box:
            raise box["error"]
        return box["value"]

    return result


def _map(fn, items, *, carry_hook: bool):
    """``[fn(x) for x in items]`` on up to :func:`parallel` threads, the cancel hook checked
    before every item (and, with ``carry_hook``, set in the pool thread's context while the
    item runs, so its own chunks check it too). When an item raises (``Cancelled`` or an
    error), the items not started yet are dropped, not run."""
    items = list(items)
    n = min(_WORKERS.get(), len(items))
    hook = _CANCEL.get()
    if hook is not None:
        inner = fn

        def fn(x):
            check_cancel(hook)
            if not carry_hook:
                return inner(x)
            token = _CANCEL.set(hook)
            try:
                return inner(x)
            finally:
                _CANCEL.reset(token)
    if n <= 1:
        return [fn(x) for x in items]
    # once an item has raised, the items a pool thread starts afterwards return at once
    # without running (or polling the hook): a thread that finishes its item could otherwise
    # start, poll and fail every queued item before this thread wakes up to cancel them
    failed = threading.Event()

    def guarded(x):
        if failed.is_set():
            return None  # never read: an earlier item's exception is raised below
        try:
            return fn(x)
        except BaseException:
            failed.set()
            raise

    with ThreadPoolExecutor(max_workers=n) as ex:
        futures = [ex.submit(guarded, x) for x in items]
        _, pending = wait(futures, return_when=FIRST_EXCEPTION)
        for f in pending:  # an item raised: the items not started are not run (the pool
            f.cancel()  # starts them in order, so the failed one comes first below)
        return [f.result() for f in futures]


# ================================================================== exact kernels
def _dot(a, b):
    return np.einsum("ij,ij->i", a, b)


def _edge_capsules(A, B, C, scale: float):
    """The capsule around each triangle's longest edge that holds the whole triangle.

    The angles at the ends of the longest edge are acute, so every point of the face lies
    within h (the opposite vertex's distance from the edge segment) of that segment: the
    distance to the capsule is a lower bound of the distance to the face that stays tight on
    slivers and needles (a scanned leading edge), where a disk or sphere around the centroid
    is as wide as the face is long.

    Parameters
    ----------
    A, B, C : (m, 3) mm — the corners
    scale : float mm — the coordinates' magnitude (max |x|), for the rounding pad of h

    Returns
    -------
    (m, 8) rows [S (3), D (3), 1/|D|² (1 for a point), h]: the longest edge S + t·D,
    0 ≤ t ≤ 1 (the first of equal edges AB, BC, CA), and h padded by 1e-9 relative and
    1e-12 · max(scale, 1) absolute. :func:`_capsule_distance` measures against them.
    """
    ab, bc, ca = B - A, C - B, A - C
    lab, lbc, lca = _dot(ab, ab), _dot(bc, bc), _dot(ca, ca)
    on_ab = ((lab >= lbc) & (lab >= lca))[:, None]
    on_bc = (lbc >= lca)[:, None]
    S = np.where(on_ab, A, np.where(on_bc, B, C))
    D = np.where(on_ab, ab, np.where(on_bc, bc, ca))
    O = np.where(on_ab, C, np.where(on_bc, A, B))  # the opposite vertex
    dd = _dot(D, D)
    inv = 1.0 / np.where(dd > 0, dd, 1.0)
    hv = O - S
    hv -= np.clip(_dot(hv, D) * inv, 0.0, 1.0)[:, None] * D
    h = np.sqrt(_dot(hv, hv)) * (1.0 + 1e-9) + 1e-12 * max(float(scale), 1.0)
    return np.ascontiguousarray(np.hstack([S, D, inv[:, None], h[:, None]]))


def _capsule_distance(P, G):
    """(k,) mm — distance from (k, 3) points to the capsules of the (k, 8) rows ``G`` of
    :func:`_edge_capsules` (0 inside): a lower bound of the distance to each row's face."""
    w = P - G[:, 0:3]
    t = np.clip(_dot(w, G[:, 3:6]) * G[:, 6], 0.0, 1.0)
    w -= t[:, None] * G[:, 3:6]
    return np.maximum(np.sqrt(_dot(w, w)) - G[:, 7], 0.0)


def _cross(x, y):
    """Row-wise cross products of (k, 3) arrays (np.cross's overhead is large here)."""
    x0, x1, x2 = x[:, 0], x[:, 1], x[:, 2]
    y0, y1, y2 = y[:, 0], y[:, 1], y[:, 2]
    return np.stack([x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0], axis=1)


def _triple(n, x, y):
    """Row-wise n · (x × y) of (k, 3) arrays."""
    x0, x1, x2 = x[:, 0], x[:, 1], x[:, 2]
    y0, y1, y2 = y[:, 0], y[:, 1], y[:, 2]
    return n[:, 0] * (x1 * y2 - x2 * y1) + n[:, 1] * (x2 * y0 - x0 * y2) + \
        n[:, 2] * (x0 * y1 - x1 * y0)


def closest_on_segments(p, a, b):
    """Closest points on segments to points, pairwise.

    Parameters
    ----------
    p, a, b : (k, 3) float, mm — query points and segment end points (a = b is a point)

    Returns
    -------
    t : (k,) float in [0, 1] — the closest point is ``a + t (b − a)``
    d2 : (k,) float, mm² — squared distance
    """
    d = b - a
    dd = _dot(d, d)
    t = _dot(p - a, d) / np.where(dd > 0, dd, 1.0)
    t = np.clip(t, 0.0, 1.0)
    q = a + t[:, None] * d
    e = p - q
    return t, _dot(e, e)


def closest_on_triangles(p, a, b, c):
    """Exact closest points on triangles to points, pairwise (robust to degenerate triangles).

    The projection onto the triangle's plane is used when it falls inside the triangle;
    otherwise the closest point is the nearest of the three edge (segment) closest points.
    Zero-area triangles are treated as their edges only.

    Thin triangles (slivers, needles): the plane normal n is the cross product of the two
    edges at the largest angle, the interior closest point q is the projection of p onto the
    plane and its barycentric coordinates are the signed sub-areas n · ((b − q) × (c − q)) /
    |n|², ..., whose rounding is ~ε / sin(largest angle) relative — not a Gram-determinant
    solve (d00 d11 − d01², ~ε / sin²(angle at a)), which put points on a 0.8 mm needle
    3e-6 mm high up to 9e-6 mm off it.

    Parameters
    ----------
    p, a, b, c : (k, 3) float, mm

    Returns
    -------
    q : (k, 3) float, mm — closest points
    d2 : (k,) float, mm² — squared distances
    feature : (k,) int8 — 0 face interior; 1, 2, 3 edge ab, bc, ca; 4, 5, 6 vertex a, b, c
    bary : (k, 3) float — barycentric coordinates of ``q`` w.r.t. (a, b, c)
    """
    k = len(p)
    ab, bc, ca = b - a, c - b, a - c
    lab, lbc, lca = _dot(ab, ab), _dot(bc, bc), _dot(ca, ca)
    # normal from the two edges at the largest angle (opposite the longest edge)
    c_long = ((lab >= lbc) & (lab >= lca))[:, None]
    a_long = (lbc >= lca)[:, None]
    n = _cross(np.where(c_long, bc, np.where(a_long, ca, ab)),
               np.where(c_long, ca, np.where(a_long, ab, bc)))
    nn = _dot(n, n)
    ok = nn > 1e-24 * np.maximum(np.maximum(lab, lbc), lca) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(ok, 1.0 / np.where(ok, nn, 1.0), 0.0)
    # projection of p onto the plane, then its barycentric coordinates as signed sub-areas
    # (from the projection, not p: far from the plane the cross products of p − b, p − c
    # would round by ε |p − b|²)
    q_in = p + (_dot(a - p, n) * inv)[:, None] * n
    qa, qb, qc = a - q_in, b - q_in, c - q_in
    u = _triple(n, qb, qc) * inv
    v = _triple(n, qc, qa) * inv
    w = _triple(n, qa, qb) * inv
    inside = ok & (u >= 0) & (v >= 0) & (w >= 0)
    s_uvw = np.where(inside, u + v + w, 1.0)  # 1 up to rounding (> 0 where inside)
    u, v, w = u / s_uvw, v / s_uvw, w / s_uvw

    bary = np.zeros((k, 3))
    feature = np.zeros(k, dtype=np.int8)
    best = np.full(k, np.inf)
    # edges: (start, end, bary column of start, of end, feature ids edge / start / end)
    specs = ((a, b, 0, 1, 1, 4, 5), (b, c, 1, 2, 2, 5, 6), (c, a, 2, 0, 3, 6, 4))
    for s, e, i0, i1, fe, fs, fend in specs:
        t, d2 = closest_on_segments(p, s, e)
        better = d2 < best
        best = np.where(better, d2, best)
        bb = np.zeros((k, 3))
        bb[:, i0] = 1.0 - t
        bb[:, i1] = t
        bary = np.where(better[:, None], bb, bary)
        fcode = np.where(t <= 0.0, fs, np.where(t >= 1.0, fend, fe)).astype(np.int8)
        feature = np.where(better, fcode, feature)
    bary = np.where(inside[:, None], np.stack([u, v, w], axis=1), bary)
    feature = np.where(inside, 0, feature).astype(np.int8)
    q = np.where(inside[:, None], q_in, bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:] * c)
    e = p - q
    d2 = _dot(e, e)
    return q, d2, feature, bary


def _ray_capsules_first_hit(o, n, a, b, radius):
    """First hit parameter t ≥ 0 of rays ``o + t n`` (unit n) with capsules (segment ab,
    ``radius``), pairwise; ``inf`` where the ray misses. Rays are assumed to start outside."""
    k = len(o)
    best = np.full(k, np.inf)
    r2 = radius * radius
    for cen in (a, b):  # the two end spheres
        oc = o - cen
        bq = _dot(n, oc)
        h = bq * bq - (_dot(oc, oc) - r2)
        t = -bq - np.sqrt(np.maximum(h, 0.0))
        best = np.where((h >= 0) & (t >= 0) & (t < best), t, best)
    ba = b - a
    oa = o - a
    baba = _dot(ba, ba)
    bard = _dot(ba, n)
    baoa = _dot(ba, oa)
    rdoa = _dot(n, oa)
    oaoa = _dot(oa, oa)
    A = baba - bard * bard
    B = baba * rdoa - baoa * bard
    C = baba * oaoa - baoa * baoa - r2 * baba
    h = B * B - A * C
    okc = (A > 1e-12 * np.maximum(baba, 1e-300)) & (h >= 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(okc, (-B - np.sqrt(np.maximum(h, 0.0))) / np.where(okc, A, 1.0), np.inf)
    y = baoa + np.where(okc, t, 0.0) * bard
    okc &= (t >= 0) & (y >= 0) & (y <= baba)
    return np.where(okc & (t < best), t, best)


# ================================================================== bounding-volume tree
def _median_slots(cen, size):
    """Recursive median splits of points along the longest extent (vectorised, level by
    level) into 2^L groups of ``size`` slots. Returns (slots (2^L, size) ids, −1 padded; L)."""
    m = len(cen)
    nleaf = max(1, -(-m // size))
    L = int(np.ceil(np.log2(nleaf))) if nleaf > 1 else 0
    NS = (1 << L) * size
    # one contiguous array per coordinate: the per-segment extents are then reductions along
    # contiguous rows (3-4x faster than over (nseg, seglen, 3) blocks; the same values)
    keys = []
    for j in range(3):
        k = np.full(NS, np.inf)
        k[:m] = cen[:, j]
        keys.append(k)
    order = np.arange(NS)
    for level in range(L):
        nseg = 1 << level
        seglen = NS >> level
        cs = [k[order].reshape(nseg, seglen) for k in keys]
        fin = np.isfinite(cs[0])
        lo = np.stack([np.min(x, axis=1, where=fin, initial=np.inf) for x in cs], axis=1)
        hi = np.stack([np.max(x, axis=1, where=fin, initial=-np.inf) for x in cs], axis=1)
        ext = np.where(np.isfinite(hi - lo), hi - lo, -1.0)
        ax = np.argmax(ext, axis=1)[:, None]
        key = np.where(ax == 0, cs[0], np.where(ax == 1, cs[1], cs[2]))
        part = np.argpartition(key, seglen // 2 - 1, axis=1)
        order = np.take_along_axis(order.reshape(nseg, seglen), part, axis=1).reshape(-1)
    return np.where(order < m, order, -1).reshape(-1, size), L


def _run_clusters(breaks, m, size):
    """Clusters of up to ``size`` consecutive primitives, never across ``breaks`` (sorted
    start indices of runs, e.g. the first segment of each curve). (n, size) ids, −1 padded."""
    starts = np.unique(np.concatenate([[0], np.asarray(breaks, dtype=np.int64)]))
    starts = starts[starts < m]
    ends = np.append(starts[1:], m)
    nper = -(-(ends - starts) // size)
    rank = np.arange(nper.sum()) - np.repeat(np.cumsum(nper) - nper, nper)
    first = np.repeat(starts, nper) + size * rank
    last = np.repeat(ends, nper)
    ids = first[:, None] + np.arange(size)
    return np.where(ids < last[:, None], ids, -1)


class _Tree:
    """A complete binary bounding-volume tree over clusters of primitives.

    The clusters (leaves) are split at the median of their centroids along the longest
    extent, level by level (vectorised). Every node stores an axis-aligned box and an
    oriented cylinder (axis = the smallest principal direction of the node's points for
    surfaces, the largest for curves) containing the node's points; a node is visited only
    if both bounds come within the search radius. Queries are breadth-first, vectorised over
    (query, node) pairs. A k-d tree of the primitives' centroids gives nearest queries a
    first upper bound.

    Parameters
    ----------
    corners : (m, c, 3) float — the corner points of each (convex) primitive
    flat : bool — True for surface patches (cylinder along the normal), False for curves
    clusters : (n, B) int — primitive ids of each leaf, −1 padded; default median splits
    leaf_size : int — B when ``clusters`` is not given
    discs : (axes (m, 2, 3), phi (m,), radius) or None — widen the bounds for a disc of
        ``radius`` ⟂ the axis at every point of each primitive, the axis turning on the great
        arc from axes[:, 0] to axes[:, 1] (angle phi): along a unit direction w such a disc
        reaches radius · sin∠(w, axis), and sin∠(w, axis(t)) ≤ (sin∠(w, a₀) + sin∠(w, a₁) +
        φ)/2 on the arc (the angle is 1-Lipschitz in t φ); across w it reaches ≤ radius. The
        node boxes and cylinders grow by these amounts (used by :class:`SweptCutter`: a posed
        cutter lies in the cylinder of radius ``max_radius`` about its axis segment, so the
        bound below the tips is tight instead of ``max_radius``).
    disc_axis : bool — with ``discs``: every node's cylinder takes the mean disc axis of its
        primitives as its axis (instead of a principal direction) and the axis-aligned box
        is replaced by an oriented box (the mean axis, the points' principal direction across
        it, their cross product), so a node of nearly parallel discs is bounded by a flat
        puck and box — tight above and below the discs, where a principal-direction
        cylinder around a run of discs would be ``radius`` thick.
    group_tail : int — levels above the leaves where the packet traversal of many queries
        (:meth:`_group_descent`) hands over to per-query tests (speed only: the pairs are
        the same)
    leaf_obb : bool — :meth:`pairs` also tests each leaf's oriented box (its points'
        principal axes): fewer leaves, the same order
    """

    def __init__(self, corners, *, flat: bool, clusters=None, leaf_size: int = 8, discs=None,
                 disc_axis: bool = False, group_tail: int = _GROUP_TAIL, leaf_obb: bool = False):
        corners = np.asarray(corners, dtype=np.float64)
        self.group_tail = int(group_tail)
        m, nc, _ = corners.shape
        self.m = m
        pcen = corners.mean(axis=1)
        if clusters is None:
            clusters, _ = _median_slots(pcen, leaf_size)
            clusters = clusters[np.any(clusters >= 0, axis=1)]
        clusters = np.asarray(clusters, dtype=np.int64)
        B = clusters.shape[1]
        cnt = np.maximum((clusters >= 0).sum(axis=1), 1)
        ccen = np.where((clusters >= 0)[:, :, None], pcen[np.maximum(clusters, 0)], 0.0)
        ccen = ccen.sum(axis=1) / cnt[:, None]
        slots, L = _median_slots(ccen, 1)
        slot = slots[:, 0]
        NL = 1 << L
        self.L, self.NL = L, NL
        self.prims = np.where((slot >= 0)[:, None], clusters[np.maximum(slot, 0)], -1)

        # the points of each leaf; padding (absent primitives, empty leaves) repeats points of
        # the same leaf or of the previous leaf, which leaves every bound valid and tight.
        # Padding may sit in any slot (median splits leave −1 anywhere in a cluster): repeat
        # the row's first present primitive, not slot 0 — a leaf whose slot 0 was padding
        # used to be bounded by the previous leaf's points and lost its own primitives
        present = self.prims >= 0
        first = self.prims[np.arange(NL), np.argmax(present, axis=1)]  # −1 for an empty leaf
        fill = np.where(present, self.prims, first[:, None])
        empty = first < 0
        if np.any(empty):
            src = np.maximum.accumulate(np.where(~empty, np.arange(NL), -1))
            src = np.where(src >= 0, src, np.argmax(~empty))
            fill = fill[src]
        pts = corners[fill].reshape(NL, B * nc, 3)
        nn = 2 * NL
        self.lo = np.empty((nn, 3))
        self.hi = np.empty((nn, 3))
        self.c = np.zeros((nn, 3))
        self.w = np.tile([0.0, 0.0, 1.0], (nn, 1))
        self.H = np.zeros(nn)
        self.R = np.zeros(nn)
        self.lo[NL:] = pts.min(axis=1)
        self.hi[NL:] = pts.max(axis=1)
        if discs is not None:
            d_ax = np.asarray(discs[0], dtype=np.float64)[fill]  # (NL, B, 2, 3)
            d_phi = np.asarray(discs[1], dtype=np.float64)[fill]  # (NL, B)
            d_rad = float(discs[2])

            def reach(sin_a, sin_b, ph):
                return d_rad * np.minimum(1.0, 0.5 * (sin_a + sin_b + ph))

            sx = np.sqrt(np.maximum(1.0 - d_ax * d_ax, 0.0))  # sine to each coordinate axis
            ext = reach(sx[:, :, 0], sx[:, :, 1], d_phi[:, :, None]).max(axis=1)
            self.lo[NL:] -= ext
            self.hi[NL:] += ext
        for level in range(L - 1, -1, -1):
            nodes = np.arange(1 << level, 2 << level)
            self.lo[nodes] = np.minimum(self.lo[2 * nodes], self.lo[2 * nodes + 1])
            self.hi[nodes] = np.maximum(self.hi[2 * nodes], self.hi[2 * nodes + 1])
        for level in range(L + 1):
            nodes = np.arange(1 << level, 2 << level)
            X = pts.reshape(1 << level, -1, 3)
            mean = X.mean(axis=1)
            D = X - mean[:, None, :]
            _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", D, D))
            wv = vec[:, :, 0] if flat else vec[:, :, 2]
            if discs is not None and disc_axis:
                ma = d_ax.reshape(1 << level, -1, 3).sum(axis=1)
                mn = np.linalg.norm(ma, axis=1)
                wv = np.where((mn > 1e-12)[:, None], ma / np.maximum(mn, 1e-300)[:, None], wv)
                self._obb_level(nodes, D, mean, wv, d_ax, d_phi, reach)
            z = np.einsum("npi,ni->np", D, wv)
            rad2 = np.einsum("npi,npi->np", D, D) - z * z
            self.c[nodes] = mean
            self.w[nodes] = wv
            self.H[nodes] = np.abs(z).max(axis=1)
            self.R[nodes] = np.sqrt(np.maximum(rad2.max(axis=1), 0.0))
            if discs is not None:
                cw = np.einsum("npki,ni->npk", d_ax.reshape(1 << level, -1, 2, 3), wv)
                sw_ = np.sqrt(np.maximum(1.0 - cw * cw, 0.0))
                ph = d_phi.reshape(1 << level, -1)
                self.H[nodes] += reach(sw_[:, :, 0], sw_[:, :, 1], ph).max(axis=1)
                self.R[nodes] += d_rad
        self.leaf_box = self._leaf_boxes(pts) if leaf_obb else None
        # bounds are computed from rounded numbers: widen them a little
        self.H += 1e-12 * (1.0 + np.abs(self.H))
        self.obb = None
        if discs is not None and disc_axis:
            half = self._obb[:, 12:15]
            self._obb[:, 12:15] = half + 1e-12 * (1.0 + np.abs(half))
            self.obb = self._obb
        self.R += 1e-12 * (1.0 + np.abs(self.R))
        self._pack()
        # upper bounds for nearest queries: the primitives with the nearest centroids
        self.kd = cKDTree(pcen) if m else None
        self.kd_k = int(min(2, m))
        # a small slack for rounding in the bounds (never prunes a true candidate)
        scale = float(np.max(np.abs(corners))) if m else 1.0
        self.slack = 1e-9 * max(scale, 1.0)

    @staticmethod
    def _leaf_boxes(pts):
        """(NL, 18) per leaf [mean (3), principal axes as columns (9), low (3), high (3)
        corner of its points' box in that frame, widened for rounding]. A patch of a
        surface cut by median splits is long and narrow: the box bounds it where the
        cylinder (radius the patch's half-length) does not — Rotor 37's ball centres 6 mm off
        the surface reach 12 leaves per point through the node bounds, 6.6 through the box."""
        mean = pts.mean(axis=1)
        D = pts - mean[:, None, :]
        _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", D, D))
        x = np.einsum("npi,nij->npj", D, vec)
        lo, hi = x.min(axis=1), x.max(axis=1)
        pad = 1e-9 * (1.0 + np.abs(lo) + np.abs(hi))
        return np.ascontiguousarray(np.hstack([mean, vec.reshape(-1, 9), lo - pad, hi + pad]))

    def _obb_level(self, nodes, D, mean, w2, d_ax, d_phi, reach):
        """Oriented boxes of one level's nodes (``disc_axis`` trees): axis w2 = the mean
        disc axis, w1 the principal direction of the node's points across it, w3 = w2 × w1;
        half extents = the points' extents plus the discs' reach along each direction."""
        if not hasattr(self, "_obb"):
            self._obb = np.zeros((len(self.H), 15))
        n = len(nodes)
        Dp = D - np.einsum("npi,ni->np", D, w2)[:, :, None] * w2[:, None, :]
        _, vec = np.linalg.eigh(np.einsum("npi,npj->nij", Dp, Dp))
        w1 = vec[:, :, 2]
        w1 = w1 - np.einsum("ni,ni->n", w1, w2)[:, None] * w2
        w1n = np.linalg.norm(w1, axis=1)
        alt = np.cross(w2, np.where((np.abs(w2[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0],
                                    [0.0, 1.0, 0.0]))
        w1 = np.where((w1n > 1e-6)[:, None], w1 / np.maximum(w1n, 1e-300)[:, None],
                      alt / np.linalg.norm(alt, axis=1)[:, None])
        w3 = np.cross(w2, w1)
        ax = d_ax.reshape(n, -1, 2, 3)
        ph = d_phi.reshape(n, -1)
        half = np.empty((n, 3))
        for j, w in enumerate((w1, w2, w3)):
            cw = np.einsum("npki,ni->npk", ax, w)
            sw_ = np.sqrt(np.maximum(1.0 - cw * cw, 0.0))
            half[:, j] = (np.abs(np.einsum("npi,ni->np", D, w)).max(axis=1)
                          + reach(sw_[:, :, 0], sw_[:, :, 1], ph).max(axis=1))
        self._obb[nodes] = np.hstack([mean, w1, w2, w3, half])

    def _pack(self):
        """One (nodes, 14) array [lo, hi, c, w, H, R] so a level needs a single gather
        (with oriented boxes: [c, w1, w2, w3, half (3), H, R], (nodes, 17))."""
        if getattr(self, "obb", None) is not None:
            self.nd = np.ascontiguousarray(
                np.hstack([self.obb, self.H[:, None], self.R[:, None]]))
            return
        self.nd = np.ascontiguousarray(
            np.hstack([self.lo, self.hi, self.c, self.w, self.H[:, None], self.R[:, None]]))

    def _within_bound(self, P, node, r2):
        """Whether the lower bound of the distance from points P (k, 3) to ``node`` (k,)
        is at most sqrt(r2) (k,) — both the box and the cylinder bound must pass."""
        nd = np.take(self.nd, node, axis=0)  # the same rows as self.nd[node], ~2.5x faster
        if self.obb is not None:  # oriented box [c, w1, w2, w3, half] and the puck along w2
            d = P - nd[:, 0:3]
            acc = np.zeros(len(P))
            for j in range(3):
                x = np.einsum("ij,ij->i", d, nd[:, 3 + 3 * j: 6 + 3 * j])
                if j == 1:
                    z2 = x.copy()  # the height along the puck's axis w2, used below
                x = np.abs(x, out=x)
                x -= nd[:, 12 + j]
                np.maximum(x, 0.0, out=x)
                acc += x * x
                if j == 1:
                    ez = x
            ok = acc <= r2
            rr = np.einsum("ij,ij->i", d, d) - z2 * z2
            er = np.sqrt(np.maximum(rr, 0.0)) - nd[:, 16]
            np.maximum(er, 0.0, out=er)
            ok &= ez * ez + er * er <= r2
            return ok
        g = np.maximum(nd[:, 0:3] - P, 0.0)
        g += np.maximum(P - nd[:, 3:6], 0.0)
        ok = np.einsum("ij,ij->i", g, g) <= r2
        d = P - nd[:, 6:9]
        z = np.abs(np.einsum("ij,ij->i", d, nd[:, 9:12]))
        rr = np.einsum("ij,ij->i", d, d) - z * z
        er = np.sqrt(np.maximum(rr, 0.0)) - nd[:, 13]
        np.maximum(er, 0.0, out=er)
        ez = z - nd[:, 12]
        np.maximum(ez, 0.0, out=ez)
        ok &= ez * ez + er * er <= r2
        return ok

    def leaf_pairs(self, P, r2, groups=None):
        """All (query, leaf) pairs whose node bounds come within sqrt(r2) of the query.

        Parameters
        ----------
        P : (k, 3) float
        r2 : (k,) float — squared search radii
        groups : None or :func:`query_groups` of P — the packet traversal's groups, when
            several trees are asked about the same points (built once; the same pairs)

        Returns
        -------
        qi, leaf : (n,) int64 — leaf = row of ``prims``
        """
        k = len(P)
        r2 = (np.sqrt(np.maximum(r2, 0.0)) + self.slack) ** 2
        if k * self.NL <= _FLAT_PAIRS:
            # few queries on a small tree (e.g. sphere tracing against one level's passes):
            # test every leaf at once instead of L levels of small steps. A superset of the
            # breadth-first answer in the same order (by query, then leaf): a leaf within the
            # radius has every ancestor within it, and the extra leaves hold nothing within it
            q = np.repeat(np.arange(k), self.NL)
            node = np.tile(np.arange(self.NL, 2 * self.NL), k)
            keep = self._within_bound(P[q], node, r2[q])
            return q[keep], node[keep] - self.NL
        tail = self.group_tail
        if k >= _GROUP_MIN and self.L > tail + 1:
            q, node = self._group_descent(P, r2, self.L - tail, groups)
        else:
            q = np.arange(k)
            node = np.ones(k, dtype=np.int64)
        keep = self._within_bound(np.take(P, q, axis=0), node, np.take(r2, q))
        q, node = q[keep], node[keep]
        two = np.arange(2)
        for _ in range(self.L - int(np.log2(node[0])) if len(node) else 0):
            q = np.repeat(q, 2)
            node = (2 * node[:, None] + two).reshape(-1)
            keep = self._within_bound(np.take(P, q, axis=0), node, np.take(r2, q))
            q, node = q[keep], node[keep]
        return q, node - self.NL

    def _group_descent(self, P, r2, depth, groups=None):
        """Packet traversal of the top ``depth`` levels: the queries in groups of
        ``_GROUP`` neighbours (median splits), each group walks the tree as one sphere
        around its mean whose radius holds every member's search sphere (r_q + |p_q − c|);
        the nodes it reaches at level ``depth`` are handed to its members. Returns
        (query, node) pairs sorted by query, then node: a superset of the per-query walk's
        pairs at that level (a node within a member's radius is within the group's, the
        distance to a bound being 1-Lipschitz), far fewer bound tests where the tree is
        wide (the upper levels are tested once per group instead of once per query)."""
        slots = query_groups(P) if groups is None else groups
        ok = slots >= 0
        ids = np.where(ok, slots, 0)
        cnt = ok.sum(axis=1)
        Pg = np.take(P, ids, axis=0)
        c = np.where(ok[:, :, None], Pg, 0.0).sum(axis=1) / cnt[:, None]
        off = np.sqrt(np.einsum("gmi,gmi->gm", Pg - c[:, None, :], Pg - c[:, None, :]))
        rg = (np.where(ok, np.sqrt(np.take(r2, ids)) + off, 0.0).max(axis=1) * (1.0 + 1e-12)
              + self.slack)
        rg2 = rg * rg
        ng = len(slots)
        g = np.arange(ng)
        node = np.ones(ng, dtype=np.int64)
        keep = self._within_bound(c, node, rg2)
        g, node = g[keep], node[keep]
        two = np.arange(2)
        for _ in range(depth):
            g = np.repeat(g, 2)
            node = (2 * node[:, None] + two).reshape(-1)
            keep = self._within_bound(np.take(c, g, axis=0), node, np.take(rg2, g))
            g, node = g[keep], node[keep]
        # hand the nodes to the members: (query, node), sorted by query (stable: by node)
        mem = np.take(slots, g, axis=0)
        node = np.broadcast_to(node[:, None], mem.shape)[mem >= 0]
        q = mem[mem >= 0]
        # a stable sort by query (radix sort on 16-bit keys: the same permutation, ~5x faster)
        order = np.argsort(q.astype(np.int16) if len(P) <= 32767 else q, kind="stable")
        return np.take(q, order), np.take(node, order)

    def pairs(self, P, r2):
        """All (query, primitive) pairs whose node bounds come within sqrt(r2) of the query.

        Parameters
        ----------
        P : (k, 3) float
        r2 : (k,) float — squared search radii

        Returns
        -------
        qi, prim : (n,) int64 — a superset of the primitives within the radii
        """
        q, leaf = self.leaf_pairs(P, r2)
        if self.leaf_box is not None and len(q):
            # the leaves' oriented boxes (a filter: the order is kept)
            bx = self.leaf_box[leaf]
            d = np.einsum("ni,nij->nj", P[q] - bx[:, 0:3], bx[:, 3:12].reshape(-1, 3, 3))
            g = np.maximum(bx[:, 12:15] - d, 0.0)
            g += np.maximum(d - bx[:, 15:18], 0.0)
            rr = (np.sqrt(np.maximum(r2[q], 0.0)) + self.slack) ** 2
            keep = np.einsum("ij,ij->i", g, g) <= rr
            q, leaf = q[keep], leaf[keep]
        B = self.prims.shape[1]
        prim = self.prims[leaf].reshape(-1)
        q = np.repeat(q, B)
        ok = prim >= 0
        return q[ok], prim[ok]


def query_groups(P):
    """Groups of ``_GROUP`` neighbouring queries (k, 3) for :meth:`_Tree.leaf_pairs`'
    packet traversal: (g, _GROUP) query ids, −1 padded (median splits, empty groups
    dropped)."""
    slots, _ = _median_slots(P, _GROUP)
    return slots[np.any(slots >= 0, axis=1)]


def _group_argmin(k, qi, values, ids):
    """Per query the minimum value and the id achieving it (−1 and inf where none)."""
    best = np.full(k, np.inf)
    np.minimum.at(best, qi, values)
    win = values <= best[qi]
    arg = np.full(k, -1, dtype=np.int64)
    arg[qi[win]] = ids[win]
    return best, arg


def _nearest(tree: _Tree, P, d2fn, keepfn=None, chunk=_CHUNK, fastfn=None, near=None):
    """Exact nearest primitive to each point.

    The primitives with the nearest centroids give an upper bound u; then every primitive in
    a node whose bounds lie within u, and that ``keepfn`` (if given) keeps, is evaluated
    exactly. Returns (d2 (k,), prim (k,)).

    ``keepfn(P, qi, prim, u2)`` (optional) returns the mask (n,) of the pairs (query ``qi``,
    primitive ``prim``) whose lower bound of the squared distance is ≤ ``u2`` (n,) ≥ 0; a
    valid lower bound never drops the nearest primitive.

    ``near`` (optional, (k, 3)): the centroids are looked up nearest to these points instead
    of P (a guess of where each point's nearest primitive is). Any points give a valid bound
    and the same result, bit for bit and ties included (every primitive within u is listed
    after the looked-up ones, in tree order, and the last of equal distances wins); points
    close to the primitives spare the k-d search its slow case, a query far from every
    centroid (a ball centre 6 mm off the surface, a surface point under the centre polylines).

    ``fastfn(P, qi, prim)`` (optional) returns (d2 (n,), tol (float)): the same squared
    distances by a cheaper formula, each within ``tol`` of ``d2fn``'s (NaN: no estimate,
    always evaluate). Then only the
    candidates within 2 tol of their query's smallest ``fastfn`` value — a superset of every
    candidate that can reach the exact minimum, ties included — are evaluated with ``d2fn``,
    in their original order, so the result is the one without ``fastfn``, bit for bit.
    """
    k = len(P)
    d2 = np.full(k, np.inf)
    arg = np.full(k, -1, dtype=np.int64)
    if tree.m == 0:
        return d2, arg

    def run(s):
        Pc = P[s : s + chunk]
        kc = len(Pc)
        _, j = tree.kd.query(Pc if near is None else near[s : s + chunk], k=tree.kd_k)
        pr = np.asarray(j, dtype=np.int64).reshape(-1)
        qi = np.repeat(np.arange(kc), tree.kd_k)
        u2, _ = _group_argmin(kc, qi, d2fn(Pc, qi, pr), pr)
        u2 = u2 * (1.0 + 1e-9)
        q2, p2 = tree.pairs(Pc, u2)
        if keepfn is not None and len(q2):
            keep = keepfn(Pc, q2, p2, u2[q2])
            q2, p2 = q2[keep], p2[keep]
        qi = np.concatenate([qi, q2])
        pr = np.concatenate([pr, p2])
        if fastfn is not None and len(qi):
            fa, tol = fastfn(Pc, qi, pr)
            always = np.isnan(fa)
            fbest = np.full(kc, np.inf)
            np.minimum.at(fbest, qi, np.where(always, np.inf, fa))
            keep = always | (fa <= fbest[qi] + 2.0 * tol)
            qi, pr = qi[keep], pr[keep]
        best, a = _group_argmin(kc, qi, d2fn(Pc, qi, pr), pr)
        d2[s : s + chunk] = best
        arg[s : s + chunk] = a

    map_chunks(run, k, chunk)
    return d2, arg


def _within(tree: _Tree, P, radius, chunk=_CHUNK):
    """Candidate (query, primitive) pairs within ``radius`` (k,) of each point (superset)."""
    r2 = np.asarray(radius, dtype=np.float64) ** 2

    def run(s):
        q, p = tree.pairs(P[s : s + chunk], r2[s : s + chunk])
        return q + s, p

    out = map_chunks(run, len(P), chunk)
    if not out:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate([q for q, _ in out]), np.concatenate([p for _, p in out])


# ================================================================== point → mesh
@dataclass
class ClosestPoints:
    """Closest points on a mesh.

    Attributes
    ----------
    distance : (k,) float, mm — unsigned distance to the mesh
    point : (k, 3) float, mm — closest point on the mesh
    face : (k,) int64 — face containing the closest point
    bary : (k, 3) float — its barycentric coordinates in that face
    feature : (k,) int8 — 0 face interior, 1..3 edge, 4..6 vertex (see closest_on_triangles)
    sign : (k,) float — +1 on the normal (outer, tool) side, −1 inside the material, 0 on it
    """

    distance: np.ndarray
    point: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    feature: np.ndarray
    sign: np.ndarray

    @property
    def signed_distance(self) -> np.ndarray:
        """(k,) float, mm — > 0 outside (normal side), < 0 inside the material."""
        return self.sign * self.distance


class MeshDistance:
    """Reusable exact closest-point queries on a :class:`TriMesh`.

    Parameters
    ----------
    mesh : TriMesh
    leaf_size : int — triangles per tree leaf
    """

    def __init__(self, mesh: TriMesh, *, leaf_size: int = 8):
        self.mesh = mesh
        V, F = mesh.V, mesh.F
        self._A, self._B, self._C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        T = V[F]
        self._cen = T.mean(axis=1)
        self._rad = np.linalg.norm(T - self._cen[:, None, :], axis=2).max(axis=1)
        self._n = mesh.face_normals  # zero for zero-area faces: the bound is then a sphere
        # per-query tests for the last 2 levels: queries far off the surface (ball centres,
        # 6 mm) come in groups whose common sphere reaches many more leaves than each member
        # (Rotor 37's centre polylines: 1.6 -> 1.1 s; surface points unchanged)
        self.tree = _Tree(T, flat=True, leaf_size=leaf_size, group_tail=2, leaf_obb=True)
        self._frames = None
        # the capsule of each face around its longest edge (see :meth:`_lb_keep`)
        self._cap = _edge_capsules(self._A, self._B, self._C,
                                   float(np.abs(T).max()) if len(T) else 1.0)

    def _face_frames(self):
        """(m, 31) per face: A, unit normal n, then per edge (AB, BC, CA) its start, unit
        direction, length and in-plane outward normal (direction × n); zero-area faces get
        n = 0 (see :meth:`_fast_d2`); the same for slivers."""
        if self._frames is None:
            A, B, C = self._A, self._B, self._C
            n = _cross(B - A, C - A)
            nl = np.sqrt(_dot(n, n))
            longest = np.sqrt(np.maximum.reduce([_dot(B - A, B - A), _dot(C - B, C - B),
                                                 _dot(A - C, A - C)]))
            # slivers (an angle below ~0.06°) are always evaluated exactly: their normal, from
            # rounded edges, is off by ~ε / sin(angle)
            ok = nl > 1e-3 * np.maximum(longest, 1e-300) ** 2
            n = np.where(ok[:, None], n / np.where(ok, nl, 1.0)[:, None], 0.0)
            cols = [A, n]
            for S, E in ((A, B), (B, C), (C, A)):
                d = E - S
                L = np.sqrt(_dot(d, d))
                e = d / np.where(L > 0, L, 1.0)[:, None]
                cols += [S, e, L[:, None], _cross(e, n)]
            self._frames = np.ascontiguousarray(np.hstack(cols))
        return self._frames

    def _fast_d2(self, P, qi, f):
        """Squared point–triangle distances (n,) from per-face frames — the plane height z and
        the in-plane distance to the triangle (0 inside; else the nearest edge segment, from
        its signed offset s and its parameter t): z² + min_i (s_i² + (t_i − clamp t_i)²) —
        and their error bound (a float, mm²). Zero-area faces and slivers give NaN (always
        evaluated exactly)."""
        G = self._face_frames()[f]
        p = P[qi]
        d = p - G[:, 0:3]
        z = np.einsum("ij,ij->i", d, G[:, 3:6])
        out = np.full(len(p), np.inf)
        inside = np.ones(len(p), bool)
        for j in range(3):
            c = 6 + 10 * j
            w = p - G[:, c : c + 3]
            t = np.einsum("ij,ij->i", w, G[:, c + 3 : c + 6])
            sg = np.einsum("ij,ij->i", w, G[:, c + 7 : c + 10])
            inside &= sg <= 0.0
            t -= np.clip(t, 0.0, G[:, c + 6])
            np.minimum(out, sg * sg + t * t, out=out)
        d2 = z * z + np.where(inside, 0.0, out)
        dd = np.einsum("ij,ij->i", d, d)
        d2 = np.where(np.any(G[:, 3:6] != 0.0, axis=1), d2, np.nan)
        # both formulas round by a few ε |p − A|² (|p − A| ≥ every distance here); far wider
        tol = 1e-10 * (1.0 + float(dd.max(initial=0.0)))
        return d2, tol

    def _d2(self, P, qi, f):
        return closest_on_triangles(P[qi], self._A[f], self._B[f], self._C[f])[1]

    def _lb_keep(self, P, qi, f, u2):
        """Whether a lower bound of the squared distance to each face is ≤ ``u2`` (n,) ≥ 0
        ((n,) bool): the larger of the squared distances to the disk (in the face plane,
        around the centroid) and to the capsule (around the longest edge, radius the opposite
        vertex's height) that contain the face, less a rounding pad of 1e-12 |p − centroid|².
        The capsule is what prunes slivers and needles (a scanned blade's leading edge: a
        disk of half their length around a face 0.03 mm wide let ~70 faces per ball centre
        through to the point–triangle kernels on Rotor 37, the capsule ~10), and it is tested
        first (it drops ~75 % of a ball centre's candidates there), the disk only on the
        pairs it keeps: max(a, b) − pad ≤ u2 exactly when a − pad and b − pad both are."""
        p = P[qi]
        d = p - self._cen[f]
        dd = _dot(d, d)
        c = _capsule_distance(p, self._cap[f])
        keep = c * c - 1e-12 * dd <= u2
        i = np.flatnonzero(keep)
        d, dd, fi = d[i], dd[i], f[i]
        z = _dot(d, self._n[fi])
        rad = np.sqrt(np.maximum(dd - z * z, 0.0))
        e = np.maximum(rad - self._rad[fi] * (1.0 + 1e-12), 0.0)
        keep[i] = z * z + e * e - 1e-12 * dd <= u2[i]
        return keep

    def query(self, points, near=None) -> ClosestPoints:
        """Closest points on the mesh to (k, 3) points (mm); exact.

        The side uses the pseudo-normal of the closest feature: the face normal in a face
        interior, the sum of the two face normals on an edge, the angle-weighted vertex
        normal at a vertex — so points near edges and vertices get the right sign.

        ``near`` (optional, (k, 3) mm): guesses of the closest points (e.g. the contact
        points under ball centres); they only make the search faster — the result is the
        same bit for bit, ties included (see :func:`_nearest`).
        """
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        if k == 0:
            z = np.zeros(0)
            return ClosestPoints(z, np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 3)),
                                 np.zeros(0, np.int8), z)
        if near is not None:
            near = np.ascontiguousarray(np.asarray(near, dtype=np.float64).reshape(-1, 3))
            if near.shape != P.shape:
                raise ValueError(f"MeshDistance.query: near must give one guess per point, "
                                 f"got {len(near)} for {k} points")
        _, face = _nearest(self.tree, P, self._d2, fastfn=self._fast_d2, near=near,
                           keepfn=self._lb_keep)
        q, d2, feat, bary = closest_on_triangles(P, self._A[face], self._B[face], self._C[face])
        mesh = self.mesh
        fn = mesh.face_normals
        pn = fn[face].copy()
        on_edge = (feat >= 1) & (feat <= 3)
        if np.any(on_edge):
            e = mesh.face_edges[face[on_edge], feat[on_edge] - 1]
            ef = mesh.edge_faces[e]
            n2 = np.where((ef[:, 1] >= 0)[:, None], fn[np.maximum(ef[:, 1], 0)], 0.0)
            pn[on_edge] = fn[ef[:, 0]] + n2
        on_vert = feat >= 4
        if np.any(on_vert):
            v = mesh.F[face[on_vert], feat[on_vert] - 4]
            pn[on_vert] = mesh.vertex_normals[v]
        sign = np.sign(_dot(P - q, pn))
        return ClosestPoints(np.sqrt(d2), q, face, bary, feat, sign)


def closest_points(mesh: TriMesh, points) -> ClosestPoints:
    """Exact closest points on ``mesh`` to (k, 3) ``points`` (see :class:`MeshDistance`)."""
    return MeshDistance(mesh).query(points)


class NearestFaces:
    """Exact closest points on a :class:`TriMesh` without a whole-mesh tree: k-d trees of
    the face centroids, one per circumradius size class (half an octave each; built on the
    first query, a fraction of a second per million faces), give each point an upper bound u
    (the exact distance to the nearest of the faces of the nearest centroid of each class);
    each class lists the faces whose centroid lies within u + the class's largest
    circumradius (not the mesh's: a few long slivers no longer widen every search), and a face
    is tested exactly only if its lower bounds — centroid distance − circumradius, distance
    to its longest edge − the height of the opposite vertex (tight on thin faces) — do not
    exceed u. For the generator's few, clustered queries (links between passes, the spiral
    blend, the passes' contacts in the orient stage) this costs far less than
    :class:`MeshDistance`'s bounding-volume tree, and it returns the same distances and
    points: the minimum of the same exact point–triangle distances. Of faces at exactly the same
    distance (a point on a shared edge or vertex) the lowest face id wins: a rule of the mesh
    alone. (It used to be "the face last in :class:`MeshDistance`'s leaf order", which needed
    that tree's whole median-split chain, about 1 s per million faces, for every plan with a
    tie; the distances, points and smooth normals are the same either way (to rounding), only
    the face id of a point on an edge can differ, and with it the face whose curvature the
    local-gouge check reads.)

    Parameters
    ----------
    mesh : TriMesh
    """

    def __init__(self, mesh: TriMesh):
        self.mesh = mesh
        self._trees = None

    def _build(self):
        V, F = self.mesh.V, self.mesh.F
        A, B, C = V[F[:, 0]], V[F[:, 1]], V[F[:, 2]]
        self._A, self._B, self._C = A, B, C
        # ((a + b) + c) / 3: the very operations of V[F].mean(axis=1) (a reduction over the
        # middle axis adds the rows in order, then divides by the count), a third the time
        cen = (A + B + C) / 3.0
        rad2 = np.maximum(np.maximum(_dot(A - cen, A - cen), _dot(B - cen, B - cen)),
                          _dot(C - cen, C - cen))
        rad = np.sqrt(rad2) * (1.0 + 1e-12)
        self._cen, self._rad = cen, rad
        self._scale = float(np.abs(V).max()) if len(V) else 1.0  # for the capsules' pad
        # size classes: circumradius in (rmax / 2^((c+1)/n), rmax / 2^(c/n)], n per octave,
        # the last class everything smaller; one centroid tree per class, searched with
        # u + the largest circumradius of that class
        n = len(F)
        rmax = float(rad.max()) if n else 0.0
        with np.errstate(divide="ignore", invalid="ignore"):
            cls = np.floor(_NF_PER_OCTAVE * np.log2(rmax / rad))
        cls = np.clip(np.nan_to_num(cls, nan=0.0), 0, _NF_CLASSES - 1).astype(np.int64)
        self._trees = []
        for c in range(_NF_CLASSES):
            ids = np.flatnonzero(cls == c)
            if len(ids):
                kd = cKDTree(cen[ids], balanced_tree=False, compact_nodes=False)
                self._trees.append((ids, float(rad[ids].max()), kd))

    def query(self, points):
        """(point (k, 3), face (k,), bary (k, 3)) — exact closest points to (k, 3) points."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        if k == 0 or self.mesh.n_faces == 0:
            return np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros((0, 3))
        if self._trees is None:
            self._build()
        A, B, C = self._A, self._B, self._C
        # the upper bound u: the nearest of the faces of the nearest centroid of each class
        j = np.concatenate([ids[kd.query(P)[1]] for ids, _, kd in self._trees])
        qj = np.tile(np.arange(k), len(self._trees))
        u = np.full(k, np.inf)
        np.minimum.at(u, qj, closest_on_triangles(P[qj], A[j], B[j], C[j])[1])
        u = np.sqrt(u)
        # every face within u of p has its centroid within u + its circumradius ≤ u + the
        # largest circumradius of its class
        slack = 1e-9 * max(1.0, float(np.abs(P).max()))
        qi, f = [], []
        for ids, rc, kd in self._trees:
            lists = kd.query_ball_point(P, u + rc + slack, return_sorted=False)
            cnt = np.fromiter(map(len, lists), dtype=np.int64, count=k)
            qi.append(np.repeat(np.arange(k), cnt))
            f.append(ids[np.fromiter(itertools.chain.from_iterable(lists), dtype=np.int64,
                                     count=int(cnt.sum()))])
        qi, f = np.concatenate(qi), np.concatenate(f)
        # lower bounds: centroid distance − circumradius, then the distance to the face's
        # longest-edge capsule (:func:`_edge_capsules`, tight on thin faces); a face whose
        # bound exceeds u + slack is farther than the best
        pq = P[qi]
        ub = u[qi] + slack
        d = pq - self._cen[f]
        keep = np.sqrt(_dot(d, d)) - self._rad[f] <= ub
        pq, ub, qi, f = pq[keep], ub[keep], qi[keep], f[keep]
        a, b, c = A[f], B[f], C[f]
        keep = _capsule_distance(pq, _edge_capsules(a, b, c, self._scale)) <= ub
        qi, f = qi[keep], f[keep]
        q, d2, _, bary = closest_on_triangles(pq[keep], a[keep], b[keep], c[keep])
        best = np.full(k, np.inf)
        np.minimum.at(best, qi, d2)
        win = d2 <= best[qi]
        qw, fw = qi[win], f[win]
        face = np.full(k, np.iinfo(np.int64).max, dtype=np.int64)
        np.minimum.at(face, qw, fw)  # of faces at exactly the best distance, the lowest id
        face[face == np.iinfo(np.int64).max] = -1
        # each (point, face) pair is listed once (a face is in one class): the winner's row
        # of the exact kernel is the closest point (row-wise, the same as computed alone)
        row = np.flatnonzero(f == face[qi])
        if len(row) == k:
            row = row[np.argsort(qi[row], kind="stable")]
            return q[row], face, bary[row]
        q, _, _, bary = closest_on_triangles(P, A[face], B[face], C[face])  # NaN points
        return q, face, bary
