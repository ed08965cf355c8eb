"""The spacing radius of the LMC passes: the radius the cusp-height expansion (paper 001
§3.2) is run with, from the cutter (DIN 66215 shape, lead and tilt) and the surface's smallest
convex and concave radii. mm, radians.

:mod:`.passes` spaces passes for a ball. With lead/tilt given in the local frame, the cutter's
swept envelope across the feed does not depend on the surface, so the passes are spaced for
the ball that leaves the same scallop at the same step (:func:`expansion_radius`), the
smallest over the requested lead/tilt range (the conservative choice). Two surface figures
enter (:func:`surface_radii`): the smallest convex radius — a bull nose's or flat end's
envelope trails the contact, and rolled around a thin leading edge it covers less than on a
plane (issue #4: a flat at lead 10° left 0.17 mm for 0.05 mm at the demo blade's 0.3 mm
edges) — and the smallest concave radius, which decides whether the cutter fits a hub fillet
(:func:`lead_for_concave`). The true tips then come from the cutter itself. For fixed-axis
modes the inclination is not known in advance and the range 0–80° is used.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BliskCamError
from ..geometry.axis import Axis
from ..geometry.mesh import TriMesh
from ..tool.cutter import Cutter
from .orientation import (
    AxisStrategy,
    lead_tilt_axes,
)

__all__ = ["convex_edge_radius", "surface_radii", "expansion_radius"]
#: largest ball radius the passes are spaced for, as a multiple of the tool radius (a flat
#: bottom at a small lead has a very large cross-feed radius)
MAX_EXPANSION_FACTOR = 20.0


def _cusp_equivalent_radius(cutter: Cutter, axis, cusp: float, edge_radius: float = math.inf):
    """Radius (mm) of the ball that leaves the same scallop ``cusp`` at the same side step as
    ``cutter`` posed with unit ``axis`` (3,) in the frame f = x, n = z, k = f × n — on a plane
    (``edge_radius`` ∞) or on a convex cylinder of radius ``edge_radius`` about k (a leading or
    trailing edge, the pass running around it).

    Why the edge matters. Across the feed, a posed ball's envelope is a great circle through
    the contact (feed offset x = 0 at every side offset y); a bull nose's or flat end's is not:
    with lead λ the point of a flat's bottom rim at side offset y trails the contact by
    x ≈ cos λ · y² / 2R while rising only z ≈ sin λ · y² / 2R. On a plane only z counts; as the
    tool rolls around an edge of radius r_e (the pass turning about k) the point sweeps a circle
    about the edge's axis at the distance ``hypot(x, z + r_e) − r_e ≈ z + x² / 2 r_e`` from the
    surface, so the rim covers less across the feed — the demo blade's 0.3 mm edges left
    0.17 mm for a 0.05 mm tolerance with a flat at lead 10° spaced for the plane (issue #4).

    The envelope's cross-section (height above the surface over y) is the lower boundary of the
    cutter's points mapped to (y, height), sampled from the revolved profile and binned in y;
    the step w whose neighbouring passes cross at height ``cusp`` is bisected, and a ball of
    radius (w²/4 + h²)/2h has the same step on a plane. The ball rolling around the same edge
    leaves the same scallop as on the plane (its envelope has x = 0), so spacing for this ball
    holds the tolerance on the edge as well."""
    n = np.array([0.0, 0.0, 1.0])
    f = np.array([1.0, 0.0, 0.0])
    k = np.cross(f, n)
    off = cutter.cl_points(np.zeros((1, 3)), n[None], axis[None])[0]  # tip for cc = origin
    prof0 = cutter.profile(128)
    prof0 = prof0[: int(np.searchsorted(prof0[:, 1], cutter.radius, side="right")) + 1]
    seg = np.linalg.norm(np.diff(prof0, axis=0), axis=1)
    t0 = np.concatenate([[0.0], np.cumsum(seg)])  # arc length along the profile

    def resample(ta, tb, step):  # profile points every ``step`` mm of arc in [ta, tb]
        tt = np.linspace(ta, tb, int((tb - ta) / step) + 2)
        return tt, np.stack([np.interp(tt, t0, prof0[:, j]) for j in (0, 1)], 1)

    u1 = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
    u1 /= np.linalg.norm(u1)
    u2 = np.cross(axis, u1)
    re = float(edge_radius)

    def points(prof, ph):  # (y, height) (p, a) of the profile revolved to the angles ph
        radial = np.cos(ph)[:, None] * u1 + np.sin(ph)[:, None] * u2  # (a, 3)
        P = off + prof[:, 0, None, None] * radial[None] + prof[:, 1, None, None] * axis
        x, y, z = P @ f, P @ k, P @ n
        h = np.hypot(x, z + re) - re if math.isfinite(re) else z
        return y, h

    # coarse samples find where the cutter comes within 2 cusp of the surface; fine samples
    # there (4 µm along the profile, 1/32° about the axis): a flat's rim is a sharp edge, and
    # rolled around an edge only the points of one angle come close — every 5 µm bin below
    # must hold points of the true boundary
    tc, pc = resample(0.0, t0[-1], 0.03)
    coarse = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    _, h = points(pc, coarse)
    close = h <= 2.0 * cusp
    near = np.nonzero(close.any(axis=0))[0]
    near = np.unique(np.concatenate([near - 1, near, near + 1]) % len(coarse))
    rows = np.nonzero(close.any(axis=1))[0]
    ta, tb = tc[max(rows.min() - 1, 0)], tc[min(rows.max() + 1, len(tc) - 1)]
    _, pf = resample(ta, tb, 0.004)
    sub = np.arange(16) / 16.0 * (coarse[1] - coarse[0])
    y, h = points(pf, (coarse[near][:, None] + sub[None, :]).ravel())
    y, h = y.ravel(), h.ravel()
    # lower boundary over y: the least height per 5 µm bin. Rolled around an edge only the
    # points of one angle come close (x ≈ 0), spaced along y by the profile sampling: empty
    # bins between filled ones are interpolated (the boundary is smooth there); beyond the
    # sampled angles it lies above any cusp of interest
    nb = max(int((y.max() - y.min()) / 0.005), 2)
    edges = np.linspace(y.min(), y.max(), nb + 1)
    b = np.clip(np.searchsorted(edges, y, side="right") - 1, 0, nb - 1)
    low = np.full(nb, np.inf)
    np.minimum.at(low, b, h)
    yc = 0.5 * (edges[:-1] + edges[1:])
    have = np.isfinite(low)
    low = np.interp(yc, yc[have], low[have], left=10.0 * cusp, right=10.0 * cusp)
    low = low - low.min()
    y0 = float(yc[np.argmin(low)])  # the contact

    def crossing(w):  # scallop between passes at 0 and w: max over y of min of the two profiles
        between = (yc >= y0) & (yc <= y0 + w)
        if not np.any(between):
            return 0.0
        yy = yc[between]
        other = np.interp(yy - w, yc, low, left=np.inf, right=np.inf)
        return float(np.max(np.minimum(low[between], other)))

    lo_w, hi_w = 0.0, float(yc.max() - yc.min())
    if crossing(hi_w) < cusp:
        return np.inf
    for _ in range(50):
        mid = 0.5 * (lo_w + hi_w)
        if crossing(mid) < cusp:
            lo_w = mid
        else:
            hi_w = mid
    w = lo_w
    return (0.25 * w * w + cusp * cusp) / (2.0 * cusp)


def surface_radii(mesh: TriMesh, axis: Axis, morph) -> tuple[float, float]:
    """(smallest convex, smallest concave) principal radius of curvature (mm) of the mesh
    between the cones; ∞ where the surface never curves that way.

    Per face whose centroid lies in the band 0 ≤ s ≤ 1: the shape operator is the symmetric
    part of the Jacobian of the linearly interpolated vertex normals (the curvature tool of
    :mod:`.gouge`), restricted to the face's tangent plane; its eigenvalues are the
    principal curvatures (> 0 convex, outward normals). A thin leading/trailing edge sets the
    convex radius (the demo blade: 0.27 mm, Rotor 37: 0.08 mm), a hub fillet the concave one
    (the demo's 8 mm fillet: 4.2 mm where it meets the trailing edge)."""
    V, F = mesh.V, mesh.F
    s = morph.ratio_of_points(V[F].mean(axis=1), axis)
    band = np.nonzero((s >= -1e-6) & (s <= 1 + 1e-6))[0]
    if len(band) == 0:
        return math.inf, math.inf
    Fb = F[band]
    fn = mesh.face_normals[band]
    a2 = mesh.face_areas[band] * 2.0
    inv = np.where(a2 > 0, 1.0 / np.where(a2 > 0, a2, 1.0), 0.0)
    vn = mesh.vertex_normals
    J = np.zeros((len(band), 3, 3))
    for i in range(3):
        e = V[Fb[:, (i + 2) % 3]] - V[Fb[:, (i + 1) % 3]]
        g = np.cross(fn, e) * inv[:, None]  # gradient of corner i's hat function
        J += vn[Fb[:, i]][:, :, None] * g[:, None, :]
    P = np.eye(3)[None] - fn[:, :, None] * fn[:, None, :]
    S = P @ (0.5 * (J + J.transpose(0, 2, 1))) @ P
    w = np.linalg.eigvalsh(S)  # ascending; one eigenvalue ≈ 0 belongs to the normal
    kmin, kmax = float(w[:, 0].min()), float(w[:, 2].max())
    return (1.0 / kmax if kmax > 0 else math.inf, -1.0 / kmin if kmin < 0 else math.inf)


def convex_edge_radius(mesh: TriMesh, axis: Axis, morph) -> float:
    """Smallest convex radius of curvature (mm) between the cones (:func:`surface_radii`)."""
    return surface_radii(mesh, axis, morph)[0]


def lead_for_concave(cutter: Cutter, strategy: AxisStrategy, limits, concave: float):
    """Smallest |lead| (radians) at which ``cutter`` curves at least as much as a concave
    surface of radius ``concave`` (mm) in both the feed and the side direction (the local
    gouge condition, :mod:`.gouge`), searching leads from the requested one up to the
    gouge-fix limit at the requested tilts; None when no lead within the limit does.

    Returns (lead or None, the smallest effective radius (mm) reachable within the limit)."""
    (l0, l1), (t0, t1) = strategy.angle_bounds()
    lead0 = max(abs(l0), abs(l1))
    leads = np.linspace(lead0, max(limits.max_lead, lead0), 121)
    tilts = np.linspace(t0, t1, 3)
    L, T = (x.ravel() for x in np.meshgrid(leads, tilts, indexing="ij"))
    n = np.tile([0.0, 0.0, 1.0], (len(L), 1))
    f = np.tile([1.0, 0.0, 0.0], (len(L), 1))
    k = np.cross(f, n)
    a = lead_tilt_axes(f, n, k, L, T)
    try:
        eff = np.maximum(*cutter.effective_radii(n, a, f, k))
    except BliskCamError:
        return None, math.inf
    eff = np.max(eff.reshape(len(leads), len(tilts)), axis=1)  # every requested tilt must fit
    fits = np.nonzero(eff <= concave)[0]
    return (float(leads[fits[0]]) if len(fits) else None), float(eff.min())


def expansion_radius(
    cutter: Cutter, strategy: AxisStrategy, cusp: float = 0.05, edge_radius: float = math.inf
) -> float:
    """Radius (mm) of the ball the passes are spaced for: over the strategy's lead/tilt range
    (a 5 × 5 grid), the smallest of the cutter's cross-feed effective radius (the osculating
    circle of the swept envelope, :meth:`..tool.cutter.Cutter.effective_radius`) and the radius of
    the ball leaving the same scallop ``cusp`` on a plane and, with ``edge_radius`` (mm, the
    smallest convex radius the passes run around, :func:`convex_edge_radius`), on that edge
    (:func:`_cusp_equivalent_radius` — the osculating radius alone over-estimates a bull nose's
    or flat end's side step, since its envelope curves more away from the contact, and an
    edge costs it more); capped at ``MAX_EXPANSION_FACTOR`` × the tool radius."""
    if cutter.type == "ball":
        return cutter.radius
    if strategy.mode in ("local", "radial"):
        (l0, l1), (t0, t1) = strategy.angle_bounds()
    else:
        l0, l1, t0, t1 = 0.0, math.radians(80.0), 0.0, 0.0
    L, T = np.meshgrid(np.linspace(l0, l1, 5), np.linspace(t0, t1, 5))
    L, T = np.unique(np.stack([L.ravel(), T.ravel()], 1), axis=0).T
    n = np.tile([0.0, 0.0, 1.0], (len(L), 1))
    f = np.tile([1.0, 0.0, 0.0], (len(L), 1))
    k = np.cross(f, n)
    a = lead_tilt_axes(f, n, k, L, T)
    r = cutter.effective_radius(n, a, k)
    radii = [math.inf] if not math.isfinite(edge_radius) else [math.inf, float(edge_radius)]
    sec = np.array(
        [_cusp_equivalent_radius(cutter, ai, float(cusp), re) for ai in a for re in radii]
    )
    return float(min(np.min(r), np.min(sec), MAX_EXPANSION_FACTOR * cutter.radius))
