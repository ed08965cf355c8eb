"""Global collision detection between the posed tool assembly and the blisk (paper 004 §2).

Obstacles (:class:`Obstacles`): the target blade, its neighbours — the blade turned about the
blisk axis by ±k·360°/N, k = 1..``neighbours`` — and any extra meshes (hub, whole blisk,
fixture), each a named triangle mesh.

Tool (:class:`~..tool.assembly.ToolAssembly`): the **flute** (the :class:`~..tool.cutter.Cutter`'s
own convex shape, from the tip to the assembly's flute length) and the **body** (the union of the
frustums of the holder profile above it). Clearance of a pose (mm, signed):

    clearance = min( dist(body, every obstacle incl. the target blade),
                     dist(flute, every obstacle except the target blade) )

capped at ``safety + 5`` mm (never NaN). A pose collides when clearance < ds (paper 004 Eq. 9:
the paper compares the point–axis distance L of Eq. 7 with R2 + ds; here the distance from
the obstacle to the tool *surface* is compared with ds, which is the same test for its
cylindrical handle, and holds for tapers and shoulders too).

**Distances to triangles, not to points.** Paper 004 §2.1 discretises the blade into points
(Eqs. 2–8), which misses a collision between the points of a coarse mesh. Here every part is a
convex solid of revolution S (one frustum of the profile, or the cutter), whose signed distance
sd_S(x) is exact and convex in x (it only depends on the meridional coordinates (ρ, z) of x, in
which S is a convex polygon, or the cutter's convex outline). The minimum of sd_S over a
triangle T is found exactly as follows:

* the three vertices and, along each edge, the minimum of the convex function sd_S by golden
  section with a convexity bound: the secant through the bracket's two probes, extended,
  bounds sd_S from below outside them, and the secants through each probe and its bracket
  end bound it between them; an edge stops once that bound is within 10⁻⁹ mm of its best
  value (at most 40 steps: 0.618⁴⁰ ≈ 4·10⁻⁹ of the edge), or above the pose's best so far
  (it cannot hold the minimum);
* the interior: with n the triangle's unit normal and y± the support points of S in the
  directions ±n (closed form for frustums and for the cutter's profile), if S lies entirely on
  one side of the triangle's plane the closest point of the plane to S is the support point's
  foot: when that foot lies inside T, the interior minimum is its plane distance (exact, and
  T's minimum: its edges are not searched), otherwise that distance bounds sd_S over T. If
  the plane cuts S and the point of the segment y⁻y⁺ on the plane lies inside T, T intersects
  S (its depth is taken there). A minimum on the interior with S on both sides of the plane is
  impossible unless T intersects S.

Positive clearances are therefore exact to ~10⁻⁹ mm. Negative values (penetration) are the
deepest signed distance found among those candidates and the feet on T's plane of the
part's axis points (exact when a cylinder's side cuts a plane; otherwise an estimate that
is ≤ 0 whenever T meets the part). Once a pose is known to penetrate, its search is a beam
(the 8 nodes per level with the deepest representative points) and only its 16 triangles
with the deepest centroids are refined (the depth is an estimate there anyway; the
centroids count too, so the figure stays below the bound that showed the penetration), and
a pose whose lower bound is ≥ ds + 1 mm descends as a beam of its 8 most promising nodes
and refines its 8 most promising triangles: exact to ~10⁻⁹ mm where it matters (below
ds + 1 mm), within the gap between the bounds (about the local triangle size) above.

**Neighbours by turning the poses.** The neighbours are rigid copies of the blade (turned by
±k·360°/N about the blisk axis), and distances are invariant under the rotation: one
triangle tree over the blade serves every copy, each queried with the poses turned back by
the copy's angle (tip and axis by −k·360°/N); the contact point and normal found are turned
forward again. Extra obstacles (and a neighbour that is not an exact copy) share a second
tree. Building the tree is then a fifth of the work for ±2 neighbours.

**Culling** (paper 004 §2.2, Eqs. 3–6 project the handle to cull points; here a bounding
volume hierarchy of the triangles replaces the projection): triangles are sorted along a
Morton curve of their centroids; an implicit 4-ary tree over that order (leaves of 8
triangles) carries a bounding box and one representative triangle point per node. A
frontier of (pose, node) pairs descends the tree for every part and copy: the lower bound of
a node is ``sd_S(centre) − radius`` (sd_S is 1-Lipschitz; radius of the box's sphere) and,
for the frustums on small nodes, the tangent plane of the convex sd_S at the centre,
``sd_S(c) − Σ |∇sd_S(c)_i| h_i`` over the box of half-sizes h, and for a triangle the same
plane at its centroid over its three vertices — far tighter where a shank runs along a
surface. The upper bound of the pose's clearance is the smallest ``sd_S`` of any
representative point met so far (a point on an obstacle), and a pair survives only while
its lower bound is at most that upper bound (and the cap). Only the surviving triangles are
refined exactly. Poses are processed in chunks, in threads (numpy releases the GIL).

**Compiled.** With the compiled kernels (:mod:`..kernels.collision`) the walks, the ranking
and the refine of every chunk of a batch run in one call, the chunks in parallel (rayon, the
GIL released), the same steps on the same chunks as numpy: the same figures (the tests
compare the two backends). The numpy code here stays the reference and the fallback.

Units mm and radians. numpy/scipy only.
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..errors import CollisionError
from ..geometry.axis import Axis
from ..geometry.vectors import rotate_about, rotation_matrix
from ..kernels import collision as compiled_collision
from ..runtime import requested_workers
from ..runtime import workers as runtime_workers
from ..tool.assembly import ToolAssembly
from ..tool.cutter import as_cutter
from .obstacles import Obstacles
from .posed_tool import CAP_MARGIN, _Flute, _Frustum
from .tri_tree import (
    _CHUNK,
    _FAR_MARGIN,
    _FAR_PAIRS,
    _PENETRATION_PAIRS,
    _groups,
    _part_spec,
    _refine,
    _TriTree,
)

__all__ = ["CollisionScene", "Detection", "detect_collisions"]


# ====================================================================== detection
@dataclass
class Detection:
    """Per-pose collision figures.

    Attributes
    ----------
    clearance : (m,) float, mm — signed clearance (< 0: penetration depth), capped at
        ``cap`` for poses with nothing closer
    obstacle : (m,) int — index into ``Obstacles.meshes`` of the nearest obstacle (−1: none
        within the cap)
    part : (m,) int8 — ``PART_FLUTE`` (0) or ``PART_BODY`` (1), −1 for none
    point : (m, 3) float, mm — the closest point on the obstacle (NaN for none)
    normal : (m, 3) float — unit normal of the obstacle triangle holding ``point``, turned
        toward the tool axis (NaN for none)
    safety : float, mm — ds
    cap : float, mm
    """

    clearance: np.ndarray
    obstacle: np.ndarray
    part: np.ndarray
    point: np.ndarray
    normal: np.ndarray
    safety: float
    cap: float

    @property
    def colliding(self) -> np.ndarray:
        """(m,) bool: clearance < ds."""
        return self.clearance < self.safety

    def __len__(self) -> int:
        return len(self.clearance)


class _Copies:
    """One triangle tree and the rigid copies of it that are obstacles: the blade and its
    neighbours (copy c is the blade turned by ``angles[c]`` about the blisk axis), or the
    extra meshes (one copy, the identity; each triangle's owner is its obstacle).

    A copy is queried by turning the poses back onto the tree (tip and axis by −angle):
    distances are invariant under the rotation, so one tree over the blade serves every
    neighbour, and the contact point and normal found are turned forward again."""

    def __init__(self, tree: _TriTree, axis: Axis, angles, obstacles, blade: bool):
        self.tree = tree
        self.blade = blade
        self.o = np.asarray(axis.o, dtype=np.float64)
        self.obst = np.asarray(obstacles, dtype=np.int64)  # obstacle index per copy
        self.R = np.stack([rotation_matrix(axis.d, a, form="outer") for a in angles])  # (c, 3, 3)
        self.identity = not blade

    @property
    def n_copies(self) -> int:
        return len(self.R)

    def queries(self, tips, axes):
        """(tips (c·m, 3), axes (c·m, 3), pose (c·m,), copy (c·m,)) of every pose turned back
        onto the tree for each copy, copy-major (copy c's queries are rows c·m … c·m + m)."""
        m = len(tips)
        if self.identity:
            return tips, axes, np.arange(m), np.zeros(m, dtype=np.int64)
        rel = tips - self.o
        tq = np.concatenate([rel @ R for R in self.R]) + self.o  # Rᵀ x, row-wise
        aq = np.concatenate([axes @ R for R in self.R])
        c = len(self.R)
        return tq, aq, np.tile(np.arange(m), c), np.repeat(np.arange(c), m)

    def obstacle(self, cid, T):
        """(k,) obstacle index of triangle T (k,) of copy cid (k,)."""
        return self.tree.owner[T] if self.identity else self.obst[cid]

    def to_world(self, cid, points, normals):
        """Points and normals (k, 3) found on copy cid (k,) in the tree's frame, turned
        onto the copy."""
        if self.identity:
            return points, normals
        R = self.R[cid]
        return (np.einsum("kij,kj->ki", R, points - self.o) + self.o,
                np.einsum("kij,kj->ki", R, normals))


def _copy_angle(obstacles: Obstacles, i: int):
    """The angle (rad) by which ``obstacles.meshes[i]`` is the blade turned about the axis,
    or None when it is not (exactly) such a copy."""
    blade, ob = obstacles.meshes[0], obstacles.meshes[i]
    j = (i + 1) // 2
    angle = (1 if i % 2 else -1) * j * 2.0 * math.pi / obstacles.blade_count
    src = ob.turned_from
    if src is not None and src[0] is blade.V and ob.F is blade.F and \
            src[1:] == (1 if i % 2 else -1, j, obstacles.blade_count):
        return angle  # Obstacles.build turned it so (the check below would say the same)
    if ob.F.shape != blade.F.shape or ob.V.shape != blade.V.shape or \
            not (ob.F is blade.F or np.array_equal(ob.F, blade.F)):
        return None
    # the copies of Obstacles.build are bit for bit these; others within rounding
    turned = rotate_about(blade.V, obstacles.axis.d, angle, obstacles.axis.o, form="outer")
    if not np.array_equal(turned, ob.V):
        scale = max(1.0, float(np.abs(blade.V - obstacles.axis.o).max()))
        if float(np.abs(turned - ob.V).max()) > 1e-12 * scale:
            return None
    return angle


def _obstacle_groups(obstacles: Obstacles):
    """[_Copies]: the blade with the neighbours that are its rotated copies, then one group
    over every other obstacle (the extra meshes, and any neighbour given as its own mesh)."""
    meshes = obstacles.meshes
    angles, idx, other = [0.0], [0], []
    for i in range(1, len(meshes)):
        a = _copy_angle(obstacles, i) if i < obstacles.extra_start else None
        if a is None:
            other.append(i)
        else:
            angles.append(a)
            idx.append(i)
    blade = meshes[0]
    tree = _TriTree(blade.V, blade.F, np.zeros(blade.n_triangles, dtype=np.int64))
    groups = [_Copies(tree, obstacles.axis, angles, idx, blade=True)]
    if other:
        base = np.cumsum([0] + [len(meshes[i].V) for i in other])
        V = np.concatenate([meshes[i].V for i in other])
        F = np.concatenate([meshes[i].F + b for i, b in zip(other, base, strict=False)])
        owner = np.concatenate([np.full(meshes[i].n_triangles, i, dtype=np.int64)
                                for i in other])
        groups.append(_Copies(_TriTree(V, F, owner), obstacles.axis, [0.0], [-1],
                              blade=False))
    return groups


class CollisionScene:
    """Obstacles, cutter and assembly with the triangle trees built once (reused by the
    avoidance iterations).

    Parameters
    ----------
    obstacles : Obstacles
    cutter : Cutter (or anything :func:`..tool.cutter.as_cutter` reads)
    assembly : ToolAssembly
    """

    def __init__(self, obstacles: Obstacles, cutter, assembly: ToolAssembly):
        if not isinstance(assembly, ToolAssembly):
            raise CollisionError("collision check needs a ToolAssembly (flute length, holder "
                                 "profile, safety)")
        self.obstacles = obstacles
        self.cutter = as_cutter(cutter)
        self.assembly = assembly
        self.safety = float(assembly.safety)
        self.cap = self.safety + CAP_MARGIN
        self.flute = _Flute(self.cutter, assembly.flute_length)
        self.body = [_Frustum(*f) for f in assembly.frustums()]
        self._groups = _obstacle_groups(obstacles)

    def with_assembly(self, assembly: ToolAssembly) -> CollisionScene:
        """The same obstacles (their triangle trees shared, not rebuilt) with another tool
        assembly: cheap what-if checks (e.g. which holder would clear)."""
        if not isinstance(assembly, ToolAssembly):
            raise CollisionError("with_assembly needs a ToolAssembly")
        out = object.__new__(CollisionScene)
        out.__dict__.update(self.__dict__)
        out.assembly = assembly
        out.safety = float(assembly.safety)
        out.cap = out.safety + CAP_MARGIN
        out.flute = _Flute(self.cutter, assembly.flute_length)
        out.body = [_Frustum(*f) for f in assembly.frustums()]
        return out

    def parts(self, flute_on_target: bool = False):
        """[(part, groups)]: the flute against the non-target obstacles (against all with
        ``flute_on_target``), the body frustums against all; ``groups`` is a list of
        (:class:`_Copies`, first copy) — the flute skips copy 0 of the blade (the target blade
        itself) unless ``flute_on_target``."""
        skip = 0 if flute_on_target else 1
        fl = [(g, skip if g.blade else 0) for g in self._groups
              if not g.blade or g.n_copies > skip]
        out = [(self.flute, fl)] if fl else []
        return out + [(f, [(g, 0) for g in self._groups]) for f in self.body]

    # long on purpose: candidates of every part and obstacle group, the per-pose pruning and the
    # exact refinement share the per-pose bounds; split, they would pass a dozen arrays around
    def _chunk(self, tips, axes, flute_on_target=False):
        m = len(tips)
        ub = np.full(m, self.cap)
        queries = {id(g): g.queries(tips, axes) for g in self._groups}
        cand = []
        for part, groups in self.parts(flute_on_target):
            for g, first in groups:
                tq, aq, pid, cid = (x[first * m:] for x in queries[id(g)])
                P, T, sdc, lb = g.tree.candidates(part, tq, aq, ub, pid,
                                                  far=self.safety + _FAR_MARGIN)
                if len(P):
                    cand.append((part, g, tq[P], aq[P], pid[P], cid[P], T, sdc, lb))
        best = np.full(m, self.cap)
        obst = np.full(m, -1, dtype=np.int64)
        kind = np.full(m, -1, dtype=np.int8)
        pt = np.full((m, 3), np.nan)
        nr = np.full((m, 3), np.nan)
        for part, g, tq, aq, P, cid, T, sdc, lb in cand:
            tree = g.tree
            keep = lb <= ub[P]
            tq, aq, P, cid, T, sdc, lb = (x[keep] for x in (tq, aq, P, cid, T, sdc, lb))
            if len(P) == 0:
                continue
            # a pose already known to penetrate (bound < 0) needs a depth, not the exact
            # deepest point: only its _PENETRATION_PAIRS triangles with the deepest centroids
            # are refined (a flat obstacle across a cap would otherwise tie over thousands of
            # them), and the centroid itself is offered (the pose's figure stays ≤ its bound)
            # ... and a pose whose lower bound is ≥ ds + _FAR_MARGIN is certainly clear:
            # only its _FAR_PAIRS most promising triangles are refined (its figure is then
            # within the bounds' gap, about the local triangle size, of the exact one)
            deep = ub[P] < 0
            bound = sdc <= ub[P] + 1e-12  # the centroid that gave the pose's bound: kept
            order = np.lexsort((np.where(deep, sdc, np.where(bound, -np.inf, lb)), P))
            tq, aq, P, cid, T, sdc, lb, deep = (x[order] for x in
                                                (tq, aq, P, cid, T, sdc, lb, deep))
            starts, sizes = _groups(P)
            start = np.repeat(starts, sizes)
            rank = np.arange(len(P)) - start
            far = np.minimum.reduceat(lb, starts)[np.repeat(np.arange(len(starts)), sizes)] \
                >= self.safety + _FAR_MARGIN
            keep = ~(deep | far) | (rank < np.where(deep, _PENETRATION_PAIRS, _FAR_PAIRS))
            beamed = (deep | far)[keep]
            tq, aq, P, cid, T, sdc = (x[keep] for x in (tq, aq, P, cid, T, sdc))
            d, w = _refine(part, tree.A[T], tree.B[T], tree.C[T], tree.nrm[T], tree.ok[T],
                           tq, aq, P, ub)
            cen = beamed & (sdc < d)
            d = np.where(cen, sdc, d)
            w = np.where(cen[:, None], tree.cen[T], w)
            order = np.lexsort((d, P))
            first = np.ones(len(P), bool)
            first[1:] = P[order][1:] != P[order][:-1]
            sel = order[first]
            sel = sel[d[sel] < best[P[sel]]]
            Ps, Ts, ws, ts, as_ = P[sel], T[sel], w[sel], tq[sel], aq[sel]
            best[Ps] = d[sel]
            obst[Ps] = g.obstacle(cid[sel], Ts)
            kind[Ps] = part.kind
            nn = tree.nrm[Ts]
            foot = ts + np.einsum("ij,ij->i", ws - ts, as_)[:, None] * as_
            side = np.einsum("ij,ij->i", nn, foot - ws)
            nn = np.where((side < 0)[:, None], -nn, nn)
            pt[Ps], nr[Ps] = g.to_world(cid[sel], ws, nn)
        return best, obst, kind, pt, nr

    def detect(self, tips, axes, *, chunk: int = _CHUNK, workers: int | None = None,
               progress=None, flute_on_target: bool = False) -> Detection:
        """Clearance of every pose (module docstring).

        Parameters
        ----------
        tips : (m, 3) float, mm — tool tip (CL) points
        axes : (m, 3) float — unit tool axes (tip → spindle)
        flute_on_target : bool — the flute counts against the target blade too (poses that do
            not cut it, e.g. rapids: there a touch of the flute is a gouge)
        chunk : int — poses per work unit
        workers : int or None — threads (default: up to 2)
        progress : callable(fraction) or None

        Returns
        -------
        Detection
        """
        tips = np.ascontiguousarray(tips, dtype=np.float64).reshape(-1, 3)
        axes = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
        if len(axes) != len(tips):
            raise CollisionError(f"{len(tips)} tips but {len(axes)} axes")
        ln = np.linalg.norm(axes, axis=1)
        if not (np.all(np.isfinite(tips)) and np.all(np.isfinite(ln)) and np.all(ln > 0)):
            raise CollisionError("poses with NaN coordinates or zero tool axes cannot be checked")
        axes = axes / ln[:, None]
        m = len(tips)
        out = (np.full(m, self.cap), np.full(m, -1, np.int64), np.full(m, -1, np.int8),
               np.full((m, 3), np.nan), np.full((m, 3), np.nan))
        if m == 0:
            return Detection(*out, self.safety, self.cap)
        parts = self.parts(flute_on_target)
        specs = [_part_spec(p) for p, _ in parts]
        if compiled_collision.detect_available() and all(x is not None for x in specs):
            nw = workers or (runtime_workers() if runtime_workers() > 1 or requested_workers()
                             else min(2, os.cpu_count() or 1))  # --threads N: N
            self._detect_compiled(tips, axes, parts, specs, out, chunk, nw, progress)
            return Detection(*out, self.safety, self.cap)
        spans = [(s, min(s + chunk, m)) for s in range(0, m, chunk)]
        nw = workers or (runtime_workers() if requested_workers()
                         else min(2, os.cpu_count() or 1))
        done = 0

        def work(span):
            s, e = span
            return span, self._chunk(tips[s:e], axes[s:e], flute_on_target)

        if nw > 1 and len(spans) > 1:
            with ThreadPoolExecutor(nw) as ex:
                results = ex.map(work, spans)
                for (s, e), res in results:
                    for o, r in zip(out, res, strict=True):
                        o[s:e] = r
                    done += e - s
                    if progress is not None:
                        progress(done / m)
        else:
            for span in spans:
                (s, e), res = work(span)
                for o, r in zip(out, res, strict=True):
                    o[s:e] = r
                done += e - s
                if progress is not None:
                    progress(done / m)
        return Detection(*out, self.safety, self.cap)


    def _compiled_tree(self, tree: _TriTree):
        """The compiled copy of ``tree``'s arrays (made once, kept on the tree: scenes made by
        :meth:`with_assembly` share it)."""
        ct = getattr(tree, "_compiled", None)
        if ct is None:
            ct = tree._compiled = compiled_collision.collision_tree(
                tree.levels, tree.cen, tree.rad, tree.A, tree.B, tree.C, tree.nrm, tree.ok)
        return ct

    def _detect_compiled(self, tips, axes, parts, specs, out, chunk, nw, progress):
        """:meth:`detect` by the compiled kernels (:func:`..kernels.collision.detect`): the
        walks, ranking and refine of :meth:`_chunk` for every chunk of a batch in one call,
        then the obstacle, part, point and normal of each pose as :meth:`_chunk` sets them.
        ``out`` (clearance, obstacle, part, point, normal) filled in place."""
        m = len(tips)
        groups = self._groups
        gid = {id(g): i for i, g in enumerate(groups)}
        trees = [self._compiled_tree(g.tree) for g in groups]
        cparts = [(spec, p.rmax) for (p, _), spec in zip(parts, specs, strict=True)]
        plan = [[(gid[id(g)], first) for g, first in grp] for _, grp in parts]
        kinds = np.array([p.kind for p, _ in parts], dtype=np.int8)
        batch = chunk * 32  # poses per call: progress between calls
        for b0 in range(0, m, batch):
            b1 = min(b0 + batch, m)
            qs = [[g.queries(tips[s:min(s + chunk, b1)], axes[s:min(s + chunk, b1)])[:2]
                   for s in range(b0, b1, chunk)] for g in groups]
            queries = [(np.concatenate([q[0] for q in gq]), np.concatenate([q[1] for q in gq]),
                        g.n_copies) for g, gq in zip(groups, qs, strict=True)]
            best, ids, w = compiled_collision.detect(trees, cparts, plan, queries, b1 - b0,
                                                     chunk, self.cap, self.safety, nw)
            out[0][b0:b1] = best
            for gi, g in enumerate(groups):
                sel = np.nonzero(ids[:, 0] == gi)[0]
                if len(sel) == 0:
                    continue
                row, cid, T = ids[sel, 2], ids[sel, 3], ids[sel, 4]
                ts, as_, ws = queries[gi][0][row], queries[gi][1][row], w[sel]
                nn = g.tree.normals(T)
                foot = ts + np.einsum("ij,ij->i", ws - ts, as_)[:, None] * as_
                side = np.einsum("ij,ij->i", nn, foot - ws)
                nn = np.where((side < 0)[:, None], -nn, nn)
                ps = sel + b0
                out[1][ps] = g.obstacle(cid, T)
                out[2][ps] = kinds[ids[sel, 1]]
                out[3][ps], out[4][ps] = g.to_world(cid, ws, nn)
            if progress is not None:
                progress(b1 / m)


def detect_collisions(obstacles: Obstacles, cutter, assembly: ToolAssembly, tips, axes,
                      **kw) -> Detection:
    """Clearance of every pose against the obstacles (builds a :class:`CollisionScene`; reuse
    a scene for repeated checks). See :meth:`CollisionScene.detect`."""
    return CollisionScene(obstacles, cutter, assembly).detect(tips, axes, **kw)
