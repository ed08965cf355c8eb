"""Volumes swept by a cutter along pass polylines, for :mod:`.verify`.

For a ball of radius ρ the swept volume is a union of capsules around the centre polyline;
the *material left* at a surface point p is the signed distance from p to that volume,
``min_seg dist(p, seg) − ρ`` (> 0: material left, < 0: gouge, in mm). Other cutters
(:class:`SweptCutter`, DIN 66215 profiles) sweep their posed profile between the poses, the
axis turning on the great arc. :func:`swept_cutter` picks the right one.

The swept volume assumes the ball centre moves on straight lines between poses (linear
interpolation in the part frame); a ball is symmetric, so its axis does not matter.

Units are mm; numpy/scipy only (no bpy).
"""

from __future__ import annotations

import threading

import numpy as np
from scipy.spatial import cKDTree

from ..errors import BliskCamError, ToleranceError
from ..geometry.bvh import CHUNK, GROUP_MIN, ClusterTree, group_argmin, query_groups, run_clusters
from ..geometry.vectors import dot, rotate, slerp
from ..kernels import knn as compiled_knn
from ..kernels import swept_cutter as compiled_cutter
from ..runtime import map_chunks, map_tasks, workers
from ..tool.cutter import as_cutter
from .sweep_ball import SweptBall, _curve_polyline

#: serialises the first builds of the "fast" trees (:attr:`SweptCutter.tree`)
_TREE_LOCK = threading.Lock()

__all__ = ["SWEEP_METHODS", "SweepError", "SweptCutter", "searched_once", "swept_cutter"]


_GOLD = 0.5 * (np.sqrt(5.0) - 1.0)


def _golden_step(f, lo, hi, x1, x2, f1, f2):
    """One golden-section step on brackets [lo, hi] (arrays) with interior points
    x1 < x2 and their values f1, f2: the bracket keeps the side of the smaller value and
    one new point is evaluated (``f`` on an array). Returns (lo, hi, x1, x2, f1, f2)."""
    left = f1 < f2  # the minimum is in [lo, x2]
    hi = np.where(left, x2, hi)
    lo = np.where(left, lo, x1)
    nx = np.where(left, hi - _GOLD * (hi - lo), lo + _GOLD * (hi - lo))
    fn = f(nx)
    return (lo, hi, np.where(left, nx, x2), np.where(left, x1, nx), np.where(left, fn, f2),
            np.where(left, f1, fn))

#: boxes per leaf of the compiled candidates, along the tool (:meth:`SweptCutter._leaf_box_arrays`)
BOX_PIECES = 4

#: how :class:`SweptCutter` finds the minimum over each move (see its docstring)
SWEEP_METHODS = ("fast", "exact")


class SweepError(BliskCamError):
    """A path cannot be swept: non-finite poses, zero axes, or an axis reversed between two
    consecutive poses."""


