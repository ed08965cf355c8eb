"""Local gouge check: the cutter must curve at least as much as a concave surface it touches.

At a CC point, in a tangent direction d, the surface has the normal curvature κ_s(d) (> 0
convex, < 0 concave, outward normals) and the cutter, as it sweeps along the pass, the
effective radius R_c(d) (:meth:`..tool.cutter.Cutter.effective_radius`: ρ for a ball, r + (R −
r)/sin λ across the feed for a bull nose at lead λ, ∞ for a flat bottom flush with the surface). Two
surfaces touching at a point with the tool above: the cutter stays out of the material near
the contact in direction d iff ``1/R_c(d) + κ_s(d) ≥ 0``; on a concave region that is
``R_c(d) ≤ 1/|κ_s(d)|`` (paper 003 §IV.B: "the cutter orientation should be restricted in an
adequate range for avoiding local interference"). We check the feed direction f and the side
direction k = f × n.

κ_s comes from the per-face Jacobian of the linearly interpolated vertex normals,
``κ_s(d) = d · (∂n/∂x) d`` (the curvature tool of :mod:`.expansion`), taken at the face the CC
point lies on.

Where a pose gouges and the axis is given by lead/tilt, :func:`fix_local_gouges` searches the
smallest change of lead and tilt within the limits that clears both directions (for bull-nose
and flat cutters a larger lead shrinks the cross-feed radius; a ball cannot be fixed — its
radius is the same in every orientation) and reports what is left.

The curvature test is second order at the contact. Where the curvature changes within the
cutter's reach (a hub fillet running into a trailing edge) :func:`fix_near_gouges` measures
the posed cutter against the surface samples around the contact (exact signed distance) and
searches the same lead/tilt changes until nothing lies deeper than a tolerance; what no change
within the limits clears is flagged, never hidden.

Lengths mm, curvatures 1/mm, angles radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import BliskCamError
from ..geometry.mesh import TriMesh
from .orientation import MAX_ANGLE, lead_tilt_axes

__all__ = [
    "GougeLimits",
    "LocalGougeReport",
    "fix_local_gouges",
    "fix_near_gouges",
    "gouge_margin",
    "requested_margin",
    "search_fixes",
    "surface_normal_curvature",
]


@dataclass(frozen=True)
class GougeLimits:
    """How far lead/tilt may be raised to clear a local gouge.

    max_lead, max_tilt : float, radians — largest |lead|, |tilt| allowed after the fix
    step : float, radians — search step
    """

    max_lead: float = math.radians(30.0)
    max_tilt: float = math.radians(20.0)
    step: float = math.radians(1.0)

    def __post_init__(self):
        for name in ("max_lead", "max_tilt"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and 0.0 <= v <= MAX_ANGLE):
                raise BliskCamError(f"local gouge fix: {name} must lie in [0°, 89°], got {v!r} rad")
        if not (math.isfinite(self.step) and 0.0 < self.step <= math.radians(10.0)):
            raise BliskCamError("local gouge fix: the search step must lie in (0°, 10°]")


@dataclass
class LocalGougeReport:
    """Figures of the local gouge check (per path).

    n_poses : poses checked; n_flagged : poses gouging with the requested axis;
    n_fixed : of those, cleared by changing lead/tilt; n_left : still gouging;
    worst : the most negative margin ``1/R_c + κ_s`` left (1/mm; 0 when nothing is left);
    left_at : (q, 3) CC points still gouging
    """

    n_poses: int = 0
    n_flagged: int = 0
    n_fixed: int = 0
    n_left: int = 0
    worst: float = 0.0
    left_at: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def add(self, other: LocalGougeReport) -> None:
        self.n_poses += other.n_poses
        self.n_flagged += other.n_flagged
        self.n_fixed += other.n_fixed
        self.n_left += other.n_left
        self.worst = min(self.worst, other.worst)
        self.left_at = np.vstack([self.left_at, other.left_at])

    def summary(self) -> dict:
        return {
            "poses": self.n_poses,
            "flagged": self.n_flagged,
            "fixed": self.n_fixed,
            "left": self.n_left,
            "worst_margin_per_mm": float(self.worst),
        }


def surface_normal_curvature(mesh: TriMesh, faces, directions):
    """(k,) normal curvature (1/mm, > 0 convex) of the mesh along unit tangent ``directions``
    (k, 3) in ``faces`` (k,): ``d · J d`` with J the face's Jacobian of the interpolated
    vertex normals (symmetric part)."""
    faces = np.asarray(faces, dtype=np.int64)
    V, F = mesh.V, mesh.F[faces]
    fn = mesh.face_normals[faces]
    area2 = mesh.face_areas[faces] * 2.0
    inv = np.where(area2 > 0, 1.0 / np.where(area2 > 0, area2, 1.0), 0.0)
    vn = mesh.vertex_normals
    d = np.asarray(directions, dtype=np.float64)
    out = np.zeros(len(faces))
    for i in range(3):
        e = V[F[:, (i + 2) % 3]] - V[F[:, (i + 1) % 3]]
        g = np.cross(fn, e) * inv[:, None]  # gradient of corner i's hat function
        out += np.einsum("ij,ij->i", d, vn[F[:, i]]) * np.einsum("ij,ij->i", g, d)
    return out


def gouge_margin(cutter, normal, axis, f, k, kappa_f, kappa_k):
    """(k,) ``min over d in (f, k) of 1/R_c(d) + κ_s(d)`` (1/mm); < 0 gouges."""
    with np.errstate(divide="ignore"):
        eff_f, eff_k = cutter.effective_radii(normal, axis, f, k)
        inv_f, inv_k = 1.0 / eff_f, 1.0 / eff_k
    return np.minimum(inv_f + kappa_f, inv_k + kappa_k)


def _unfixable(cutter, kappa_f, kappa_k, tol):
    """(q,) bool: poses no lead/tilt can clear, known without trying them — for a ball
    (e = 0, no bottom or side angle) only. Its effective radius is ρ cos² + ρ sin² = ρ for
    every axis (to a few roundings, far below the 1e-12 kept here), so the margin
    min(1/R + κ_f, 1/R + κ_k) stays below −tol for every candidate when it does with R a
    hair under ρ; and its contact never fails (a lead/tilt axis n + tan(lead) f + tan(tilt) k
    has a · n > 0, inside the ball's 90°), so skipping these poses changes no chunk of the
    search. Other cutters: none (their radius depends on the axis)."""
    kappa_f, kappa_k = np.asarray(kappa_f, float), np.asarray(kappa_k, float)
    if not (cutter.e == 0.0 and cutter.alpha == 0.0 and cutter.beta == 0.0 and cutter.r > 0):
        return np.zeros(len(kappa_f), dtype=bool)
    inv = 1.0 / (cutter.r * (1.0 - 1e-12))
    best = np.minimum(inv + kappa_f, inv + kappa_k)
    return best + 1e-12 * (inv + np.abs(kappa_f) + np.abs(kappa_k)) < -tol


def fix_local_gouges(
    cutter,
    f,
    n,
    k,
    lead,
    tilt,
    kappa_f,
    kappa_k,
    limits: GougeLimits,
    *,
    fix: bool = True,
    tol: float = 1e-6,
):
    """Flag local gouges of lead/tilt poses and, where possible, change lead/tilt to clear them.

    Parameters
    ----------
    cutter : Cutter
    f, n, k : (m, 3) — local frames of the poses
    lead, tilt : (m,) radians — requested
    kappa_f, kappa_k : (m,) 1/mm — surface normal curvature along f and k
    limits : GougeLimits
    fix : bool — False only flags
    tol : float, 1/mm — margin below which a pose counts as gouging

    Returns
    -------
    lead, tilt : (m,) — after the fix
    flagged : (m,) bool — gouging as requested
    left : (m,) bool — still gouging
    margin : (m,) 1/mm — final margins
    """
    lead = np.asarray(lead, dtype=np.float64).copy()
    tilt = np.asarray(tilt, dtype=np.float64).copy()
    margin = requested_margin(cutter, f, n, k, lead, tilt, kappa_f, kappa_k)
    flagged = margin < -tol
    left = flagged.copy()
    if fix:
        search_fixes(cutter, f, n, k, lead, tilt, kappa_f, kappa_k, limits, margin, flagged,
                     left, tol=tol)
    return lead, tilt, flagged, left, margin


def requested_margin(cutter, f, n, k, lead, tilt, kappa_f, kappa_k):
    """(m,) 1/mm — the gouge margin (:func:`gouge_margin`) of the requested lead/tilt
    (m,) in the frames f, n, k (m, 3): each pose's own figure (the orient stage computes it
    for all passes at once, then searches each pass's flagged poses,
    :func:`search_fixes`)."""
    axes = lead_tilt_axes(f, n, k, lead, tilt)
    return gouge_margin(cutter, n, axes, f, k, kappa_f, kappa_k)


def _candidate_steps(limits: GougeLimits):
    """(ΔL, ΔT) (c,) radians — the lead and tilt changes the fix tries, smallest first
    (a function of the limits alone: made once per limits, ~30 000 of them sorted)."""
    key = (float(limits.step), float(limits.max_lead), float(limits.max_tilt))
    got = _CANDIDATES.get(key)
    if got is None:
        st = key[0]
        dl = np.arange(0.0, 2 * limits.max_lead + st / 2, st)
        dt = np.arange(-2 * limits.max_tilt, 2 * limits.max_tilt + st / 2, st)
        DL, DT = np.meshgrid(dl, dt, indexing="ij")
        cost = np.hypot(DL, DT).ravel()
        order = np.argsort(cost, kind="stable")
        got = (DL.ravel()[order], DT.ravel()[order])
        for a in got:
            a.flags.writeable = False
        if len(_CANDIDATES) > 8:
            _CANDIDATES.clear()
        _CANDIDATES[key] = got
    return got


_CANDIDATES: dict = {}


def search_fixes(cutter, f, n, k, lead, tilt, kappa_f, kappa_k, limits: GougeLimits,
                 margin, flagged, left, *, tol: float = 1e-6) -> None:
    """The search of :func:`fix_local_gouges` over the ``flagged`` poses of one pass, in
    place: ``lead``, ``tilt`` (m,) of the poses fixed become the cheapest change that
    clears them, ``left`` (m,) bool turns False there and ``margin`` (m,) is theirs."""
    idx = np.nonzero(flagged)[0]
    if len(idx) == 0:
        return
    hopeless = _unfixable(cutter, kappa_f[idx], kappa_k[idx], tol)
    if hopeless.all():  # nothing to search (a ball larger than the fillet: every pass there)
        return
    # candidate changes, smallest first: raise |lead| (away from 0 in its sign, + if 0) and
    # move tilt either way, within the limits
    DL, DT = _candidate_steps(limits)
    q = len(idx)
    sgn = np.where(lead[idx] < 0, -1.0, 1.0)
    cand_lead = lead[idx][:, None] + sgn[:, None] * DL[None, :]
    cand_tilt = tilt[idx][:, None] + DT[None, :]
    ok = (np.abs(cand_lead) <= limits.max_lead + 1e-12) & (
        np.abs(cand_tilt) <= limits.max_tilt + 1e-12
    )
    best = np.full(q, -1)
    chunk = max(1, 200_000 // max(q, 1))
    for c0 in range(0, len(DL), chunk):
        sl = slice(c0, c0 + chunk)
        open_ = (best < 0) & ~hopeless
        if not np.any(open_):
            break
        qi, cj = np.nonzero(ok[:, sl] & open_[:, None])
        if len(qi) == 0:
            continue
        cj = cj + c0
        ii = idx[qi]
        ax = lead_tilt_axes(f[ii], n[ii], k[ii], cand_lead[qi, cj], cand_tilt[qi, cj])
        try:
            m = gouge_margin(cutter, n[ii], ax, f[ii], k[ii], kappa_f[ii], kappa_k[ii])
        except BliskCamError:  # an orientation beyond the cutter's side: not a candidate
            continue
        good = m >= -tol
        # first (cheapest) good candidate per pose
        gq, gc = qi[good], cj[good]
        firsts = np.full(q, np.iinfo(np.int64).max)
        np.minimum.at(firsts, gq, gc)
        newly = open_ & (firsts < np.iinfo(np.int64).max)
        best[newly] = firsts[newly]
    fixed = best >= 0
    sel = idx[fixed]
    lead[sel] = cand_lead[np.nonzero(fixed)[0], best[fixed]]
    tilt[sel] = cand_tilt[np.nonzero(fixed)[0], best[fixed]]
    left[sel] = False
    if len(sel):
        ax = lead_tilt_axes(f[sel], n[sel], k[sel], lead[sel], tilt[sel])
        margin[sel] = gouge_margin(cutter, n[sel], ax, f[sel], k[sel], kappa_f[sel], kappa_k[sel])


def fix_near_gouges(
    cutter,
    samples,
    cc,
    f,
    n,
    k,
    lead,
    tilt,
    limits: GougeLimits,
    *,
    tol: float,
    fix: bool = True,
    tree=None,
    chunk: int = 64,
):
    """Flag poses whose cutter reaches into the surface *away* from the contact and, where
    possible, change lead/tilt until it clears.

    The curvature test of :func:`fix_local_gouges` is second order at the CC point; where the
    surface curvature changes within the cutter's reach (a hub fillet meeting a trailing edge,
    the demo blisk's 4.2 mm concave corner) the cutter can still cut into the surface a few
    millimetres away. Here every pose is checked against the surface ``samples`` (mesh
    vertices and face centroids) within its bounding radius with the cutter's exact signed
    distance (:meth:`..tool.cutter.Cutter.signed_distance`); a pose deeper than ``tol`` tries the
    same lead/tilt changes as :func:`fix_local_gouges`, cheapest first, until one clears.

    Parameters
    ----------
    cutter : Cutter
    samples : (q, 3) mm — surface points
    cc, f, n, k : (m, 3) — CC points and local frames
    lead, tilt : (m,) radians — current
    limits : GougeLimits
    tol : float, mm — depth accepted
    fix : bool — False only flags
    tree : scipy.spatial.cKDTree of ``samples`` or None (built)

    Returns
    -------
    lead, tilt : (m,) — after the fix
    flagged : (m,) bool — deeper than ``tol`` before; left : still deeper
    depth : (m,) mm — final depth (≥ 0)
    """

    from scipy.spatial import cKDTree  # optional: on first use (~60 ms)

    S = np.asarray(samples, dtype=np.float64)
    tree = cKDTree(S) if tree is None else tree
    lead = np.asarray(lead, dtype=np.float64).copy()
    tilt = np.asarray(tilt, dtype=np.float64).copy()
    near = tree.query_ball_point(cc, r=2.0 * cutter.radius)  # the cutting end's near field
    cnt = np.array([len(x) for x in near])
    pose = np.repeat(np.arange(len(cc)), cnt)
    pts = np.concatenate([np.asarray(x, dtype=np.int64) for x in near]) if len(pose) else pose

    # depth of every pose as it stands: only the (point, pose) pairs inside the cylinder of
    # the cutter's largest radius about its axis, above the tip, can be inside the cutter
    ax = lead_tilt_axes(f, n, k, lead, tilt)
    tip = cutter.cl_points(cc, n, ax)
    rel = S[pts] - tip[pose]
    t = np.einsum("ij,ij->i", rel, ax[pose])
    inside = (t > -1e-6) & (
        np.einsum("ij,ij->i", rel, rel) - t * t < (cutter.max_radius + 1e-6) ** 2
    )
    pp, qq = pose[inside], pts[inside]
    depth = np.zeros(len(cc))
    np.maximum.at(depth, pp, -cutter.signed_distance(S[qq], tip[pp], ax[pp]))
    flagged = depth > tol
    left = flagged.copy()
    if not fix or not flagged.any():
        return lead, tilt, flagged, left, depth
    st = float(limits.step)
    dl = np.arange(0.0, 2 * limits.max_lead + st / 2, st)
    dt = np.arange(-2 * limits.max_tilt, 2 * limits.max_tilt + st / 2, st)
    DL, DT = (x.ravel() for x in np.meshgrid(dl, dt, indexing="ij"))
    order = np.argsort(np.hypot(DL, DT), kind="stable")
    DL, DT = DL[order], DT[order]
    for i in np.nonzero(flagged)[0]:  # few poses (concave corners): one at a time
        own = pts[pose == i]
        sgn = -1.0 if lead[i] < 0 else 1.0
        cl = lead[i] + sgn * DL
        ct = tilt[i] + DT
        ok = (np.abs(cl) <= limits.max_lead + 1e-12) & (np.abs(ct) <= limits.max_tilt + 1e-12)
        cl, ct = cl[ok], ct[ok]
        for c0 in range(1, len(cl), chunk):  # candidate 0 is the current axis
            c = slice(c0, c0 + chunk)
            try:
                d = _depth_candidates(cutter, S, own, cc[i], f[i], n[i], k[i], cl[c], ct[c])
            except BliskCamError:
                continue
            good = np.nonzero(d <= tol)[0]
            if len(good):
                j = c0 + int(good[0])
                lead[i], tilt[i], depth[i], left[i] = cl[j], ct[j], d[good[0]], False
                break
    return lead, tilt, flagged, left, depth


def _depth_candidates(cutter, S, near, cc, f, n, k, leads, tilts):
    """(c,) depth of the surface points ``S[near]`` inside the cutter posed at one CC point
    with each candidate (lead, tilt) (pairs outside the cutter's bounding cylinder skipped)."""
    c = len(leads)
    F, N, K = (np.broadcast_to(v, (c, 3)) for v in (f, n, k))
    ax = lead_tilt_axes(F, N, K, leads, tilts)
    tip = cutter.cl_points(np.broadcast_to(cc, (c, 3)), N, ax)
    P = S[near]
    out = np.zeros(c)
    if len(P) == 0:
        return out
    rel = P[None, :, :] - tip[:, None, :]  # (c, q, 3)
    t = np.einsum("cqi,ci->cq", rel, ax)
    r2 = np.einsum("cqi,cqi->cq", rel, rel) - t * t
    inside = (t > -1e-6) & (r2 < (cutter.max_radius + 1e-6) ** 2)
    ci, qi = np.nonzero(inside)
    np.maximum.at(out, ci, -cutter.signed_distance(P[qi], tip[ci], ax[ci]))
    return out
