"""The volume swept by a ball along pass polylines: exact distances to the
swept spheres (capsules of the centre polylines), the nearest pass and the
height of the swept surface along a direction. mm.
"""

from __future__ import annotations

import numpy as np

from ..geometry.bvh import ClusterTree, group_argmin, nearest, run_clusters, within
from ..geometry.closest import ray_capsules_first_hit, segment_offsets
from ..geometry.vectors import dot
from ..kernels import swept_ball as compiled_ball
from ..runtime import workers
from ..toolpath.types import PassCurve

__all__ = ["SweptBall"]


# ================================================================== swept cutters
def _curve_polyline(c: PassCurve, pts):
    """Segments (a, b) of a pass polyline; closed passes include the closing move."""
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 3)
    if len(pts) == 1:
        return pts, pts
    if c.closed and len(pts) > 2:
        return pts, np.concatenate([pts[1:], pts[:1]])  # (np.roll's values, faster)
    return pts[:-1], pts[1:]


class SweptBall:
    """The volume swept by a ball of ``radius`` along centre polylines: a union of capsules.

    ``distance(points)`` is the signed distance to that volume's boundary,
    ``min over segments dist(p, segment) − radius`` (mm; > 0 outside = material left at a
    surface point, < 0 inside = gouge). This is the pluggable "distance from a point to the
    swept cutter" of :func:`verify_path`; other cutter shapes provide the same methods.

    Parameters
    ----------
    a, b : (S, 3) float, mm — centre segments
    radius : float, mm
    owner : (S,) int — an id per segment (e.g. the curve index), reported by ``nearest``
    leaf_size : int or None — consecutive segments per tree leaf; None: a run of about ρ/3
        (2 mm for ρ = 6; 2 to 8 segments of the median length). Points on the surface are
        ~ρ from the centres and only the centres within ~1 mm along the pass matter; a
        leaf's cylinder around a curved run of 8 × 0.74 mm let 7 leaves (53 segments) per
        point through on Rotor 37, 3 × 0.74 mm let 8 segments through (1.2 are within
        reach): 30 % faster; with 0.52 mm moves 4 segments are fastest
    """

    def __init__(self, a, b, radius: float, owner=None, *, leaf_size: int | None = None):
        self.a = np.ascontiguousarray(a, dtype=np.float64).reshape(-1, 3)
        self.b = np.ascontiguousarray(b, dtype=np.float64).reshape(-1, 3)
        self.radius = float(radius)
        S = len(self.a)
        self.owner = (np.zeros(S, np.int64) if owner is None
                      else np.asarray(owner, dtype=np.int64))
        self._tree = None
        self._leaf_size = leaf_size
        self._d = self.b - self.a
        dd = dot(self._d, self._d)
        self._dd = np.where(dd > 0, dd, 1.0)
        # the compiled kernels' tree when they run (the numpy tree is then built only if asked)
        self._ctree = compiled_ball.segment_tree(self.a, self.b, self._d, self._dd) if S else None
        if S and self._ctree is None:
            self._build_tree()

    def _build_tree(self):
        S = len(self.a)
        # leaves = runs of consecutive segments of one polyline (thin bounding cylinders);
        # segments are given polyline by polyline, a new owner starts a new run
        breaks = np.nonzero(np.diff(self.owner) != 0)[0] + 1
        jump = np.nonzero(np.any(self.a[1:] != self.b[:-1], axis=1))[0] + 1
        leaf_size = self._leaf_size
        if leaf_size is None:
            seg = float(np.median(np.sqrt(dot(self._d, self._d))))
            leaf_size = 8 if not seg > 0 else int(np.clip(round(self.radius / (3.0 * seg)),
                                                          2, 8))
        clusters = run_clusters(np.union1d(breaks, jump), S, int(leaf_size))
        self._tree = ClusterTree(np.stack([self.a, self.b], axis=1), flat=False,
                                 clusters=clusters)

    @property
    def tree(self):
        """The numpy bounding-volume tree of the segments (None without segments; built on
        first use when the compiled kernels run)."""
        if self._tree is None and len(self.a):
            self._build_tree()
        return self._tree

    @classmethod
    def from_curves(cls, curves, radius: float, owners=None):
        """Swept ball of passes whose centres are ``tip + radius · axis`` (the tool as posed).

        ``owners`` (one int per curve, default the curve index) label the segments."""
        aa, bb, oo = [], [], []
        for i, c in enumerate(curves):
            cen = np.asarray(c.tip, float) + radius * np.asarray(c.axis, float)
            a, b = _curve_polyline(c, cen)
            aa.append(a)
            bb.append(b)
            oo.append(np.full(len(a), i if owners is None else owners[i], dtype=np.int64))
        if not aa:
            return cls(np.zeros((0, 3)), np.zeros((0, 3)), radius)
        return cls(np.vstack(aa), np.vstack(bb), radius, np.concatenate(oo))

    def _d2(self, P, qi, sg):
        """Squared distances from P[qi] to segments sg: :func:`.closest.segment_offsets`,
        the arithmetic of :func:`.closest.closest_on_segments` (the same bits), with b − a and
        |b − a|² taken once per segment instead of once per pair."""
        e = segment_offsets(P[qi], self.a[sg], self._d[sg], self._dd[sg])[1]
        return dot(e, e)

    def nearest(self, points, near=None):
        """Signed distance to the swept volume (k,) and the nearest segment (k,) (exact).

        ``near`` (optional, (k, 3) mm): guesses of the ball centres nearest to the points
        (e.g. a surface point + radius · its normal); they only make the search faster, the
        result is the same bit for bit (see :func:`..geometry.bvh.nearest`)."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        if len(self.a) == 0:
            return np.full(len(P), np.inf), np.full(len(P), -1, dtype=np.int64)
        if self._ctree is not None:
            d2, seg = compiled_ball.nearest_segments(self._ctree, P, workers())
            return np.sqrt(d2) - self.radius, seg
        if near is not None:
            near = np.ascontiguousarray(np.asarray(near, dtype=np.float64).reshape(-1, 3))
        d2, seg = nearest(self.tree, P, self._d2, near=near)
        return np.sqrt(d2) - self.radius, seg

    def distance(self, points, near=None):
        """(k,) signed distance (mm) from points to the swept volume (> 0 outside);
        ``near`` as in :meth:`nearest`."""
        return self.nearest(points, near)[0]

    def near(self, points, margin, guess=None):
        """The segments near (k, 3) ``points``, for distances at points that move a little
        (the iterates of a root search): see :class:`_NearSegments`. ``margin`` (k,) or
        float, mm — how far the points may move before a full query is needed; ``guess``
        as ``near`` in :meth:`nearest`."""
        return _NearSegments(self, points, margin, guess)

    def height_along(self, points, directions, max_height):
        """Distance along unit ``directions`` from ``points`` (outside the volume) to the first
        hit of the swept volume, (k,) mm; ``inf`` where there is none within ``max_height``."""
        P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        N = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        out = np.full(len(P), np.inf)
        if len(self.a) == 0 or len(P) == 0:
            return out
        hmax = np.broadcast_to(np.asarray(max_height, float), (len(P),))
        # a hit at height t lies on a capsule whose segment is within ρ + t of the point (the
        # first hit is the least over every listed segment: a longer list gives the same)
        if self._ctree is not None:  # the same walk and arithmetic, compiled
            return compiled_ball.first_hits(self._ctree, P, N, self.radius, hmax, workers())
        qi, sg = within(self.tree, P, self.radius + hmax)
        if len(qi):
            t = ray_capsules_first_hit(P[qi], N[qi], self.a[sg], self.b[sg], self.radius)
            np.minimum.at(out, qi, t)
        out[out > hmax] = np.inf
        return out


class _NearSegments:
    """The segments of a :class:`SweptBall` that can be nearest to points within a margin
    of base points x (k, 3): for each x, every segment whose tree bounds come within
    R = u (1 + 1e-9) + margin of it, u the distance to the segments whose centroids are
    nearest to x (or to its ``guess``; an upper bound of the distance to the centre
    polylines), so the list holds every segment within R of x.

    :meth:`distance` at points y (k, 3), row i near x_i, takes the minimum of the same
    squared point–segment distances (:meth:`SweptBall._d2`) over row i's segments only. A
    segment not listed is farther than R − |y − x| from y (the distance is 1-Lipschitz), so
    where that minimum's distance is below R − |y − x| (less a rounding pad) it is the
    minimum over every segment — the very float :meth:`SweptBall.distance` returns (a minimum
    does not depend on which larger values are also compared); the other rows are measured
    by :meth:`SweptBall.distance` itself. At y = x the list always decides."""

    def __init__(self, ball: SweptBall, points, margin, guess=None):
        self.ball = ball
        self.base = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(self.base)
        self.qi = self.sg = np.zeros(0, dtype=np.int64)
        self.R = np.zeros(k)
        self.guess = None if guess is None else np.ascontiguousarray(
            np.asarray(guess, dtype=np.float64).reshape(-1, 3))
        if ball._ctree is not None or k == 0:  # compiled: every query is a full one
            return
        tree = ball.tree
        if tree is None:
            return
        _, j = tree.kd.query(self.base if self.guess is None else self.guess, k=tree.kd_k)
        pr = np.asarray(j, dtype=np.int64).reshape(-1)
        qi = np.repeat(np.arange(k), tree.kd_k)
        u2, _ = group_argmin(k, qi, ball._d2(self.base, qi, pr), pr)
        self.R = np.sqrt(u2) * (1.0 + 1e-9) + np.broadcast_to(np.asarray(margin, float), (k,))
        self.qi, self.sg = within(tree, self.base, self.R)

    def distance(self, points):
        """(k,) signed distances (mm) of points y (row i near base point i) to the swept
        volume, bit for bit those of :meth:`SweptBall.distance`."""
        Y = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        ball = self.ball
        k = len(Y)
        if len(ball.a) == 0 or k == 0:
            return np.full(k, np.inf)
        if ball._ctree is not None:
            return ball.distance(Y)
        d2 = np.full(k, np.inf)
        if len(self.qi):
            np.minimum.at(d2, self.qi, ball._d2(Y, self.qi, self.sg))
        e = Y - self.base
        reach = self.R - np.sqrt(dot(e, e))
        # rounding of the distances and of the move: far below the pad
        ok = np.sqrt(d2) <= reach * (1.0 - 1e-12) - 1e-12 * (1.0 + self.R)
        out = np.sqrt(d2) - ball.radius
        if not np.all(ok):
            out[~ok] = ball.distance(Y[~ok], None if self.guess is None else self.guess[~ok])
        return out