class SweptCutter:
    """The volume swept by any :class:`~..tool.cutter.Cutter` along pose polylines.

    Between two consecutive poses the tip moves on a straight line and the axis turns on the
    great arc (slerp) at a uniform rate — the machine's motion to first order. ``distance``
    is the signed distance from points to the swept volume, ``min over segments and t of
    cutter.signed_distance(p, tip(t), axis(t))`` (mm; > 0 outside = material left, < 0 gouge),
    computed from the cutter's exact shape. Both methods start alike:

    * candidates — segments whose bounds (the hull of the posed axes from the tip to the flute
      length, widened by the cutter's largest radius) come within the upper bound u given by
      the poses nearest to the point;
    * motion bound — in the tool frame of pose a (the rotation R(t) about k = a_a × a_b by
      t φ takes the axis along the arc), a point P moves on p(t) = R(t)ᵀ (P − tip(t)) with
      |p′| ≤ D = |Δtip| + φ |P − tip|max and |p″| ≤ φ² |P − tip|max + 2 φ |Δtip|; the signed
      distance is 1-Lipschitz in the point, so with the values v₀, v₁ at the two poses the
      minimum over the segment is ≥ (v₀ + v₁ − D)/2 (segments above u are done).

    Then, ``method``:

    * ``"exact"`` — ``nsub`` + 1 samples of t, then golden-section search around the best
      sample (``iters`` steps shrink the bracket to 2/nsub · 0.618^iters of the segment);
      every segment that passes the motion bound is searched. Slow (10–20 × a ball); kept as
      the reference the fast method is tested against.
    * ``"fast"`` (default) — tighter candidates, more pruning, then one bracketed search per
      surviving segment:

      0. candidates — u is the distance to the poses whose corner-centre circle (radius e
         at height f) passes nearest the point (a k-d tree of 16 points per circle); two
         trees over runs of consecutive segments bound the cutter's side (the cylinder of
         radius max_radius about the axis from f to h) and its bottom (the discs of radius e
         at height f, widened by R_b; see :meth:`_fast_trees`) — with :class:`ClusterTree`
         ``discs`` the bounds below the tips reach radius · sin∠(node axis, tool axis), not
         the radius. The poses of a run are evaluated once for both segments they end;
      1. the cutter lies in the slab 0 ≤ z ≤ h of its frame, so sd ≥ −z and sd ≥ z − h for
         any point (inside too); along the move p(t) leaves the chord c(t) from p(0) to p(1)
         by at most ε = |p″|max / 8, hence sd ≥ −max(z₀, z₁) − ε on the whole segment (z₀, z₁
         the point's heights above the tip at the two poses: no distance evaluation needed);
      2. the motion bound above with the exact pose values;
      3. convexity: the cutter is convex, so g(t) = sd(c(t)) (the point moving on the straight
         chord, tool frame of pose a) is convex in t, and f(t) ≥ g(t) − ε. The secants from
         each end over δ = 1e-6 give lines below g (a convex function lies above its secant
         lines extended beyond their chord): g(t) ≥ max(v₀ + t s₀, v₁ + (1 − t) s₁) (up to
         2 δ |c′| on the first and last δ). Where that lower bound minus ε exceeds u, f cannot
         beat u: this leaves a closed-form bracket [t_lo, t_hi] per segment, empty for most
         segments (monotone along the move, e.g. the poses behind and ahead of the contact);
      4. golden-section search of f on the bracket until its width in motion, (t_hi − t_lo) D,
         is below ``xtol`` mm (each step drops segments whose best value minus the bracket's
         motion is above the point's current best). f is evaluated from six scalars per
         (point, segment): no vectors per step.

      Steps 0–3 are rigorous bounds; step 4 finds the minimum of f in the bracket to ``xtol``
      where f is unimodal there. f differs from the convex g by at most ε = (φ² |P − tip| +
      2 φ |Δtip|)/8 (µm to tens of µm for real moves), which is assumed not to create a
      second local minimum inside the bracket — the exact method assumes the same around its
      best sample. Measured agreement with ``"exact"`` (tests/core/test_verify.py,
      bench/bench_verify.py): ≤ 1e-11 mm for bull-nose and tapered ball, ≤ 1e-8 mm for a flat
      end mill outside the cutter and ≤ 6e-7 mm inside it (at the creases of the inside
      distance either search may stop a little off the minimum).

    Parameters
    ----------
    cutter : Cutter
    tip_a, axis_a, tip_b, axis_b : (S, 3) float — segment end poses (mm, unit axes)
    owner : (S,) int — an id per segment, reported by ``nearest``
    method : "fast" | "exact"
    nsub, iters : int — samples per segment and golden-section steps ("exact")
    xtol : float, mm — final bracket width in motion of the search ("fast"); bounds the error
        of the minimum by xtol at a kink of f and by far less at a smooth minimum
    """

    def __init__(self, cutter, tip_a, axis_a, tip_b, axis_b, owner=None, *, method: str = "fast",
                 nsub: int = 4, iters: int = 24, xtol: float = 1e-5, leaf_size: int = 4):
        m = str(method).strip().lower()
        if m not in SWEEP_METHODS:
            raise ToleranceError(f"swept-cutter method must be one of {', '.join(SWEEP_METHODS)}; "
                                 f"got {method!r}")
        xtol = float(xtol)
        if not (np.isfinite(xtol) and xtol > 0):
            raise ToleranceError(f"swept-cutter xtol must be a positive number of mm, got {xtol}")
        self.method, self.xtol = m, xtol
        self.cutter = cutter
        f64 = np.float64
        self.ta = np.ascontiguousarray(tip_a, dtype=f64).reshape(-1, 3)
        self.tb = np.ascontiguousarray(tip_b, dtype=f64).reshape(-1, 3)
        self.aa = np.ascontiguousarray(axis_a, dtype=f64).reshape(-1, 3)
        self.ab = np.ascontiguousarray(axis_b, dtype=f64).reshape(-1, 3)
        with np.errstate(divide="ignore", invalid="ignore"):
            self.aa = self.aa / np.linalg.norm(self.aa, axis=1)[:, None]
            self.ab = self.ab / np.linalg.norm(self.ab, axis=1)[:, None]
        bad = ~np.all(np.isfinite(np.hstack([self.ta, self.tb, self.aa, self.ab])), axis=1)
        if np.any(bad):
            raise SweepError(f"{int(bad.sum())} move(s) have a non-finite tip or a zero/non-finite "
                             f"tool axis (first: move {int(np.argmax(bad))}); give finite tips "
                             "and non-zero axes for every pose")
        S = len(self.ta)
        self.owner = (np.zeros(S, np.int64) if owner is None
                      else np.asarray(owner, dtype=np.int64))
        self.nsub, self.iters = max(int(nsub), 2), max(int(iters), 0)
        # the turn of the axis, accurate for small angles too (arccos is not)
        kx = np.cross(self.aa, self.ab)
        kn = np.linalg.norm(kx, axis=1)
        self.phi = np.arctan2(kn, dot(self.aa, self.ab)) if S else np.zeros(0)
        flip = self.phi > np.pi - 1e-6
        if np.any(flip):
            raise SweepError(f"{int(flip.sum())} move(s) turn the tool axis by 180° between two "
                             f"poses (first: move {int(np.argmax(flip))}): the turn is undefined; "
                             "check the axes' direction (tip → spindle) along the pass")
        self.dtip = np.linalg.norm(self.tb - self.ta, axis=1)
        # fast method: unit rotation axis k (0 where the axis does not turn), b = k × a_a (so the
        # axis at t is a_a cos tφ + b sin tφ, the slerp), and where the chord bound is usable
        self._k = kx / np.where(kn > 0, kn, 1.0)[:, None]
        self._b = np.cross(self._k, self.aa)
        self._chord_ok = self.phi < 0.5 * np.pi
        h = cutter.h
        # the slerped axis leaves the chord of the two axes by at most 1 − cos(φ/2): the axis
        # segments of the poses in between lie within ``bulge`` of the hull of the end ones
        self.bulge = h * float(np.max(1.0 - np.cos(0.5 * self.phi), initial=0.0)) * (
            1.0 + 1e-9) + 1e-9
        rmax = cutter.max_radius * (1.0 + 1e-9) + 1e-9
        self.inflate = rmax + self.bulge  # "exact": candidates within u + inflate of the hulls
        self._tree_s = None
        self._fast_args = None  # the "fast" trees' inputs until they are built
        scale = max(float(np.max(np.abs(self.ta), initial=0.0)), h, 1.0)
        self._slack = 1e-12 * scale  # rounding allowance in the bounds, mm
        if S:
            breaks = np.nonzero(np.diff(self.owner) != 0)[0] + 1
            jump = np.nonzero(np.any(self.ta[1:] != self.tb[:-1], axis=1))[0] + 1
            clusters = run_clusters(np.union1d(breaks, jump), S, leaf_size)
            if m == "fast":
                self._fast_trees(clusters, rmax)
            else:
                corners = np.stack([self.ta, self.tb, self.ta + h * self.aa,
                                    self.tb + h * self.ab], 1)
                self._tree_s = ClusterTree(corners, flat=False, clusters=clusters)
            self._ring_points()

    def _fast_trees(self, clusters, rmax):
        """The two bounding-volume trees of the "fast" method, over the same clusters (runs
        of ≤ B consecutive segments of one pass; ``_ls`` (NC, B)).

        The cutter (tool frame, tip at the origin, axis z) lies in the union of

        * the **side**: the solid cylinder of radius ``max_radius`` for f ≤ z ≤ h
          (``self.tree``; node bounds hold the cylinder about each axis segment from f to h);
        * the **bottom**: the points within ``R_b = max(f, r / cos β)`` of the disc of radius
          e at height f (``self._tree_b``; the node bounds hold those discs, as flat pucks
          along the mean axis). Below z = f the profile region is the convex hull of the tip
          (0, 0) (distance f from the disc), the corner arc (r from the disc's rim, inside
          its sector) and the side line's point at z = f (r / cos β from the rim), so every
          point of it is within R_b of the disc.

        A segment can come within u of a point only if the point is within u + bulge of its
        side bound or within u + R_b + bulge of its bottom bound. Below and beside a bull nose
        the bottom bound is the torus' own distance (a pose's disc ⊕ R_b), where the one
        cylinder of radius max_radius from the tip to h, bounded over a run of poses, was
        loose by the run's length across the axis: on Rotor 37 (bull R6 r2, lead 10°, tilt
        5°) the candidate segments per surface sample drop from ~780 to ~200."""
        self._fast_args = (clusters, rmax)
        self._rb = _bottom_reach(self.cutter) * (1.0 + 1e-9) + 1e-9
        self._leaf_tables(clusters)

    @property
    def has_tree(self) -> bool:
        """Whether the volume has segments (its trees exist or are built on first use)."""
        return self._tree_s is not None or self._fast_args is not None

    @property
    def tree(self):
        """The side tree (:meth:`_fast_trees`; the "exact" method's hull tree), None without
        segments. The "fast" trees are built on first use: the compiled candidates walk boxes
        of their own (:meth:`_leaf_box_arrays`), so with the compiled kernels they are never
        built (46 per-level pairs took 1.3 s of Rotor 37's bull-nose verify)."""
        if self._tree_s is None and self._fast_args is not None:
            with _TREE_LOCK:  # the chunks' threads ask together
                if self._tree_s is None:
                    self._build_fast_trees(*self._fast_args)
        return self._tree_s

    def _build_fast_trees(self, clusters, rmax):
        """:meth:`_fast_trees`' two trees and their leaves' clusters."""
        cut = self.cutter
        f, h = cut.f, cut.h
        ax2 = np.stack([self.aa, self.ab], 1)
        cf_a, cf_b = self.ta + f * self.aa, self.tb + f * self.ab
        side = np.stack([cf_a, cf_b, self.ta + h * self.aa, self.tb + h * self.ab], 1)
        tree = ClusterTree(side, flat=False, clusters=clusters, discs=(ax2, self.phi, rmax))
        erad = cut.e * (1.0 + 1e-9) + 1e-9
        self._tree_b = ClusterTree(np.stack([cf_a, cf_b], 1), flat=False, clusters=clusters,
                                   discs=(ax2, self.phi, erad), disc_axis=True)
        # cluster id of each tree's leaf rows (a leaf holds one cluster; its first present
        # segment names it)
        cl_of = np.full(len(self.ta), -1, dtype=np.int64)
        ok = clusters >= 0
        cl_of[clusters[ok]] = np.nonzero(ok)[0]
        for tr, name in ((tree, "_cl_s"), (self._tree_b, "_cl_b")):
            pr = tr.prims
            first = pr[np.arange(len(pr)), np.argmax(pr >= 0, axis=1)]
            setattr(self, name, np.where(first >= 0, cl_of[np.maximum(first, 0)], -1))
        self._tree_s = tree

    def _candidate_clusters(self, Pc, u):
        """(query, cluster) pairs whose side or bottom bound comes within u (k,) of the
        points (each pair once, sorted by query)."""
        sl = self._slack
        r = np.maximum(u + self.bulge + sl, 0.0)
        # both trees walk the same groups of neighbouring points (median splits, once)
        groups = query_groups(Pc) if len(Pc) >= GROUP_MIN else None
        q1, l1 = self.tree.leaf_pairs(Pc, r * r, groups)
        r = np.maximum(u + self._rb + self.bulge + sl, 0.0)
        q2, l2 = self._tree_b.leaf_pairs(Pc, r * r, groups)
        nc = len(self._ls)
        q = np.concatenate([q1, q2])
        cl = np.concatenate([np.take(self._cl_s, l1), np.take(self._cl_b, l2)])
        ok = cl >= 0  # empty leaves (padding of the complete tree) name no cluster
        key = q[ok] * nc + cl[ok]
        if len(Pc) * nc < 2**31:  # the same keys sorted as int32: faster
            key = key.astype(np.int32)
        key = np.unique(key).astype(np.int64)
        return key // nc, key % nc

    def _ring_points(self):
        """A k-d tree of points on the corner-centre circle (radius e at height f) of every
        segment's first pose: the poses whose circle passes nearest a point give it a tight
        first upper bound (a bull nose or flat end mill touches with its rim, not near its
        axis)."""
        cut = self.cutter
        M = 16 if cut.e > 0 else 1
        a = self.aa
        ref = np.where((np.abs(a[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        u1 = np.cross(a, ref)
        u1 /= np.linalg.norm(u1, axis=1)[:, None]
        u2 = np.cross(a, u1)
        psi = 2.0 * np.pi * np.arange(M) / M
        ring = (np.cos(psi)[None, :, None] * u1[:, None, :]
                + np.sin(psi)[None, :, None] * u2[:, None, :])
        self._ring_m = M
        self.kd = cKDTree(((self.ta + cut.f * a)[:, None, :] + cut.e * ring).reshape(-1, 3))

    def _leaf_tables(self, clusters):
        """Per cluster (a run of ≤ B consecutive segments of one pass): its B + 1 poses
        (tips ``_lt``, axes ``_la`` (NC, B + 1, 3)), segment ids ``_ls`` (NC, B) (−1 padded;
        padding repeats the last pose) and the segments' φ, |Δtip| (NC, B)."""
        pr = np.asarray(clusters, dtype=np.int64)
        NL = len(pr)
        valid = pr >= 0
        last = np.maximum(pr[np.arange(NL), np.maximum(valid.sum(axis=1) - 1, 0)], 0)
        p = np.where(valid, pr, last[:, None])
        vm = valid[:, :, None]
        self._lt = np.concatenate([np.where(vm, self.ta[p], self.tb[last][:, None]),
                                   self.tb[last][:, None]], axis=1)
        self._la = np.concatenate([np.where(vm, self.aa[p], self.ab[last][:, None]),
                                   self.ab[last][:, None]], axis=1)
        self._ls = pr
        self._lphi = np.where(valid, self.phi[p], 0.0)
        self._ldt = np.where(valid, self.dtip[p], 0.0)

    @classmethod
    def from_curves(cls, cutter, curves, owners=None, **kw):
        """Swept cutter of passes (``tip``, ``axis`` per pose; closed passes include the
        closing move); ``owners`` (one int per curve, default the curve index) label them.
        Keywords go to the constructor (``method``, ``xtol``, ...)."""
        parts = [[], [], [], [], []]
        for i, c in enumerate(curves):
            ta, tb = _curve_polyline(c, c.tip)
            aa, ab = _curve_polyline(c, c.axis)
            for lst, x in zip(parts, (ta, aa, tb, ab), strict=False):
                lst.append(x)
            parts[4].append(np.full(len(ta), i if owners is None else owners[i], dtype=np.int64))
        if not parts[0]:
            z = np.zeros((0, 3))
            return cls(cutter, z, z, z, z, **kw)
        return cls(cutter, *(np.vstack(x) for x in parts[:4]), np.concatenate(parts[4]), **kw)

    def pose(self, seg, t):
        """(tip (k, 3), axis (k, 3)) of segments ``seg`` (k,) at parameters t (k,)."""
        tip = self.ta[seg] + t[:, None] * (self.tb[seg] - self.ta[seg])
        return tip, slerp(self.aa[seg], self.ab[seg], t, weights_first=True)

    def _segment_min(self, P, seg, v0, v1):
        """Minimum over t ∈ [0, 1] of the distance from P (k, 3) to segments ``seg`` (k,)
        (the "exact" method's search)."""
        k, m = len(P), self.nsub
        ta, dt = self.ta[seg], self.tb[seg] - self.ta[seg]
        a0, a1 = self.aa[seg], self.ab[seg]
        phi = self.phi[seg]
        sphi = np.sin(phi)
        small = sphi < 1e-9
        sden = np.where(small, 1.0, sphi)
        sd = self.cutter.signed_distance

        def f(t):
            w0 = np.where(small, 1.0 - t, np.sin((1.0 - t) * phi) / sden)
            w1 = np.where(small, t, np.sin(t * phi) / sden)
            ax = w0[:, None] * a0 + w1[:, None] * a1
            ax /= np.sqrt(np.einsum("ij,ij->i", ax, ax))[:, None]
            return sd(P, ta + t[:, None] * dt, ax)

        vals = np.empty((k, m + 1))
        vals[:, 0], vals[:, m] = v0, v1
        for j in range(1, m):
            vals[:, j] = f(np.full(k, j / m))
        jb = np.argmin(vals, axis=1)
        best = vals[np.arange(k), jb]
        lo = np.maximum(jb - 1, 0) / m
        hi = np.minimum(jb + 1, m) / m
        x1 = hi - _GOLD * (hi - lo)
        x2 = lo + _GOLD * (hi - lo)
        f1, f2 = f(x1), f(x2)
        for _ in range(self.iters):
            lo, hi, x1, x2, f1, f2 = _golden_step(f, lo, hi, x1, x2, f1, f2)
        return np.minimum(best, np.minimum(f1, f2))

    def _upper_bound(self, Pc):
        """Distances to the poses of the nearest corner centres: (u (k,), segment (k,))."""
        kk = int(min(4, len(self.ta) * self._ring_m))
        j = self._ring_nearest(Pc, kk).reshape(-1) // self._ring_m
        if compiled_cutter.pose_bound_available():  # the same floats, compiled
            return compiled_cutter.pose_bound(self.cutter, Pc, j.reshape(len(Pc), kk), self.ta,
                                              self.aa, workers())
        qi = np.repeat(np.arange(len(Pc)), kk)
        tk = np.take
        d = self.cutter.signed_distance(tk(Pc, qi, axis=0), tk(self.ta, j, axis=0),
                                        tk(self.aa, j, axis=0))
        return group_argmin(len(Pc), qi, d, j)

    def _ring_nearest(self, Pc, kk):
        """(k, kk) int64: the ``kk`` ring points nearest each point (scipy's set; the compiled
        k-d tree answers when it runs, scipy where the kk-th and the next are at the same
        distance, and in the order of distance either way)."""
        if not compiled_knn.available():
            _, j = self.kd.query(Pc, k=kk)
            return np.asarray(j, dtype=np.int64).reshape(len(Pc), kk)
        if getattr(self, "_ckd", None) is None:
            self._ckd = compiled_knn.point_tree(self.kd.data)
        return compiled_knn.nearest_k(
            self._ckd, Pc, kk, np.inf, workers(),
            ties=lambda Q: np.asarray(self.kd.query(Q, k=kk)[1], np.int64).reshape(-1, kk))

    def _exact_chunk(self, Pc):
        """The "exact" method on a chunk of points: (distance (k,), segment (k,))."""
        cut = self.cutter
        kc = len(Pc)
        u, _ = self._upper_bound(Pc)
        r = np.maximum(u + self.inflate, 0.0)
        q, sg = self.tree.pairs(Pc, r * r)
        Pq = Pc[q]
        v0 = cut.signed_distance(Pq, self.ta[sg], self.aa[sg])
        v1 = cut.signed_distance(Pq, self.tb[sg], self.ab[sg])
        vmin = np.minimum(v0, v1)
        u, _ = group_argmin(kc, q, vmin, sg)
        # in the tool frame the point moves by ≤ |Δtip| + φ |p − tip| over the segment
        # (tip linear, axis turning at a uniform rate): the distance is Lipschitz in t
        reach = np.maximum(np.linalg.norm(Pq - self.ta[sg], axis=1),
                           np.linalg.norm(Pq - self.tb[sg], axis=1))
        D = (self.dtip[sg] + self.phi[sg] * reach) * (1.0 + 1e-9) + 1e-12
        lb = 0.5 * (v0 + v1 - D)
        ref = lb < u[q]
        if np.any(ref):
            vmin[ref] = np.minimum(vmin[ref], self._segment_min(Pq[ref], sg[ref], v0[ref],
                                                                v1[ref]))
        return group_argmin(kc, q, vmin, sg)

    def _leaf_box_arrays(self):
        """(lo, hi) (NC · P, 3) mm: per leaf, P = :data:`BOX_PIECES` boxes, piece k of the
        poses' axis segments (tip + z axis for z from k h / P to (k + 1) h / P), widened by the
        cutter's largest radius, the slerp's bulge and a rounding pad: together they hold the
        volume the cutter sweeps along the leaf's moves (for the compiled candidates; one box
        of a whole tilted tool spans its length across the axis too)."""
        h = self.cutter.h
        z = h * np.arange(BOX_PIECES + 1) / BOX_PIECES
        los, his = [], []
        for z0, z1 in zip(z[:-1], z[1:], strict=True):
            pts = np.concatenate([self._lt + z0 * self._la, self._lt + z1 * self._la], axis=1)
            los.append(pts.min(axis=1))
            his.append(pts.max(axis=1))
        scale = max(1.0, float(np.abs(self._lt).max(initial=0.0)) + h)
        pad = (self.cutter.max_radius * (1.0 + 1e-9) + 1e-9 + self.bulge + 2.0 * self._slack
               + 1e-9 * scale)
        return (np.stack(los, 1).reshape(-1, 3) - pad, np.stack(his, 1).reshape(-1, 3) + pad)

    def _compiled_boxes(self):
        """The compiled tree of :meth:`_leaf_box_arrays` (built once)."""
        if getattr(self, "_cboxes", None) is None:
            self._cboxes = compiled_cutter.leaf_boxes(*self._leaf_box_arrays(),
                                                      pieces=BOX_PIECES)
        return self._cboxes

    def _fast_chunk(self, Pc, delta: float = 1e-6):
        """The "fast" method on a chunk of points: (distance (k,), segment (k,)).
        Steps 0–4 of the class docstring."""
        u, arg = self._upper_bound(Pc)
        if compiled_cutter.boxes_available():  # the candidates and steps 1–4 compiled
            k = len(Pc)
            return compiled_cutter.fast_search_boxes(
                self.cutter, self, self._compiled_boxes(), Pc, u, arg, np.full(k, self._slack),
                np.zeros(k, np.int64), np.full(k, len(self._ls), np.int64), self.xtol, delta,
                workers())
        q, leaf = self._candidate_clusters(Pc, u)
        return _fast_search(self, Pc, u, arg, q, leaf, np.full(len(Pc), self._slack),
                            self.xtol, delta)

    def nearest(self, points, chunk: int = CHUNK // 2):
        """Signed distance to the swept volume (k,) and the nearest segment (k,)."""
        P = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        k = len(P)
        if not self.has_tree or k == 0:
            return np.full(k, np.inf), np.full(k, -1, dtype=np.int64)
        # a point asked more than once is searched once (its figures are a function of its
        # coordinates alone; the material samples repeat ~1 in 4)
        return searched_once(P, np.zeros(k, np.int64),
                             lambda Q, _: self._nearest_distinct(Q, chunk))

    def _nearest_distinct(self, P, chunk):
        """:meth:`nearest` of distinct points, chunk by chunk."""
        k = len(P)
        out = np.full(k, np.inf)
        arg = np.full(k, -1, dtype=np.int64)
        run = self._fast_chunk if self.method == "fast" else self._exact_chunk

        def one(s0):
            out[s0 : s0 + chunk], arg[s0 : s0 + chunk] = run(P[s0 : s0 + chunk])

        map_chunks(one, k, chunk)
        return out, arg

    def distance(self, points):
        """(k,) signed distance (mm) from points to the swept volume (> 0 outside)."""
        return self.nearest(points)[0]

    def height_along(self, points, directions, max_height, steps: int = 60):
        """Distance along unit ``directions`` from ``points`` (outside the volume) to the first
        hit of the swept volume, (k,) mm; ``inf`` where there is none within ``max_height``.
        Sphere tracing: the signed distance is 1-Lipschitz, so a step of its value never
        passes the first hit."""
        return _sphere_trace(lambda X, idx: self.distance(X), points, directions, max_height,
                             steps)


def _fast_search(tab, Pc, u, arg, q, leaf, slack, xtol, delta):
    """Steps 1–4 of :class:`SweptCutter`'s "fast" method on a chunk of points ``Pc`` (k, 3):
    (distance (k,), segment (k,)).

    ``tab`` holds the cutter and the segment and cluster tables (``ta``, ``tb``, ``_k``,
    ``_b``, ``_chord_ok`` per segment; ``_lt``, ``_la``, ``_ls``, ``_lphi``, ``_ldt`` per
    cluster): a :class:`SweptCutter`, or a :class:`SweptForest` whose tables hold all its
    members'. ``u``, ``arg`` (k,) are the points' first upper bounds and their segments
    (step 0), ``q``, ``leaf`` the candidate (point, cluster) pairs sorted by point, ``slack``
    (k,) mm the rounding allowance of each point's swept volume, ``xtol`` mm the search's
    final bracket width. Every point's figures depend on its own rows only (its bound, its
    candidates): the same bits whichever points share the chunk."""
    cut = tab.cutter
    kc = len(Pc)
    if compiled_cutter.search_available() and not np.any(q[1:] < q[:-1]):
        return compiled_cutter.fast_search(cut, tab, Pc, u, arg, q, leaf, slack, xtol, delta,
                                           workers())
    # 1. heights above the tips of a leaf's poses (a run of B segments: B + 1 poses),
    # motion bounds: no distance evaluation yet
    # (gathers by np.take on flat indices: the same values as fancy indexing, 2–4x faster)
    tk = np.take
    La = tk(tab._la, leaf, axis=0)  # (n, B + 1, 3) axes
    X = tk(Pc, q, axis=0)[:, None, :] - tk(tab._lt, leaf, axis=0)  # (n, B + 1, 3) point − tip
    zz = np.einsum("npi,npi->np", X, La)
    nn = np.einsum("npi,npi->np", X, X)
    sgm = tk(tab._ls, leaf, axis=0)  # (n, B) segment ids, −1 padded
    B = sgm.shape[1]
    z0, z1, n0, n1 = zz[:, :-1], zz[:, 1:], nn[:, :-1], nn[:, 1:]
    phi, dtip = tk(tab._lphi, leaf, axis=0), tk(tab._ldt, leaf, axis=0)
    reach = np.sqrt(np.maximum(n0, n1))
    eps = ((phi * phi * reach + 2.0 * phi * dtip) * (0.125 * (1.0 + 1e-9))
           + tk(slack, q)[:, None])
    lb = np.maximum(-np.maximum(z0, z1), np.minimum(z0, z1) - cut.h) - eps
    keep = (sgm >= 0) & (lb < tk(u, q)[:, None])
    fi = np.flatnonzero(keep)  # kept (row, j) as row B + j, in np.nonzero's order
    ii = fi // B
    pi = fi + ii  # pose j of row ii in the (n, B + 1) arrays
    q, sg = tk(q, ii), tk(sgm, fi)
    X3, A3 = X.reshape(-1, 3), La.reshape(-1, 3)
    d0, d1 = tk(X3, pi, axis=0), tk(X3, pi + 1, axis=0)
    a0 = tk(A3, pi, axis=0)
    z0, n0 = tk(zz, pi), tk(nn, pi)
    phi, dtip, reach, eps, lb = (tk(x, fi) for x in (phi, dtip, reach, eps, lb))
    # 2. exact values at the two poses; the motion (Lipschitz) bound
    need = np.zeros(zz.shape, bool)  # poses of kept segments, each evaluated once
    need[:, :-1] |= keep
    need[:, 1:] |= keep
    need = np.flatnonzero(need)
    vv = np.full(zz.size, np.inf)
    zn = tk(zz, need)
    vv[need] = cut.signed_distance_rz(np.sqrt(np.maximum(tk(nn, need) - zn * zn, 0.0)), zn)
    v0, v1 = tk(vv, pi), tk(vv, pi + 1)
    vmin = np.minimum(v0, v1)
    u, arg = group_argmin(kc, np.concatenate([np.arange(kc), q]), np.concatenate([u, vmin]),
                           np.concatenate([arg, sg]))
    D = (dtip + phi * reach) * (1.0 + 1e-9) + tk(slack, q)
    lb = np.maximum(lb, 0.5 * (v0 + v1 - D))
    keep = np.nonzero(lb < tk(u, q))[0]
    q, sg, d0, d1, a0, z0, n0, phi, dtip, eps, v0, v1, D = (
        tk(x, keep, axis=0) for x in (q, sg, d0, d1, a0, z0, n0, phi, dtip, eps, v0, v1, D))
    # 3. convexity along the chord (tool frame of pose a): a bracket per segment
    k_ = tk(tab._k, sg, axis=0)
    p1 = rotate(d1, k_, -phi)
    ch = p1 - d0
    g0 = _sd_in_frame(cut, d0 + delta * ch, a0)
    g1 = _sd_in_frame(cut, p1 - delta * ch, a0)
    s0 = (g0 - v0) / delta
    s1 = (g1 - v1) / delta
    U = tk(u, q) + eps + 2.0 * delta * np.sqrt(dot(ch, ch)) + tk(slack, q)
    tlo, thi = _bracket_below(v0, s0, v1, s1, U)
    free = ~tab._chord_ok[sg]
    tlo[free], thi[free] = 0.0, 1.0
    keep = np.nonzero(tlo <= thi)[0]
    if len(keep) == 0:
        return u, arg
    q, sg, d0, a0, z0, n0, phi, D, tlo, thi = (
        tk(x, keep, axis=0) for x in (q, sg, d0, a0, z0, n0, phi, D, tlo, thi))
    # 4. golden-section search of f on the bracket, from six scalars per pair:
    # d(t) = d0 − t Δ, axis(t) = a cos tφ + b sin tφ ⇒ z(t), |d(t)|² in closed form
    dl = tk(tab.tb, sg, axis=0) - tk(tab.ta, sg, axis=0)
    bb = tk(tab._b, sg, axis=0)
    za, zb = z0, dot(d0, bb)
    Ta, Tb = dot(dl, a0), dot(dl, bb)
    m2, L2 = 2.0 * dot(d0, dl), dot(dl, dl)
    best, arg2 = _golden_pairs(cut, q, kc, u, (za, zb, Ta, Tb, n0, m2, L2, phi), D, tlo, thi,
                               xtol)
    improved = best < u
    u = np.where(improved, best, u)
    arg = np.where(improved, sg[np.maximum(arg2, 0)], arg)
    return u, arg


def _sphere_trace(distance, points, directions, max_height, steps: int):
    """Distance along unit ``directions`` (k, 3) from ``points`` (k, 3) to the first zero of
    a 1-Lipschitz signed distance, (k,) mm; ``inf`` where there is none within
    ``max_height`` (scalar or (k,) mm) after ``steps`` steps. ``distance(X, idx)`` gives the
    signed distance (m,) at the points X (m, 3), those of the live rows ``idx`` (m,): each
    step of its value never passes the first hit."""
    P = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    N = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    hmax = np.broadcast_to(np.asarray(max_height, float), (len(P),)).copy()
    t = np.zeros(len(P))
    live = np.ones(len(P), bool)
    for _ in range(steps):
        if not np.any(live):
            break
        idx = np.nonzero(live)[0]
        d = distance(P[idx] + t[idx, None] * N[idx], idx)
        t[idx] += np.maximum(d, 0.0)
        live[idx] = (d > 1e-10) & (t[idx] <= hmax[idx])
    t[(t > hmax) | live] = np.inf
    return t


def _bottom_reach(cutter) -> float:
    """R_b (mm): every point of the cutter below its corner centres' height f lies within
    R_b = max(f, r / cos β) of the disc of radius e at height f (see
    :meth:`SweptCutter._fast_trees`; tests/core/test_geometry.py checks it on the profiles)."""
    return float(max(cutter.f, cutter.r / np.cos(cutter.beta)))


def _sd_in_frame(cutter, x, axis):
    """Signed distance of points ``x`` (m, 3) given relative to the tip of a cutter posed
    along unit ``axis`` (m, 3)."""
    z = dot(x, axis)
    return cutter.signed_distance_rz(np.sqrt(np.maximum(dot(x, x) - z * z, 0.0)), z)


def _bracket_below(v0, s0, v1, s1, U):
    """The interval of t ∈ [0, 1] where max(v0 + t s0, v1 + (1 − t) s1) ≤ U, per row:
    (t_lo, t_hi) (m,), t_lo > t_hi where it is empty."""
    tlo = np.zeros(len(v0))
    thi = np.ones(len(v0))
    with np.errstate(divide="ignore", invalid="ignore"):
        ra = (U - v0) / s0  # v0 + t s0 ≤ U: t ≤ ra for s0 > 0, t ≥ ra for s0 < 0
        rb = 1.0 - (U - v1) / s1  # v1 + (1 − t) s1 ≤ U: t ≥ rb for s1 > 0, t ≤ rb for s1 < 0
    thi = np.where(s0 > 0, np.minimum(thi, ra), thi)
    tlo = np.where(s0 < 0, np.maximum(tlo, ra), tlo)
    tlo = np.where(s1 > 0, np.maximum(tlo, rb), tlo)
    thi = np.where(s1 < 0, np.minimum(thi, rb), thi)
    dead = ((s0 == 0) & (v0 > U)) | ((s1 == 0) & (v1 > U)) | ~np.isfinite(U)
    dead |= np.isnan(tlo) | np.isnan(thi)
    tlo = np.where(dead, 1.0, tlo)
    thi = np.where(dead, 0.0, thi)
    return tlo, thi


def _sorted_group_argmin(k, qs, values, ids):
    """:func:`~..geometry.bvh.group_argmin` for queries ``qs`` sorted ascending (the same
    minimum and the same id: the last one achieving it), by segment reductions instead of
    ``np.minimum.at``."""
    best = np.full(k, np.inf)
    arg = np.full(k, -1, dtype=np.int64)
    if len(qs) == 0:
        return best, arg
    starts = np.flatnonzero(np.concatenate([[True], qs[1:] != qs[:-1]]))
    g = qs[starts]
    gmin = np.minimum.reduceat(values, starts)
    best[g] = gmin
    lens = np.diff(np.append(starts, len(qs)))
    win = values <= np.repeat(gmin, lens)
    last = np.maximum.reduceat(np.where(win, np.arange(len(qs)), -1), starts)
    ok = last >= 0
    arg[g[ok]] = ids[last[ok]]
    return best, arg


def _golden_pairs(cutter, q, kc, u, scal, D, lo, hi, xtol):
    """Golden-section search of f(t) = cutter distance of the point at parameter t of its
    segment, per (point, segment) pair, on brackets [lo, hi] until (hi − lo) D ≤ xtol.

    ``scal`` = (za, zb, Ta, Tb, n0, m2, L2, φ) (m,) each: z(t) = cos tφ (za − t Ta) +
    sin tφ (zb − t Tb), |d(t)|² = n0 − t m2 + t² L2; ``q`` (m,) the point of each pair,
    sorted ascending. A pair stops early once its best value minus its bracket's motion is
    above its point's best (``u``, updated every step). The live pairs' state is kept in
    compact arrays (no gathers per step; the nine constants of a pair as one (9, m) block,
    compacted by one gather). Each step looks for new bests among the pairs below their
    point's best only: a pair at or above it can neither be nor tie a smaller minimum, so
    the bests and the pairs achieving them are those of all pairs. Returns (best value per
    point (kc,), pair index of it or −1)."""
    m = len(q)
    if m == 0:
        return u.copy(), np.full(kc, -1, dtype=np.int64)
    if np.any(q[1:] < q[:-1]):
        order = np.argsort(q, kind="stable")
        u, arg = _golden_pairs(cutter, q[order], kc, u, tuple(x[order] for x in scal),
                               D[order], lo[order], hi[order], xtol)
        return u, np.where(arg >= 0, order[np.maximum(arg, 0)], -1)
    if compiled_cutter.available():
        return compiled_cutter.golden_pairs(compiled_cutter.cutter_profile(cutter), q, u,
                                            (*scal, D), lo, hi, xtol, workers())
    C = np.stack([*scal, D])  # (9, m): za, zb, Ta, Tb, n0, m2, L2, φ, D
    za, zb, Ta, Tb, n0, m2, L2, phi, D = C
    idx = np.arange(m)
    lo, hi = lo.copy(), hi.copy()
    sdrz = cutter.signed_distance_rz

    def f(t):
        tp = t * phi
        c, s = np.cos(tp), np.sin(tp)
        z = c * (za - t * Ta) + s * (zb - t * Tb)
        n = n0 - t * m2 + t * t * L2
        return sdrz(np.sqrt(np.maximum(n - z * z, 0.0)), z)

    x1 = hi - _GOLD * (hi - lo)
    x2 = lo + _GOLD * (hi - lo)
    f1, f2 = f(x1), f(x2)
    u = u.copy()
    arg = np.full(kc, -1, dtype=np.int64)
    for _ in range(200):
        fb = np.minimum(f1, f2)
        uq = np.take(u, q)
        # the pairs that may beat their point's best (NaN kept: it makes the group's
        # minimum NaN, as over all pairs)
        cand = np.flatnonzero(~(fb >= uq))
        if len(cand):
            ub, a = _sorted_group_argmin(kc, np.take(q, cand), np.take(fb, cand),
                                         np.take(idx, cand))
            better = ub < u
            u = np.where(better, ub, u)
            arg = np.where(better, a, arg)
            uq = np.take(u, q)
        wD = (hi - lo) * D
        keep = (wD > xtol) & (fb - wD <= uq)
        if not keep.all():
            if not keep.any():
                break
            keep = np.flatnonzero(keep)
            C = np.take(C, keep, axis=1)
            za, zb, Ta, Tb, n0, m2, L2, phi, D = C
            lo, hi, x1, x2, f1, f2, q, idx = (
                np.take(x, keep) for x in (lo, hi, x1, x2, f1, f2, q, idx))
        lo, hi, x1, x2, f1, f2 = _golden_step(f, lo, hi, x1, x2, f1, f2)
    return u, arg


def swept_cutter(tool, curves, owners=None, method: str = "fast"):
    """The swept-volume distance model for ``tool`` along ``curves`` (list of PassCurve).

    ``tool`` is a :class:`~..tool.cutter.Cutter`, a legacy ``BallTool`` or a paths-JSON tool dict.
    A ball keeps the exact swept-sphere computation (:class:`SweptBall`; any axis: the ball is
    symmetric); every other cutter is swept from its exact shape (:class:`SweptCutter`, with
    ``method`` "fast" or "exact", see there). Both provide ``distance``, ``nearest``,
    ``height_along`` and ``owner``.
    """
    cutter = as_cutter(tool)
    if cutter.type == "ball":
        return SweptBall.from_curves(curves, cutter.radius, owners)
    return SweptCutter.from_curves(cutter, curves, owners, method=method)


#: odd 64-bit multipliers of :func:`_first_of_equal_rows`'s hash
_MIX = np.array([0x9E3779B97F4A7C15, 0xC2B2AE3D27D4EB4F, 0x165667B19E3779F9,
                 0x27D4EB2F165667C5], dtype=np.uint64)


def searched_once(P, w, search):
    """``search(P, w)`` — (k,) values and (k,) ints for points ``P`` (k, 3) of members ``w``
    (k,) — asked for each distinct (point, member) row once (:func:`_first_of_equal_rows`)
    and spread back to its repeats: for searches whose answer is a function of the point and
    member alone."""
    first = _first_of_equal_rows(P, w)
    uniq = first == np.arange(len(P))
    if np.all(uniq):
        return search(P, w)
    du, gu = search(P[uniq], w[uniq])
    pos = np.cumsum(uniq) - 1
    return du[pos[first]], gu[pos[first]]


def _first_of_equal_rows(P, w):
    """(k,) int64: for each point of ``P`` (k, 3) with member ``w`` (k,), a row holding the
    same member and the same coordinates bit for bit, the same for all of them and the first
    of them in the order given (itself when it is the first). Rows are sorted by a hash of
    their bits and equal neighbours in that order matched by their bits, so rows are only
    ever merged with identical ones (two different rows sharing a hash may leave a repeat
    unmerged: it is then searched twice, with the same figures). Many rows with several
    threads: the rows are split in two by the hash's top bit (equal rows share it) and the
    halves sorted and matched on two threads (the same ``first`` but for such hash ties)."""
    k = len(P)
    bits = np.empty((k, 4), dtype=np.uint64)
    bits[:, 0] = np.asarray(w, dtype=np.int64).view(np.uint64)
    bits[:, 1:] = np.ascontiguousarray(P, dtype=np.float64).view(np.uint64)
    with np.errstate(over="ignore"):
        h = bits * _MIX
    h = (h[:, 0] ^ (h[:, 1] >> np.uint64(7))) ^ (h[:, 2] ^ (h[:, 3] >> np.uint64(13)))
    first = np.empty(k, dtype=np.int64)

    def match(rows):
        o = np.argsort(h) if rows is None else rows[np.argsort(h[rows])]
        b = bits[o]
        same = np.zeros(len(o), dtype=bool)
        if len(o) > 1:
            same[1:] = np.all(b[1:] == b[:-1], axis=1)
        head = np.flatnonzero(~same)  # the first row of each run, in sorted positions
        if len(o):
            first[o] = np.minimum.reduceat(o, head)[np.cumsum(~same) - 1]

    if k < _SPLIT_ROWS or workers() < 2:
        match(None)
    else:
        top = h >= np.uint64(1 << 63)
        map_tasks(match, (np.flatnonzero(~top), np.flatnonzero(top)))
    return first


#: rows from which :func:`_first_of_equal_rows` sorts its two halves on two threads
_SPLIT_ROWS = 50_000
