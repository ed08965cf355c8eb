"""Boundary-conformed LMC finishing paths on a mesh (paper 001 §3): slice, sample, expand.

``generate_paths`` runs the whole loop: the first pass is mesh ∩ cone 1 (s = 0); each next
ratio comes from :mod:`.expansion` (predicted, then measured and corrected so the scallop is
close to but never above the cusp height); the last pass is mesh ∩ cone 2 (s = 1). Every
pass is sampled by :mod:`.sampling` so the chord tolerance holds for the CC and the ball-centre
path. ``iter_generate_paths`` is the same as a generator yielding progress, for a modal
operator to drive; ``generate_paths`` simply exhausts it.
"""

from __future__ import annotations

import contextlib
import time

import numpy as np

from ..errors import ConeError, ToleranceError
from ..geometry.axis import Axis
from ..geometry.mesh import TriMesh
from ..kernels import knn as compiled_knn
from ..kernels import lift as compiled_lift
from ..kernels import mesh_tables as compiled_tables
from ..kernels.backend import extension
from ..part.cones import Cone
from ..part.profiles import Profile, morph_between
from ..runtime import Progress, SideThread, alongside_in_turn, workers
from ..toolpath.types import BallTool, PassCurve, ToolPath
from .expansion import (
    PolylineDistance,
    check_tolerances,
    cusp_with_b,
    face_gradient_and_curvature,
    measure_cusp,
    strip_width,
)
from .probe_samples import _ProbeSamples, _workers
from .sampling import CENTRE_CHORD_SHARE, sample_polyline
from .slicing import LevelCurve, MeshConeSlicer
from .trial_levels import level_points_normals, trial_level_work

__all__ = ["Progress", "generate_paths", "iter_generate_paths"]

#: the measured scallop must not exceed this fraction of the tolerance: the generator's
#: measure (ridge interpolated between five levels) runs up to ~2 % below verify's (ridge
#: located on the exact distances, height along the normal)
CUSP_LIMIT = 0.97
#: a pass may end with a scallop this fraction of the tolerance or more, else it is widened
CUSP_ACCEPT = 0.85
#: the cusp aimed at when correcting the side step
CUSP_TARGET = 0.92
#: the ball-centre path may sag between poses by at most this share of the cusp height (and
#: ``CENTRE_CHORD_SHARE`` of the chord tolerance): the sag adds to the scallop, and a pose
#: costs far less machining time than a pass
CENTRE_SAG_SHARE = 0.25
#: safety cap on the number of passes (a path of more passes is not a finishing path)
MAX_PASSES = 20_000
#: spacing (mm, along the ball-centre path) of the probes for parts of the mesh intruding
#: into the ball away from its contact point
INTRUSION_PROBE_SPACING = 1.0
#: probes either side of a hit whose points are lifted as well
INTRUSION_WINDOW = 1
#: a pose lifted by more than this share of the cusp height to clear such an intrusion is
#: reported as uncut (below it the lift is scan noise, not a region the ball cannot reach)
UNCUT_LIFT_SHARE = 0.1
#: an end pass may be moved inside the region (off a ragged boundary, see
#: :meth:`_Generator.end_level`) by at most the width w of the strip it then leaves uncut with
#: w² / 2ρ ≤ this share of the cusp height (the height of a ball's profile w off its contact)
END_INSET_CUSP_SHARE = 0.25


def _cross(u, v):
    """``np.cross`` of (..., 3) arrays, the same products and differences without its
    generic axis handling (this runs on every candidate face of every lifted pose)."""
    u, v = np.broadcast_arrays(u, v)
    out = np.empty(u.shape, dtype=np.result_type(u, v))
    u0, u1, u2 = u[..., 0], u[..., 1], u[..., 2]
    v0, v1, v2 = v[..., 0], v[..., 1], v[..., 2]
    np.multiply(u1, v2, out=out[..., 0])
    out[..., 0] -= u2 * v1
    np.multiply(u2, v0, out=out[..., 1])
    out[..., 1] -= u0 * v2
    np.multiply(u0, v1, out=out[..., 2])
    out[..., 2] -= u1 * v0
    return out


