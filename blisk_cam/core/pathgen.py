"""Boundary-conformed LMC finishing paths on a mesh (paper 001 §3): slice, sample, expand.

``generate_paths`` runs the whole loop: the first pass is mesh ∩ cone 1 (s = 0); each next
ratio comes from :mod:`.expansion` (predicted, then measured and corrected so the scallop is
close to but never above the cusp height); the last pass is mesh ∩ cone 2 (s = 1). Every
pass is sampled by :mod:`.sampling` so the chord tolerance holds for the CC and the ball-centre
path. ``iter_generate_paths`` is the same as a generator yielding progress, for a modal
operator to drive; ``generate_paths`` simply exhausts it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .cones import Axis, Cone, MorphingCones, meridional
from .errors import ConeError, ToleranceError
from .expansion import (
    PolylineDistance,
    check_tolerances,
    face_gradient_and_curvature,
    measure_cusp,
    strip_width,
)
from .mesh import TriMesh
from .sampling import densify_by_normal_turn, sample_polyline
from .slicing import LevelCurve, MeshConeSlicer
from .toolpath import BallTool, PassCurve, ToolPath

__all__ = ["Progress", "generate_paths", "iter_generate_paths"]

#: a pass may end with a scallop this fraction of the tolerance or more, else it is widened
CUSP_ACCEPT = 0.85
#: the cusp aimed at when correcting the side step
CUSP_TARGET = 0.94
#: safety cap on the number of passes (a path of more passes is not a finishing path)
MAX_PASSES = 20_000


@dataclass
class Progress:
    """Progress report yielded by :func:`iter_generate_paths`."""

    fraction: float
    message: str


def _resample(points, closed, spacing):
    """Points at uniform arc length ≤ ``spacing`` apart along a polyline (on its segments,
    so on the mesh and the cone when the polyline is an exact intersection)."""
    P = np.vstack([points, points[:1]]) if closed else points
    if len(P) < 2:
        return points
    L = np.linalg.norm(np.diff(P, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    n = max(2, int(np.ceil(cum[-1] / spacing)) + 1)
    u = np.linspace(0.0, cum[-1], n, endpoint=not closed)
    seg = np.clip(np.searchsorted(cum, u, side="right") - 1, 0, len(L) - 1)
    w = (u - cum[seg]) / np.where(L[seg] > 0, L[seg], 1.0)
    return P[seg] + w[:, None] * (P[seg + 1] - P[seg])


def _point_triangle_distance(p, tri):
    """Distance from points (..., 3) to triangles (..., 3, 3): the foot on the plane if it is
    inside the triangle, else the nearest of the three edges."""
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    n = np.cross(b - a, c - a)
    n2 = np.einsum("...j,...j->...", n, n)
    h = np.einsum("...j,...j->...", p - a, n) / np.where(n2 > 0, n2, 1.0)
    foot = p - h[..., None] * n
    inside = n2 > 0
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...j,...j->...", np.cross(v - u, foot - u), n) >= 0
    best = np.where(inside, np.abs(h) * np.sqrt(n2), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        uv = v - u
        L2 = np.einsum("...j,...j->...", uv, uv)
        t = np.clip(np.einsum("...j,...j->...", p - u, uv) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        d = p - (u + t[..., None] * uv)
        best = np.minimum(best, np.sqrt(np.einsum("...j,...j->...", d, d)))
    return best


class _Generator:
    def __init__(self, mesh, axis, cone1, cone2, radius, cusp, chord):
        check_tolerances(radius, cusp, chord)
        self.mesh = mesh
        self.axis = axis
        self.morph = MorphingCones(cone1, cone2)
        self.radius, self.cusp, self.chord = float(radius), float(cusp), float(chord)
        self.slicer = MeshConeSlicer(mesh, axis, self.morph)
        lo, hi = self.slicer.s_range
        if hi < 0.0 or lo > 1.0:
            raise ConeError(
                "the cones miss the blade: the mesh lies entirely "
                + ("on the hub side of cone 1" if hi < 0 else "beyond cone 2")
                + f" (its morph ratios run from {lo:.3f} to {hi:.3f}, the region is 0..1); "
                "fit the cones to the blade or move them onto it"
            )
        self.s_clipped = np.clip(self.slicer.s, -1e6, 1e6)
        self._levels: dict[float, list[LevelCurve]] = {}
        self.max_turn = 2.0 * np.arccos(1.0 - self.chord / (4.0 * self.radius))
        self.sample_spacing = max(min(0.25, 0.5 * np.sqrt(8 * self.radius * self.cusp) / 4), 0.02)

    def level(self, s):
        if s not in self._levels:
            self._levels[s] = self.slicer.slice(s)
        return self._levels[s]

    def make_pass(self, s):
        """The sampled CC curves of the level ``s`` (list of PassCurve)."""
        out = []
        for c in self.level(s):
            start = None
            if c.closed:
                _, zz = meridional(c.points, self.axis)
                start = int(np.argmax(zz))
            edge = c.edge if start is None else np.roll(c.edge, -start)
            cc, nn, lam = sample_polyline(
                c.points, c.normals, c.closed, chord=self.chord, radius=self.radius, start=start,
                lift=lambda D, DN, seg, edge=edge, closed=c.closed: self.facet_lift(D, DN, seg, edge, closed),
            )
            # the ball (axis = normal) touches at cc; its tip is cc lifted by λ along n
            out.append(PassCurve(s=s, closed=c.closed, cc=cc, normal=nn, tip=cc + lam[:, None] * nn,
                                 axis=nn.copy()))
        return out

    def facet_lift(self, D, DN, seg, edge, closed):
        """λ (mm) per point so that the ball centre ``p + (ρ + λ) n`` stays at least ρ from the
        faces around ``p``: the smooth normal n differs from the facet normals, and a ball at
        ``p + ρ n`` would sink into a facet by up to ``ρ (1 − n·n_f)``. The faces are those
        around the corners of the two mesh edges bounding the segment the point lies on;
        λ comes from a few fixed-point steps on the exact point–triangle distance."""
        k = len(edge)
        e0 = edge[np.minimum(seg, k - 1)]
        e1 = edge[(seg + 1) % k] if closed else edge[np.minimum(seg + 1, k - 1)]
        faces = np.concatenate([self.mesh.edge_faces[e0], self.mesh.edge_faces[e1]], axis=1)
        fn = self.mesh.face_normals[np.maximum(faces, 0)]  # (q, 4, 3)
        cos = np.einsum("qj,qfj->qf", DN, fn)
        plane = np.where(faces >= 0, self.radius * (1.0 - np.clip(cos, -1, 1)), 0.0).max(axis=1)
        lam = np.zeros(len(D))
        need = np.nonzero(plane > 1e-6)[0]  # only where a facet plane is penetrated at all
        if len(need) == 0:
            return lam
        verts = np.unique(self.mesh.edges[np.concatenate([e0[need], e1[need]])])
        ring = self._vertex_faces(verts)  # (len(verts), w) padded with −1
        pos = np.searchsorted(verts, self.mesh.edges[np.stack([e0[need], e1[need]], 1)].reshape(len(need), 4))
        cand = ring[pos].reshape(len(need), -1)  # (q', 4w)
        tri = self.mesh.V[self.mesh.F[np.maximum(cand, 0)]]  # (q', c, 3, 3)
        p, n = D[need], DN[need]
        lam_n = np.zeros(len(need))
        for _ in range(4):
            c = p + (self.radius + lam_n)[:, None] * n
            d = _point_triangle_distance(c[:, None, :], tri)
            d = np.where(cand >= 0, d, np.inf).min(axis=1)
            short = self.radius - d
            if np.all(short <= 1e-7):
                break
            lam_n += np.maximum(short, 0.0) * 1.05
        lam[need] = lam_n
        return lam

    def _vertex_faces(self, verts):
        """(len(verts), w) faces around each vertex, padded with −1."""
        if not hasattr(self, "_vf"):
            F = self.mesh.F
            order = np.argsort(F.ravel(), kind="stable")
            vs = F.ravel()[order]
            self._vf = (np.searchsorted(vs, np.arange(len(self.mesh.V) + 1)), order // 3)
        ptr, fids = self._vf
        cnt = ptr[verts + 1] - ptr[verts]
        w = int(cnt.max()) if len(cnt) else 0
        idx = ptr[verts][:, None] + np.arange(w)[None, :]
        return np.where(np.arange(w)[None, :] < cnt[:, None], fids[np.minimum(idx, len(fids) - 1)], -1)

    def centre_distance(self, s):
        """Distance to the exact ball-centre curves of level ``s`` (the offset of the exact
        intersection polyline, densified where the normal turns): the scallop is measured
        between ideal passes; the chord error of the sampled poses adds at most ``chord``."""
        polys = []
        for c in self.level(s):
            p, n, _ = densify_by_normal_turn(c.points, c.normals, False, self.max_turn)
            polys.append((p + self.radius * n, c.closed))
        return PolylineDistance(polys, resample=self.sample_spacing)

    def level_samples(self, s):
        return np.vstack(
            [_resample(c.points, c.closed, self.sample_spacing) for c in self.level(s)]
            or [np.zeros((0, 3))]
        )

    def predict_step(self, s):
        """Δs from the strip width (Eqs. 11–14) at the level's points (5th percentile)."""
        curves = self.level(s)
        if not curves:
            return 0.01
        edges = np.concatenate([c.edge for c in curves])
        faces = np.unique(self.mesh.edge_faces[edges, 0])
        grad, kappa = face_gradient_and_curvature(self.mesh, self.s_clipped, faces)
        g = np.linalg.norm(grad, axis=1)
        d = strip_width(self.radius, self.cusp, kappa)
        ds = g * d
        ds = ds[np.isfinite(ds) & (ds > 0)]
        if len(ds) == 0:
            return 0.01
        return float(np.percentile(ds, 5))

    def cusp_between(self, s_a, dist_a, s_b):
        fr = (0.25, 0.5, 0.75)
        levels = [self.level_samples(s_a)]
        levels += [self.level_samples(s_a + f * (s_b - s_a)) for f in fr]
        levels.append(self.level_samples(s_b))
        dist_b = self.centre_distance(s_b)
        return measure_cusp(levels, dist_a, dist_b, self.radius)

    def run(self):
        t0 = time.perf_counter()
        h = self.cusp
        first = self.make_pass(0.0)
        lo, hi = self.slicer.s_range
        if not first:
            raise ConeError(
                f"cone 1 does not cut the blade mesh (the mesh's morph ratios run from {lo:.3f} "
                f"to {hi:.3f}); move cone 1 onto the blade's hub end"
            )
        if not self.level(1.0):
            raise ConeError(
                f"cone 2 does not cut the blade mesh (the mesh's morph ratios run from {lo:.3f} "
                f"to {hi:.3f}); move cone 2 onto the blade's tip end"
            )
        passes = [first]
        cusps = []
        s = 0.0
        while s < 1.0:
            if len(passes) > MAX_PASSES:
                raise ToleranceError(
                    f"more than {MAX_PASSES} passes needed: the cusp height {h} mm is far too small "
                    f"for a {self.radius} mm ball on this blade"
                )
            dist_a = self.centre_distance(s)
            ds = min(max(self.predict_step(s), 1e-6), 1.0 - s)
            feasible = None  # (ds, pass, H)
            infeasible = None  # smallest ds known to exceed h
            for _ in range(10):
                s_new = 1.0 if ds >= 1.0 - s - 1e-12 else s + ds
                if not self.level(s_new):
                    raise ConeError(
                        f"the LMC at s = {s_new:.4f} does not cut the mesh: the blade has a gap "
                        "across the whole region between the cones; check the mesh"
                    )
                H = self.cusp_between(s, dist_a, s_new)
                if H <= h:
                    if feasible is None or ds > feasible[0]:
                        feasible = (ds, H, s_new)
                    if s_new >= 1.0 or H >= CUSP_ACCEPT * h:
                        break
                else:
                    infeasible = ds if infeasible is None else min(infeasible, ds)
                # secant on H ∝ ds², kept inside the bracket
                guess = ds * np.sqrt(CUSP_TARGET * h / max(H, 1e-12)) if H > 0 else 2 * ds
                lo_b = feasible[0] if feasible else 0.0
                hi_b = infeasible if infeasible is not None else 1.0 - s
                if not (lo_b < guess < hi_b):
                    guess = 0.5 * (lo_b + hi_b) if infeasible is not None else min(2 * ds, hi_b)
                if feasible and feasible[0] >= 1.0 - s - 1e-12:
                    break
                if abs(guess - ds) <= 1e-9:
                    break
                ds = min(guess, 1.0 - s)
            if feasible is None:
                raise ToleranceError(
                    f"cannot hold the cusp height {h} mm after s = {s:.4f}: even a tiny side "
                    f"step leaves more (a concave region tighter than the {self.radius} mm ball, "
                    "or a mesh fold); use a smaller ball or check the mesh there"
                )
            ds, H, s_new = feasible
            passes.append(self.make_pass(s_new))
            cusps.append(H)
            # release level caches we no longer need (keep the current one)
            for key in [k for k in self._levels if k < s_new]:
                del self._levels[key]
            s = s_new
            yield Progress(min(s, 1.0), f"pass {len(passes)} at s = {s:.4f}, cusp {H:.4f} mm")
        curves = [c for p in passes for c in p]
        self.result = ToolPath(
            axis=self.axis,
            cone1=self.morph.cone1,
            cone2=self.morph.cone2,
            tool=BallTool(self.radius),
            cusp=self.cusp,
            chord=self.chord,
            curves=curves,
            stats={
                "passes": len(passes),
                "curves": len(curves),
                "poses": int(sum(len(c) for c in curves)),
                "measured_cusp": [float(x) for x in cusps],
                "seconds": time.perf_counter() - t0,
            },
        )


def iter_generate_paths(mesh: TriMesh, axis: Axis, cone1: Cone, cone2: Cone, *, tool_radius: float,
                        cusp: float, chord: float):
    """Generator form of :func:`generate_paths`: yields :class:`Progress`, returns the
    :class:`ToolPath` as the generator's return value (``StopIteration.value``)."""
    gen = _Generator(mesh, axis, cone1, cone2, tool_radius, cusp, chord)
    yield from gen.run()
    return gen.result


def generate_paths(mesh: TriMesh, axis: Axis, cone1: Cone, cone2: Cone, *, tool_radius: float,
                   cusp: float, chord: float) -> ToolPath:
    """Boundary-conformed finishing passes for a ball of ``tool_radius`` (mm) between
    ``cone1`` (s = 0) and ``cone2`` (s = 1), scallop ≤ ``cusp`` and chord error ≤ ``chord`` (mm).

    Raises
    ------
    ConeError, ToleranceError, MeshError with a message that names the problem.
    """
    it = iter_generate_paths(mesh, axis, cone1, cone2, tool_radius=tool_radius, cusp=cusp, chord=chord)
    while True:
        try:
            next(it)
        except StopIteration as stop:
            return stop.value