def _point_triangle_distance(p, tri):
    """Distance from points (..., 3) to triangles (..., 3, 3): the foot on the plane if it is
    inside the triangle, else the nearest of the three edges."""
    a, b, c = tri[..., 0, :], tri[..., 1, :], tri[..., 2, :]
    n = _cross(b - a, c - a)
    n2 = np.einsum("...j,...j->...", n, n)
    h = np.einsum("...j,...j->...", p - a, n) / np.where(n2 > 0, n2, 1.0)
    foot = p - h[..., None] * n
    inside = n2 > 0
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("...j,...j->...", _cross(v - u, foot - u), n) >= 0
    best = np.where(inside, np.abs(h) * np.sqrt(n2), np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        uv = v - u
        L2 = np.einsum("...j,...j->...", uv, uv)
        t = np.clip(np.einsum("...j,...j->...", p - u, uv) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        d = p - (u + t[..., None] * uv)
        best = np.minimum(best, np.sqrt(np.einsum("...j,...j->...", d, d)))
    return best


#: a ball centre short of ρ by at most this (mm) counts as clear in the lift's fixed-point
#: steps (:func:`_fixed_point_lift`)
LIFT_TOLERANCE = 1e-7
#: each fixed-point step lifts by the shortfall times this (overshoot, so the steps end)
LIFT_GAIN = 1.05
#: slack (mm) on the plane-distance bound of :func:`_fixed_point_lift`: far above the
#: rounding of a point–plane distance at blade coordinates (~1e-13 mm at 200 mm), far below
#: any distance the lift acts on
PLANE_BOUND_SLACK = 1e-8


def _fixed_point_lift(p, n, lam, tri, valid, rho, steps):
    """λ (mm) per point after up to ``steps`` fixed-point steps that lift the ball centres
    ``p + (ρ + λ) n`` clear of their candidate triangles: while the exact distance d to the
    nearest candidate is below ``ρ − LIFT_TOLERANCE``, λ grows by ``LIFT_GAIN (ρ − d)``.

    Only the triangles whose *plane* comes closer than ``ρ − LIFT_TOLERANCE`` (+ slack) can
    decide a step (a point's distance to a triangle is at least that to its plane), so the
    exact distance is computed for those alone, per candidate, with
    :func:`_point_triangle_distance`: the nearest distance where a step is taken, and so λ,
    are the same as over every candidate (bit for bit: the kernel is elementwise).

    Parameters
    ----------
    p, n : (q, 3) float — points (mm) and unit normals
    lam : (q,) float, mm — λ to start from (not modified)
    tri : (q, c, 3, 3) float, mm — candidate triangles per point
    valid : (q, c) bool — False for padding
    rho : float, mm
    steps : int

    Returns
    -------
    (q,) float, mm
    """
    lam = np.array(lam, dtype=np.float64)
    q = len(p)
    if q == 0 or tri.shape[1] == 0:
        return lam
    a = tri[..., 0, :]
    nrm = _cross(tri[..., 1, :] - a, tri[..., 2, :] - a)  # (q, c, 3), |nrm| = 2 area
    n2 = np.einsum("qcj,qcj->qc", nrm, nrm)
    inv = np.where(n2 > 0, 1.0 / np.sqrt(np.where(n2 > 0, n2, 1.0)), 0.0)  # 0: never pruned
    an = np.einsum("qcj,qcj->qc", a, nrm)
    limit = rho - LIFT_TOLERANCE + PLANE_BOUND_SLACK
    active = np.arange(q)
    for _ in range(steps):
        c = p[active] + (rho + lam[active])[:, None] * n[active]
        plane = np.abs(np.einsum("rj,rcj->rc", c, nrm[active]) - an[active]) * inv[active]
        r, k = np.nonzero(valid[active] & (plane < limit))
        dmin = np.full(len(active), np.inf)
        if len(r):
            d = _point_triangle_distance(c[r], tri[active[r], k])
            cnt = np.bincount(r, minlength=len(active))
            has = cnt > 0
            dmin[has] = np.minimum.reduceat(d, (np.cumsum(cnt) - cnt)[has])
        short = rho - dmin
        still = short > LIFT_TOLERANCE
        lam[active[still]] += short[still] * LIFT_GAIN
        active = active[still]
        if len(active) == 0:
            break
    return lam


def _unique_per_row(ids):
    """Rows of non-negative ids with repeats replaced by −1 and the −1 columns that every
    row has squeezed out: (q, c) → (q, c') int, c' ≤ c."""
    if ids.size == 0:
        return ids
    srt = np.sort(ids, axis=1)
    dup = np.zeros(srt.shape, dtype=bool)
    dup[:, 1:] = srt[:, 1:] == srt[:, :-1]
    srt[dup] = -1
    srt = -np.sort(-srt, axis=1)  # valid ids first, −1 last
    width = int((srt >= 0).sum(axis=1).max())
    return srt[:, : max(width, 1)]


def _in_windows(lo, hi, n):
    """(k,) int64 ascending: the indices in 0..n inside any of the windows ``lo[i]..hi[i]``
    (inclusive, 0 ≤ lo ≤ hi < n)."""
    mark = np.bincount(lo, minlength=n + 1)[: n + 1] - np.bincount(hi + 1, minlength=n + 1)
    return np.nonzero(np.cumsum(mark)[:n] > 0)[0]


def _narrow_ids(n_faces):
    """Whether the vertex-face table of ``n_faces`` faces is kept narrow (:func:`_narrow_table`):
    not for a mesh whose sample ids (vertices + edges + faces ≈ 3.5 × faces) might not fit in
    int32 arithmetic."""
    return 8 * n_faces < 2**31


def _narrow_table(table, n_faces):
    """The vertex-face table ``(ptr, face, corner)`` with the faces as int32 and the corners
    as int8 (the same values; at 1M faces 33 MB less, held through the passes; not copied
    when they are so already), or None. Kept int64 unless :func:`_narrow_ids`."""
    if table is None or not _narrow_ids(n_faces):
        return table
    ptr, face, corner = table
    return ptr, face.astype(np.int32, copy=False), corner.astype(np.int8, copy=False)


def _next_step(trials, target):
    """Next side step Δs aiming the scallop at ``target`` (mm), from the trials (Δs, H) so
    far: the scallop grows like ``a Δs² + b`` (the offset b: chord sag of the centre path,
    facets), fitted on the last two trials; with one trial, or a fit that makes no sense,
    ``H ∝ Δs²``. The caller keeps the result inside its bracket."""
    ds, H = trials[-1]
    if len(trials) >= 2:
        d0, h0 = trials[-2]
        den = ds * ds - d0 * d0
        if abs(den) > 1e-18:
            a = (H - h0) / den
            b = H - a * ds * ds
            if a > 0 and target > b:
                return float(np.sqrt((target - b) / a))
    return ds * float(np.sqrt(target / H)) if H > 0 else 2.0 * ds


class _Generator:
    def __init__(self, mesh, axis, cone1, cone2, radius, cusp, chord):
        check_tolerances(radius, cusp, chord)
        self.mesh = mesh
        self.axis = axis
        # the compiled tables of the intrusion checks (each one compiled call, the GIL
        # released) are built on a side thread while the slicer is set up and the first
        # levels are sliced and sampled; with one thread, on first use (as before). The
        # sample tree first: the first pass asks for it right after this set-up (and waits
        # for it: at 1M faces it takes longer than the set-up and the first level), the
        # faces around each vertex only at its facet lifts, some levels later
        self._tables_result = None
        self._tables = None
        if extension() is not None:
            V, E, F = mesh.V, mesh.edges, mesh.F  # read here: the side thread touches no cache
            n = workers()  # the tree on the caller's threads (its splits run in parallel)
            self._tables_result = alongside_in_turn(
                lambda: compiled_tables.sample_tree(V, E, F, n),
                lambda: _narrow_table(compiled_tables.vertex_face_table(
                    F, len(V), narrow=_narrow_ids(len(F))), len(F)))
        # LMC between two cones, LMRS (paper 001 §4.2) when either generatrix is a Profile
        self.morph = morph_between(cone1, cone2)
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
        self._passes: dict[float, list[PassCurve]] = {}
        self._centre_dist: dict[float, PolylineDistance] = {}
        self._level_samples: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self._uncut_lift: dict[int, np.ndarray] = {}  # id(PassCurve) → intrusion lift per pose
        self._side = SideThread()  # the trials' level work beside their pass (cusp_between)
        #: end (0 or 1) → (ratio of the moved end pass, inset in mm), see :meth:`end_level`
        self.end_inset: dict[int, tuple[float, float]] = {}
        self.max_turn = 2.0 * np.arccos(1.0 - self.chord / (4.0 * self.radius))
        # the centre path's sag between poses adds to the scallop: keep it a small share of h
        self.centre_chord = min(CENTRE_CHORD_SHARE * self.chord, CENTRE_SAG_SHARE * self.cusp)
        #: facet penetrations below this (mm) are not lifted: 0.1 µm, or 1 % of the chord
        self.facet_tolerance = min(1e-4, 0.01 * self.chord)
        #: a pose lifted by more than this (mm) off an intrusion is reported as uncut
        self.uncut_lift = UNCUT_LIFT_SHARE * self.cusp
        self.sample_spacing = max(min(0.25, 0.5 * np.sqrt(8 * self.radius * self.cusp) / 4), 0.02)

    def end_level(self, end: float):
        """The ratio of the first (``end`` = 0) or last (``end`` = 1) pass.

        Normally ``end`` itself. But when a generatrix was *fitted* to the blade's boundary
        loop (least squares, :mod:`..part.fitting`) the loop's vertices lie on both sides of it, up
        to the fit's residual, and the level ``end`` runs in and out of the mesh: Rotor 67's
        hub level broke into 15 open pieces of 2–22 points (23 approach/retract cycles). Then
        the pass is moved a hair into the region: to the level just past every boundary vertex
        that lies inside the region within ``sqrt(2 ρ · END_INSET_CUSP_SHARE · h)`` mm of the
        end generatrix (the strip left between the pass and the boundary then stands at most
        that share of the cusp height under a ball of radius ρ). The move is kept only when it
        leaves fewer open pieces; a level without open pieces (given cones that cut through
        the mesh, a boundary lying on the cone) is never moved, so such paths do not change.
        """
        curves = self.level(end)
        n_open = sum(1 for c in curves if not c.closed)
        if n_open == 0:
            return end
        mesh = self.mesh
        bv = np.unique(mesh.edges[mesh.edge_faces[:, 1] < 0])
        f = self.slicer.vertex_side(end, bv)  # mm, + toward cone 2, 0 within on_tol
        inward = f if end == 0.0 else -f
        reach = float(np.sqrt(2.0 * self.radius * END_INSET_CUSP_SHARE * self.cusp))
        near = bv[(inward > 0) & (inward <= reach)]
        sv = self.slicer.s[near]
        sv = sv[np.isfinite(sv)]
        if len(sv) == 0:
            return end
        edge = float(sv.max() - end) if end == 0.0 else float(end - sv.min())
        s_new = float(end + 1.02 * edge) if end == 0.0 else float(end - 1.02 * edge)
        if not 0.0 < s_new < 1.0:
            return end
        moved = self.level(s_new)
        if not moved or sum(1 for c in moved if not c.closed) >= n_open:
            return end
        self.end_inset[int(end)] = (s_new, float(inward[(inward > 0) & (inward <= reach)].max()))
        return s_new

    def level(self, s):
        if s not in self._levels:
            self._levels[s] = self.slicer.slice(s)
        return self._levels[s]

    def make_pass(self, s):
        """The sampled CC curves of the level ``s`` (list of PassCurve)."""
        out = []
        for c in self.level(s):
            start = None
            if c.closed:  # at the highest point along the axis (meridional's z alone)
                start = int(np.argmax((c.points - self.axis.o) @ self.axis.d))
            edge = c.edge if start is None else np.roll(c.edge, -start)
            rec = {}
            steps = {}  # the forward step's searches, reused where a new sampling changes nothing
            screened = {}  # the poses' screens, likewise

            def lift(D, DN, seg, edge=edge, closed=c.closed, rec=rec):
                if "base" not in rec:  # the densified polyline is the same on every call
                    rec["base"] = self.facet_lift(D, DN, seg, edge, closed)
                    rec["extra"] = self.intrusion_lift(D, DN, rec["base"])
                    rec["D"], rec["DN"] = D, DN
                return rec["base"] + rec["extra"]

            for _ in range(4):
                cc, nn, lam, idx = sample_polyline(
                    c.points, c.normals, c.closed, chord=self.chord, radius=self.radius,
                    start=start, lift=lift, return_index=True, centre_chord=self.centre_chord,
                    memo=steps,
                )
                # a pose whose ball still reaches into the mesh (an intrusion between the
                # probes): lift the points between its neighbouring poses and sample again
                short = self._screened_shortfall(cc + (self.radius + lam)[:, None] * nn, idx,
                                                 screened)
                bad = np.nonzero(short > self.facet_tolerance + 1e-7)[0]
                if len(bad) == 0:
                    break
                lo = idx[np.maximum(bad - 1, 0)]
                hi = np.where(bad + 1 < len(idx), idx[np.minimum(bad + 1, len(idx) - 1)],
                              len(rec["D"]) - 1)
                win = _in_windows(lo, hi, len(rec["D"]))
                total = self._lift_points(rec["D"], rec["DN"], lift(None, None, None), win)
                rec["extra"][win] = total - rec["base"][win]
            # the ball (axis = normal) touches at cc; its tip is cc lifted by λ along n
            out.append(PassCurve(s=s, closed=c.closed, cc=cc, normal=nn, tip=cc + lam[:, None] * nn,
                                 axis=nn.copy()))
            self._uncut_lift[id(out[-1])] = rec["extra"][idx]
        return out

    def _screened_shortfall(self, centres, idx, memo):
        """:meth:`_pose_shortfall` with ``screen`` of the poses ``idx`` (ascending indices
        into the densified polyline) with ball centres ``centres`` (q, 3), taking the answer of
        the last call (kept in ``memo``) for every pose at the same index whose centre has not
        moved: each pose's answer depends on its centre only."""
        out = np.empty(len(centres))
        todo = np.ones(len(centres), dtype=bool)
        if memo:
            pos = np.minimum(np.searchsorted(memo["idx"], idx), len(memo["idx"]) - 1)
            same = (memo["idx"][pos] == idx) & np.all(memo["centres"][pos] == centres, axis=1)
            out[same] = memo["short"][pos[same]]
            todo = ~same
        if np.any(todo):
            out[todo] = self._pose_shortfall(centres[todo], screen=True)
        memo.update(idx=idx, centres=centres, short=out)
        return out

    def _pose_shortfall(self, centres, screen: bool = False):
        """ρ − exact distance (mm) from ball centres to the faces holding the (up to) 8 surface
        samples nearest each within ρ + 0.05 mm (> 0: the ball reaches into the mesh; a face
        reaching into the ball has a sample that close, see :meth:`_probe_tree`). With
        ``screen`` only the centres with a sample deeper than ``facet_tolerance`` inside the
        ball are measured (a cheap, tightly bounded KD search); the others get −inf."""
        if screen:
            out = np.full(len(centres), -np.inf)
            hit = self._any_within(centres, self.radius - self.facet_tolerance)
            if np.any(hit):
                out[hit] = self._pose_shortfall(centres[hit])
            return out
        cand = self._probe_candidates(self._nearest_samples(centres))
        V, F = self.mesh.V, self.mesh.F
        got = compiled_lift.candidate_shortfall(V, F, cand, centres, self.radius, workers())
        if got is not None:
            return got
        d = _point_triangle_distance(centres[:, None, :], V[F[np.maximum(cand, 0)]])
        return self.radius - np.where(cand >= 0, d, np.inf).min(axis=1)

    def _lift_points(self, D, DN, lam, idx):
        """λ (mm) at the points ``idx`` that clears the mesh: fixed-point steps on the exact
        distance to the faces holding the 8 surface samples nearest the centre (while the
        ball is short the intruding samples are nearer than the contact region's, which lie
        ρ away; at the end both are among them)."""
        rho = self.radius
        lam_i = lam[idx]
        # the candidate faces come from the first centres (one KD search per point); the
        # lift only moves the centre away from them
        c0 = D[idx] + (rho + lam_i)[:, None] * DN[idx]
        cand = self._probe_candidates(self._nearest_samples(c0))
        return self._lift(D[idx], DN[idx], lam_i, cand, 12)

    def _lift(self, p, n, lam, cand, steps):
        """:func:`_fixed_point_lift` on the candidate faces ``cand`` (q, c), −1 padded:
        compiled when installed (the same λ), else from their (q, c, 3, 3) corners."""
        got = compiled_lift.fixed_point_lift(
            self.mesh.V, self.mesh.F, cand, p, n, lam,
            (self.radius, LIFT_TOLERANCE, LIFT_GAIN, PLANE_BOUND_SLACK), steps, workers())
        if got is not None:
            return got
        tri = self.mesh.V[self.mesh.F[np.maximum(cand, 0)]]
        return _fixed_point_lift(p, n, lam, tri, cand >= 0, self.radius, steps)

    def intrusion_lift(self, D, DN, lam):
        """Extra λ (mm) where a part of the mesh *away* from the CC point comes closer than ρ
        to the ball centre ``p + (ρ + λ) n``: the surface is concave tighter than the ball
        there (the demo blisk's 8 mm hub fillet where it meets the trailing edge has a concave
        principal radius of 5.7 mm), so touching at ``p`` would gouge elsewhere. The ball is
        lifted along its axis until it clears — it then leaves material at ``p``, which
        :func:`generate_paths` reports (``stats["uncut_poses"]``, ``warnings``) instead of
        gouging silently.

        Probes every ``INTRUSION_PROBE_SPACING`` mm along the centre path: a mesh vertex, edge
        midpoint or face centroid more than 1e-5 mm inside the ball is an intrusion (a face
        can still reach in by up to ≈ L²/(32 ρ), L its longest edge, unseen: 0.3 µm for
        0.3 mm triangles and a 6 mm ball). All points between
        ``INTRUSION_WINDOW`` probes either side of a hit are then lifted by fixed-point steps
        on the exact distance to the faces around the samples nearest the centre
        (:meth:`_lift_points`).
        """
        rho = self.radius
        q = len(D)
        extra = np.zeros(q)
        if q == 0:
            return extra
        got = compiled_lift.intrusion_probes(D, DN, lam, rho, INTRUSION_PROBE_SPACING)
        if got is not None:  # the same probes and centres in one call
            probe, Cp = got
        else:
            C = D + (rho + lam)[:, None] * DN
            arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(C, axis=0), axis=1))])
            at = np.arange(0.0, arc[-1], INTRUSION_PROBE_SPACING)
            probe = np.unique(np.append(np.searchsorted(arc, at), q - 1))
            probe = probe[probe < q]
            Cp = C[probe]
        hp = np.nonzero(self._any_within(Cp, rho - 1e-5))[0]
        if len(hp) == 0:
            return extra
        # a face can reach into the ball while no vertex or centroid does: the windows extend
        # INTRUSION_WINDOW probes either side of a hit
        lo = probe[np.maximum(hp - INTRUSION_WINDOW, 0)]
        hi = probe[np.minimum(hp + INTRUSION_WINDOW, len(probe) - 1)]
        idx = _in_windows(lo, hi, q)
        lam_i = self._lift_points(D, DN, lam, idx)
        extra[idx] = lam_i - lam[idx]
        return extra

    def _probe_samples(self):
        """The surface samples of the intrusion checks — vertices, edge midpoints and face
        centroids: every point of the surface lies within a quarter of its triangle's longest
        edge L of one of them, so a face reaching into the ball by more than ≈ L²/(32 ρ) puts
        one of them inside. Searched through the vertices (:class:`_ProbeSamples`)."""
        if not hasattr(self, "_psamples"):
            self._psamples = _ProbeSamples(self.mesh, self._vertex_face_table(),
                                           self._probe_tree)
        return self._psamples

    def _probe_tree(self):
        """k-d tree over all samples of :meth:`_probe_samples`, whose answers define theirs:
        it finds the 8 nearest of a lift (:meth:`_nearest_samples`) and settles the near ties
        of :class:`_ProbeSamples`; built on first use (a mesh the ball clears everywhere never
        needs it)."""
        if not hasattr(self, "_ptree"):
            from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

            self._ptree = cKDTree(self._probe_samples().all_points(), leafsize=64,
                                  balanced_tree=False, compact_nodes=False)
        return self._ptree

    def _compiled_tables(self, which):
        """The compiled k-d tree over all samples (``which`` 0) or the faces around each
        vertex (1), started when the generator was made (:func:`..runtime.alongside_in_turn`,
        in this order), or None when the numpy kernels run."""
        if self._tables_result is None:
            return None
        if self._tables is None:
            self._tables = [None, None]
        if self._tables[which] is None:
            self._tables[which] = self._tables_result[which]()
        return self._tables[which]

    def _compiled_probe_tree(self):
        """The compiled k-d tree over all samples, or None when the numpy kernels run."""
        if extension() is None:
            return None
        return self._compiled_tables(0)  # the samples of _ProbeSamples.all_points

    def _any_within(self, C, bound):
        """(q,) bool: a surface sample lies closer than ``bound`` mm to the point (q, 3) — the
        full tree's answer (:meth:`_ProbeSamples.any_within`), compiled when installed."""
        tree = self._compiled_probe_tree() if len(C) else None
        if tree is not None:
            return compiled_knn.points_within(tree, C, bound, workers())
        return self._probe_samples().any_within(C, bound)

    def _nearest_samples(self, centres):
        """(q, 8) ids of the samples nearest the ball centres (q, 3) within ρ + 0.05 mm, −1
        where there are fewer, by (squared distance, id): of samples at the same distance
        the lowest ids (a rule of the mesh alone, not of a tree's traversal). The k-d tree
        over all samples (through the vertices, as :class:`_ProbeSamples` does for the
        screens, the candidates of the 8th nearest are ~300 a centre to measure and sort per
        row: 2–3× the tree's own search, measured); compiled when installed."""
        tree = self._compiled_probe_tree()
        if tree is not None:  # (distance, id) order: no row left to scipy
            return compiled_knn.nearest_k(tree, centres, 8, self.radius + 0.05, workers())
        return self._nearest_samples_scipy(centres)

    def _nearest_samples_scipy(self, centres, k=8, extra=4):
        """:meth:`_nearest_samples` by scipy's k-d tree: the k + ``extra`` nearest, ordered
        by (squared distance summed as scipy sums it, id); rows whose last is as near as
        their k-th may hide more samples at that distance and are asked again with more."""
        bound, tree = self.radius + 0.05, self._probe_tree()
        out = np.full((len(centres), k), -1, dtype=np.int64)
        rows = np.arange(len(centres))
        m = k + extra
        while len(rows):
            _, near = tree.query(centres[rows], k=m, distance_upper_bound=bound,
                                 workers=_workers(len(rows)))
            valid = near < tree.n
            near = np.where(valid, near, -1)
            d = tree.data[np.maximum(near, 0)] - centres[rows][:, None, :]
            d2 = np.where(valid, (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1])
                          + d[..., 2] * d[..., 2], np.inf)
            key_id = np.where(valid, near, np.iinfo(np.int64).max)
            order = np.lexsort((key_id, d2), axis=1)[:, :k]
            d2s = np.take_along_axis(d2, order, axis=1)
            out[rows] = np.take_along_axis(near, order, axis=1)
            # every sample nearer than the last found is among the m: the k are exact unless
            # the last is valid and at the k-th's distance
            again = valid[:, -1] & (d2.max(axis=1) == d2s[:, -1])
            rows, m = rows[again], 4 * m
        return out

    def _probe_candidates(self, ids):
        """``_unique_per_row(self._probe_faces(ids))`` (q, c), compiled when installed."""
        got = compiled_lift.probe_candidates(
            ids, len(self.mesh.V), len(self.mesh.F), self.mesh.edge_faces,
            self._vertex_face_table(), workers()) if len(ids) else None
        return got if got is not None else _unique_per_row(self._probe_faces(ids))

    def _probe_faces(self, ids):
        """Faces holding the probe-tree samples ``ids`` (q, k): the ring of a vertex, the two
        faces of an edge midpoint, the face of a centroid. (q, c) int padded with −1."""
        nv, ne = len(self.mesh.V), len(self.mesh.edges)
        q, k = ids.shape
        flat = ids.ravel()
        none = flat < 0  # no sample (outside a search bound)
        isv = (flat < nv) & ~none
        ise = (flat >= nv) & (flat < nv + ne)
        ring = self._vertex_faces(np.where(isv, flat, 0))  # (q k, w)
        ring = np.where(isv[:, None], ring, -1)
        ef = np.where(ise[:, None], self.mesh.edge_faces[np.clip(flat - nv, 0, ne - 1)], -1)
        fc = np.where(~isv & ~ise & ~none, flat - nv - ne, -1)[:, None]
        return np.concatenate([ring, ef, fc], axis=1).reshape(q, -1)

    def facet_lift(self, D, DN, seg, edge, closed):
        """λ (mm) per point so that the ball centre ``p + (ρ + λ) n`` stays at least ρ from the
        faces around ``p``: the smooth normal n differs from the facet normals, and a ball at
        ``p + ρ n`` would sink into a facet by up to ``ρ (1 − n·n_f)``. The faces are those
        around the corners of the two mesh edges bounding the segment the point lies on;
        λ comes from a few fixed-point steps on the exact point–triangle distance."""
        got = compiled_lift.facet_lift(
            (self.mesh.V, self.mesh.F, self.mesh.edges, self.mesh.edge_faces,
             self.mesh.face_normals), self._vertex_face_table(), D, DN, edge, seg, closed,
            (self.radius, self.facet_tolerance, LIFT_TOLERANCE, LIFT_GAIN, PLANE_BOUND_SLACK),
            4, workers()) if len(D) and extension() is not None else None
        if got is not None:  # the same λ, the numpy glue below in one call
            return got
        k = len(edge)
        e0 = edge[np.minimum(seg, k - 1)]
        e1 = edge[(seg + 1) % k] if closed else edge[np.minimum(seg + 1, k - 1)]
        faces = np.concatenate([self.mesh.edge_faces[e0], self.mesh.edge_faces[e1]], axis=1)
        fn = self.mesh.face_normals[np.maximum(faces, 0)]  # (q, 4, 3)
        cos = np.einsum("qj,qfj->qf", DN, fn)
        plane = np.where(faces >= 0, self.radius * (1.0 - np.clip(cos, -1, 1)), 0.0).max(axis=1)
        lam = np.zeros(len(D))
        # only where a facet plane is penetrated by more than a negligible depth (on a fine
        # mesh the facets are within 0.1 µm of the smooth normal's ball almost everywhere)
        need = np.nonzero(plane > self.facet_tolerance)[0]
        if len(need) == 0:
            return lam
        verts = np.unique(self.mesh.edges[np.concatenate([e0[need], e1[need]])])
        ring = self._vertex_faces(verts)  # (len(verts), w) padded with −1
        corners = self.mesh.edges[np.stack([e0[need], e1[need]], 1)].reshape(len(need), 4)
        pos = np.searchsorted(verts, corners)
        cand = _unique_per_row(ring[pos].reshape(len(need), -1))  # (q', c) padded with −1
        lam[need] = self._lift(D[need], DN[need], np.zeros(len(need)), cand, 4)
        return lam

    def _vertex_face_table(self):
        """The faces around each vertex, made once: (ptr (nv + 1,), face (3 m,), corner
        (3 m,)) — the faces of vertex v are ``face[ptr[v]:ptr[v + 1]]`` (ascending), v being
        their corner ``corner[...]``."""
        if not hasattr(self, "_vf"):
            self._vf = self._compiled_tables(1)
        if self._vf is None:
            F = self.mesh.F
            order = np.argsort(F.ravel(), kind="stable")
            vs = F.ravel()[order]
            self._vf = _narrow_table((np.searchsorted(vs, np.arange(len(self.mesh.V) + 1)),
                                      order // 3, order % 3), len(F))
        return self._vf

    def _vertex_faces(self, verts):
        """(len(verts), w) faces around each vertex, padded with −1."""
        ptr, fids = self._vertex_face_table()[:2]
        cnt = ptr[verts + 1] - ptr[verts]
        w = int(cnt.max()) if len(cnt) else 0
        idx = ptr[verts][:, None] + np.arange(w)[None, :]
        valid = np.arange(w)[None, :] < cnt[:, None]
        return np.where(valid, fids[np.minimum(idx, len(fids) - 1)], -1)

    def sampled_pass(self, s):
        """The sampled pass at ``s`` (list of PassCurve), made once and cached."""
        if s not in self._passes:
            self._passes[s] = self.make_pass(s)
        return self._passes[s]

    def centre_distance(self, s):
        """Distance to the ball-centre polylines of the *sampled* pass at ``s`` — the straight
        moves between the poses as machined, so the chord sag of the centre path is part of
        the measured scallop (verify measures the same thing). Poses lifted off an intrusion
        (:meth:`intrusion_lift`) count without that lift: material the ball cannot reach
        there is reported, not chased with ever smaller side steps."""
        if s not in self._centre_dist:  # the pass is cached, so is its KD-tree
            polys = [
                (c.tip + (self.radius - self._uncut_lift[id(c)])[:, None] * c.axis, c.closed)
                for c in self.sampled_pass(s)
            ]
            self._centre_dist[s] = PolylineDistance(polys, resample=self.sample_spacing)
        return self._centre_dist[s]

    def level_samples(self, s):
        """Surface points ``sample_spacing`` apart on the level ``s`` and their normals."""
        if s not in self._level_samples:
            self._level_samples[s] = level_points_normals(self.level(s), self.sample_spacing,
                                                          self.radius)
        return self._level_samples[s]

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
        """Largest scallop (mm) between the sampled passes at ``s_a`` and ``s_b``, from surface
        points on the two levels and three levels between them.

        With several threads (and the compiled kernels) the level work that pass B does not
        enter (:func:`.trial_levels.trial_level_work`) runs on a side thread while pass B is
        made here; its levels and samples are cached here afterwards. The same floats: each
        piece is computed as in the one-thread order."""
        fr = (0.0, 0.25, 0.5, 0.75, 1.0)
        keys = [s_b if f == 1.0 else s_a + f * (s_b - s_a) for f in fr]
        if workers() < 2 or extension() is None or s_b in self._centre_dist:
            samples = [self.level_samples(k) for k in keys]
            dist_b = self.centre_distance(s_b)
            return measure_cusp([x[0] for x in samples], dist_a, dist_b, self.radius,
                                level_normals=[x[1] for x in samples])
        levels = {k: self._levels[k] for k in keys if k in self._levels}
        known = {k: self._level_samples[k] for k in keys if k in self._level_samples}
        side = self._side.alongside(lambda: trial_level_work(
            self.slicer, keys, levels, known, self.sample_spacing, self.radius, dist_a))
        try:
            dist_b = self.centre_distance(s_b)
        except BaseException:
            with contextlib.suppress(Exception):  # the side thread ends before the error
                side()  # goes up (it reads this generator's state)
            raise
        new_levels, new_samples, side_a = side()
        self._levels.update(new_levels)
        self._level_samples.update(new_samples)
        return cusp_with_b(side_a, dist_b, self.radius)

    def run(self):
        """Generator: the slice → sample → expand loop of paper 001, pass after pass; yields
        :class:`Progress` between levels and sets ``self.result`` (ToolPath)."""
        with self._side:  # its thread ends with the run (also when the run is dropped)
            yield from self._run()

    def _run(self):
        """:meth:`run`'s loop."""
        t0 = time.perf_counter()
        h = self.cusp
        self._check_end_levels()
        s_lo, s_hi = self.end_level(0.0), self.end_level(1.0)
        passes = [self.sampled_pass(s_lo)]
        cusps = []
        s = s_lo
        prev = None  # (predicted Δs, accepted Δs) of the last pass
        while s < s_hi:
            if len(passes) > MAX_PASSES:
                raise ToleranceError(
                    f"more than {MAX_PASSES} passes needed: the cusp height {h} mm is far too "
                    f"small for a Ø{2 * self.radius:g} ball (or its equivalent) on this blade"
                )
            pred, (ds, H, s_new) = self._next_level(s, s_hi, prev)
            if s_new < s_hi:
                prev = (pred, ds)
            passes.append(self.sampled_pass(s_new))
            cusps.append(H)
            # release the caches we no longer need (keep the current level and pass)
            for key in [k for k in self._levels if k < s_new]:
                del self._levels[key]
            for key in [k for k in self._passes if k != s_new]:
                del self._passes[key]
            s = s_new
            yield Progress(min(s, 1.0), f"pass {len(passes)} at s = {s:.4f}, cusp {H:.4f} mm")
        self._set_result(passes, cusps, s_lo, s_hi, t0)

    def _check_end_levels(self):
        """Raise ConeError when cone 1 or cone 2 does not cut the blade mesh."""
        lo, hi = self.slicer.s_range
        if not self.level(0.0):
            raise ConeError(
                f"cone 1 does not cut the blade mesh (the mesh's morph ratios run from {lo:.3f} "
                f"to {hi:.3f}); move cone 1 onto the blade's hub end"
            )
        if not self.level(1.0):
            raise ConeError(
                f"cone 2 does not cut the blade mesh (the mesh's morph ratios run from {lo:.3f} "
                f"to {hi:.3f}); move cone 2 onto the blade's tip end"
            )

    def _next_level(self, s, s_hi, prev):
        """The next pass after level s: (predicted Δs, (Δs, its cusp H mm, level s + Δs)),
        the largest trial step whose cusp holds (secant steps toward CUSP_TARGET · h)."""
        h = self.cusp
        dist_a = self.centre_distance(s)
        pred = max(self.predict_step(s), 1e-6)
        # Eq. 13 knows neither the chord sag of the centre path nor the facets; the last
        # measured step, scaled by the change of the prediction, does
        ds = min(pred if prev is None else prev[1] * pred / prev[0], s_hi - s)
        feasible = None  # (ds, H, s_new)
        infeasible = None  # smallest ds known to exceed h
        trials = []
        for _ in range(12):
            s_new = s_hi if ds >= s_hi - s - 1e-12 else s + ds
            if not self.level(s_new):
                raise ConeError(
                    f"the LMC at s = {s_new:.4f} does not cut the mesh: the blade has a gap "
                    "across the whole region between the cones; check the mesh"
                )
            H = self.cusp_between(s, dist_a, s_new)
            if H <= CUSP_LIMIT * h:
                if feasible is None or ds > feasible[0]:
                    feasible = (ds, H, s_new)
                if s_new >= s_hi or H >= CUSP_ACCEPT * h:
                    break
            else:
                infeasible = ds if infeasible is None else min(infeasible, ds)
            trials.append((ds, H))
            guess = _next_step(trials, CUSP_TARGET * h)
            lo_b = feasible[0] if feasible else 0.0
            hi_b = infeasible if infeasible is not None else s_hi - s
            if not (lo_b < guess < hi_b):
                guess = 0.5 * (lo_b + hi_b) if infeasible is not None else min(2 * ds, hi_b)
            if feasible and feasible[0] >= s_hi - s - 1e-12:
                break
            if abs(guess - ds) <= 1e-9:
                break
            ds = min(guess, s_hi - s)
        if feasible is None:
            raise ToleranceError(
                f"cannot hold the cusp height {h} mm after s = {s:.4f}: even a tiny side "
                f"step leaves more (a concave region tighter than the "
                f"Ø{2 * self.radius:g} ball, or a mesh fold); use a smaller ball or check the "
                "mesh there"
            )
        return pred, feasible

    def _set_result(self, passes, cusps, s_lo, s_hi, t0):
        """``self.result``: the ToolPath of the sampled passes, with its stats and warnings."""
        curves = [c for p in passes for c in p]
        warnings = []
        uncut = []  # (s, poses, max lift) of the curves with poses lifted off an intrusion
        for c in curves:
            extra = self._uncut_lift[id(c)]
            if np.any(extra > self.uncut_lift):
                uncut.append((c.s, int(np.sum(extra > self.uncut_lift)), float(extra.max())))
        if uncut:
            su = [u[0] for u in uncut]
            warnings.append(
                f"{sum(u[1] for u in uncut)} poses between s = {min(su):.4f} and "
                f"{max(su):.4f} were lifted by up to {max(u[2] for u in uncut):.4f} mm off "
                f"the surface: it is concave tighter than the Ø{2 * self.radius:g} ball there (the "
                "ball would gouge elsewhere), so material is left; use a smaller ball there"
            )
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
                "uncut_poses": int(sum(u[1] for u in uncut)),
                "max_uncut_lift": float(max((u[2] for u in uncut), default=0.0)),
                "uncut_s": [float(u[0]) for u in uncut],
                "warnings": warnings,
                "seconds": time.perf_counter() - t0,
            },
        )
        if self.end_inset:  # only then: paths whose end levels were not moved stay identical
            self.result.stats["end_levels"] = [float(s_lo), float(s_hi)]
            self.result.stats["end_inset_mm"] = [
                float(self.end_inset[k][1]) if k in self.end_inset else 0.0 for k in (0, 1)
            ]


def iter_generate_paths(
    mesh: TriMesh, axis: Axis, cone1: Cone | Profile, cone2: Cone | Profile, *,
    tool_radius: float, cusp: float, chord: float,
):
    """Generator form of :func:`generate_paths`: yields :class:`Progress`, returns the
    :class:`ToolPath` as the generator's return value (``StopIteration.value``)."""
    gen = _Generator(mesh, axis, cone1, cone2, tool_radius, cusp, chord)
    yield from gen.run()
    return gen.result


def generate_paths(
    mesh: TriMesh, axis: Axis, cone1: Cone | Profile, cone2: Cone | Profile, *,
    tool_radius: float, cusp: float, chord: float,
) -> ToolPath:
    """Boundary-conformed finishing passes for a ball of ``tool_radius`` (mm) between
    ``cone1`` (s = 0) and ``cone2`` (s = 1), scallop ≤ ``cusp`` and chord error ≤ ``chord`` (mm).

    Raises
    ------
    ConeError, ToleranceError, MeshError with a message that names the problem.
    """
    it = iter_generate_paths(
        mesh, axis, cone1, cone2, tool_radius=tool_radius, cusp=cusp, chord=chord
    )
    while True:
        try:
            next(it)
        except StopIteration as stop:
            return stop.value
