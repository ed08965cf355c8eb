"""Fit the hub and tip generatrices (cone 1, cone 2) to a blade mesh's boundary loops.

Paper 001 §2.1: the hub and tip boundaries of a blade on a blisk lie on two cones. An open
blade mesh (hub and tip not capped) has a boundary loop at each end; we fit a cone to each by
least squares in the meridional (r, z) plane (:func:`.cones.fit_cone`), report the residual,
and tell hub from tip by the mean radius (the hub is nearer the axis).

When the hub (or tip) is a curved surface of revolution (paper 001 §4.2; NASA Rotor 67's hub
is fitted by a straight cone only to ≈ 2 mm) the generatrix can instead be a least-squares
polyline, a :class:`.profiles.Profile` (:func:`fit_profile`): ``generatrix="profile"`` always,
``generatrix="auto"`` when the straight cone's largest residual exceeds
:data:`PROFILE_THRESHOLD` mm and the profile fits better.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConeError
from ..geometry.axis import Axis, meridional
from ..geometry.mesh import TriMesh
from .cones import Cone, fit_cone
from .profiles import Profile, morph_between

__all__ = ["AXIS_FIT_LIMIT", "PROFILE_SPACING", "PROFILE_THRESHOLD", "ConeFit", "MeshHole",
           "fit_cones_to_mesh", "fit_profile", "region_holes"]

#: ``generatrix="auto"`` keeps a straight cone when its largest meridional residual is at most
#: this (mm): a tenth of a millimetre is well inside a finishing allowance, and float32 STL
#: noise (≈ 1e-5 mm) and published-table rounding (1e-4 mm) stay far below it.
PROFILE_THRESHOLD = 0.1
#: a boundary loop farther than this (mm) from the best cone and the best profile about the
#: axis lies on no surface of revolution about it: the axis is wrong (ConeError). Correct axes
#: fit to ≤ 0.09 mm (the demo 0, Rotor 37 0.08, Rotor 67 0.02); the axis along X or Y leaves
#: 1.5–7 mm on these blades.
AXIS_FIT_LIMIT = 0.5
#: default node spacing (mm) of a fitted profile along its chord
PROFILE_SPACING = 5.0


@dataclass
class ConeFit:
    """Result of :func:`fit_cones_to_mesh`.

    cone1, cone2 : Cone or Profile — hub and tip generatrices (the chosen ones: a Profile only
        with ``generatrix="profile"`` or ``"auto"``)
    residual1, residual2 : float, mm — largest meridional distance of a loop vertex from its
        chosen generatrix
    hub_loop, tip_loop : (k,) int — vertex ids of the loops used
    other_loops : int — further boundary loops (holes) that were not used
    straight1, straight2 : Cone — the least-squares straight cones (always fitted)
    straight_residual1, straight_residual2 : float, mm — their largest residuals
    rms1, rms2 : float, mm — root-mean-square residual of the chosen generatrices
    """

    cone1: Cone | Profile
    cone2: Cone | Profile
    residual1: float
    residual2: float
    hub_loop: np.ndarray
    tip_loop: np.ndarray
    other_loops: int = 0
    straight1: Cone | None = None
    straight2: Cone | None = None
    straight_residual1: float = float("nan")
    straight_residual2: float = float("nan")
    rms1: float = float("nan")
    rms2: float = float("nan")

    @property
    def kinds(self) -> tuple[str, str]:
        """("cone" | "profile", "cone" | "profile") of cone1, cone2."""
        return tuple(
            "profile" if isinstance(g, Profile) else "cone" for g in (self.cone1, self.cone2)
        )


def fit_profile(points, axis: Axis | None = None, *, spacing: float = PROFILE_SPACING,
                extend: float = 0.0):
    """Least-squares smooth polyline generatrix through points of a hub or tip (a boundary
    loop, or points the user picked), for a hub that is a curved surface of revolution.

    In the meridional plane the points are expressed along their principal direction
    (t, by PCA) and across it (w); w(t) is fitted by least squares as a piecewise-linear
    function with nodes every ≈ ``spacing`` mm over the points' extent in t (hat-function
    basis; a light second-difference penalty only fills nodes without data). The nodes are the
    profile's points; the end segments are then extended by ``extend`` mm (clipped at the
    axis). The data must be a graph over its principal direction (as a hub line is); the
    residual tells how well the polyline fits.

    Parameters
    ----------
    points : (n, 2) float (r, z), or (n, 3) float (x, y, z) with ``axis``; mm; n ≥ 2
    axis : Axis — required for 3-D points
    spacing : float, mm > 0 — node spacing along the principal direction
    extend : float, mm ≥ 0

    Returns
    -------
    profile : Profile — ordered so that z (then r) increases
    residual : float, mm — the largest meridional distance of a point from the profile
    rms : float, mm
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] not in (2, 3) or len(p) < 2:
        raise ConeError(
            "fit_profile needs at least two points as (r, z) or (x, y, z) rows, got shape "
            f"{p.shape}"
        )
    if not np.all(np.isfinite(p)):
        raise ConeError("fit_profile: the points contain NaN or infinite coordinates")
    if not (np.isfinite(spacing) and spacing > 0) or not (np.isfinite(extend) and extend >= 0):
        raise ConeError(
            f"fit_profile: spacing must be > 0 and extend ≥ 0 mm, got {spacing}, {extend}"
        )
    if p.shape[1] == 3:
        if axis is None:
            raise ConeError("fit_profile: 3-D points need the blisk axis to get (r, z)")
        rz = np.stack(meridional(p, axis), axis=1)
    else:
        rz = p
        if np.any(rz[:, 0] < 0):
            raise ConeError("fit_profile: (r, z) points need r ≥ 0 (the distance from the axis)")
    c = rz.mean(axis=0)
    _, sv, vt = np.linalg.svd(rz - c, full_matrices=False)
    if sv[0] < 1e-9:
        raise ConeError(
            "fit_profile: the points all have the same (r, z); they do not define a curve"
        )
    d = vt[0]
    if d[1] < 0 or (abs(d[1]) < 1e-12 and d[0] < 0):
        d = -d
    nrm = np.array([-d[1], d[0]])
    t = (rz - c) @ d
    w = (rz - c) @ nrm
    t0, t1 = float(t.min()), float(t.max())
    m = max(1, int(np.ceil((t1 - t0) / spacing)))  # segments
    nodes = np.linspace(t0, t1, m + 1)
    h = (t1 - t0) / m
    k = np.clip(((t - t0) / h).astype(np.int64), 0, m - 1)
    a = (t - nodes[k]) / h
    A = np.zeros((len(t), m + 1))
    rows = np.arange(len(t))
    A[rows, k] = 1.0 - a
    A[rows, k + 1] = a
    if m >= 2:
        D2 = np.zeros((m - 1, m + 1))
        i = np.arange(m - 1)
        D2[i, i], D2[i, i + 1], D2[i, i + 2] = 1.0, -2.0, 1.0
        mu = 1e-3 * np.sqrt(len(t) / (m + 1))
        A = np.vstack([A, mu * D2])
        rhs = np.concatenate([w, np.zeros(m - 1)])
    else:
        rhs = w
    wn = np.linalg.lstsq(A, rhs, rcond=None)[0]
    V = c + nodes[:, None] * d + wn[:, None] * nrm
    if extend > 0:
        for end, nb in ((0, 1), (-1, -2)):
            u = V[end] - V[nb]
            u /= np.linalg.norm(u)
            V[end] = V[end] + extend * u
            if V[end, 0] < 0 and abs(u[0]) > 1e-12:
                V[end] = V[end] + (-V[end, 0] / u[0]) * u
    prof = Profile(V)
    resid = prof.signed_distance(rz[:, 0], rz[:, 1])
    return prof, float(np.max(np.abs(resid))), float(np.sqrt(np.mean(resid**2)))


@dataclass(frozen=True)
class MeshHole:
    """A boundary loop of a blade mesh that is neither the hub nor the tip loop and reaches
    into the region between the cones: a hole (a scan's gap, a missing patch).

    centre : (3,) float, mm — the mean of its vertices; r, z : its meridional position, mm
    size : float, mm — its largest extent (the diagonal of its bounding box)
    area : float, mm² — the area it leaves open (the magnitude of the loop's vector area)
    s : (float, float) — the range of the morph ratio over its vertices
    """

    centre: np.ndarray
    r: float
    z: float
    size: float
    area: float
    s: tuple

    def describe(self) -> str:
        """'at r 180.2 z 3.1 mm, 4.2 mm across (9.8 mm²)'."""
        return (f"at r {self.r:.1f} z {self.z:.1f} mm, {self.size:.1f} mm across "
                f"({self.area:.1f} mm²)")


def region_holes(mesh: TriMesh, axis: Axis, cone1, cone2) -> list[MeshHole]:
    """The holes of ``mesh`` inside the region between ``cone1`` and ``cone2``, largest
    first: every boundary loop but the two longest (the hub and tip loops, as
    :func:`fit_cones_to_mesh` takes them) with a vertex at morph ratio 0 < s < 1. Nothing is
    machined or measured over a hole: the passes break there and a checker has no surface
    (issue 28: a mesh with 4 holes gave 125 curves for 59 passes and a verify PASS)."""
    loops = [lp for lp in mesh.boundary_loops() if len(lp) >= 3]
    if len(loops) <= 2:
        return []
    lengths = [np.linalg.norm(np.diff(mesh.V[np.r_[lp, lp[:1]]], axis=0), axis=1).sum()
               for lp in loops]
    morph = morph_between(cone1, cone2)
    holes = []
    for k in np.argsort(lengths)[::-1][2:]:
        P = mesh.V[loops[k]]
        s = morph.ratio_of_points(P, axis)
        if not np.any((s > 0.0) & (s < 1.0)):
            continue
        c = P.mean(axis=0)
        r, z = meridional(c[None, :], axis)
        vec = 0.5 * np.cross(P - c, np.roll(P, -1, axis=0) - c).sum(axis=0)
        holes.append(MeshHole(c, float(r[0]), float(z[0]),
                              float(np.linalg.norm(P.max(axis=0) - P.min(axis=0))),
                              float(np.linalg.norm(vec)), (float(s.min()), float(s.max()))))
    return sorted(holes, key=lambda h: -h.area)


def _check_revolution(mesh: TriMesh, axis: Axis, loop, cone_residual: float, end: str,
                      spacing: float, extend: float) -> None:
    """ConeError when the ``end`` loop lies farther than :data:`AXIS_FIT_LIMIT` from the best
    straight cone *and* the best profile about ``axis``: it lies on no surface of revolution
    about this axis, so the axis is not the blade's (issue 28: an axis along X was accepted
    with a 4.4 mm residual and cut a path)."""
    if cone_residual <= AXIS_FIT_LIMIT:
        return
    best = min(cone_residual, fit_profile(mesh.V[loop], axis, spacing=spacing,
                                          extend=extend)[1])
    if best <= AXIS_FIT_LIMIT:
        return
    o, d = (" ".join(f"{x:g}" for x in v) for v in (axis.o, axis.d))
    raise ConeError(
        f"the blade's {end} loop lies up to {best:.2f} mm off every cone and profile about "
        f"the axis through ({o}) along ({d}), but a blade's hub and tip loops lie on one to "
        f"about 0.1 mm about the blisk axis (limit {AXIS_FIT_LIMIT:g} mm): this is not the "
        "blade's axis. Give the mesh's own axis (--axis OX OY OZ DX DY DZ, or the Setup "
        "panel's axis), or give both cones (--cone1/--cone2)")


def fit_cones_to_mesh(
    mesh: TriMesh, axis: Axis, *, extend: float = 2.0, generatrix: str = "cone",
    threshold: float = PROFILE_THRESHOLD, spacing: float = PROFILE_SPACING,
) -> ConeFit:
    """Fit cone 1 to the hub boundary loop and cone 2 to the tip boundary loop.

    Parameters
    ----------
    mesh : TriMesh — an open blade (hub and tip ends open)
    axis : Axis
    extend : float, mm — the generatrices extend this far past the loops' extent
    generatrix : "cone" (straight cones, the paper's LMC), "profile" (least-squares polylines,
        :func:`fit_profile`, for LMRS) or "auto" (per end: a profile when the straight cone's
        largest residual exceeds ``threshold`` mm and the profile's is smaller, else the cone)
    threshold : float, mm — see ``generatrix="auto"`` (:data:`PROFILE_THRESHOLD`)
    spacing : float, mm — node spacing of fitted profiles

    Raises
    ------
    ConeError when the mesh has fewer than two boundary loops (e.g. a capped, watertight
    blade) — then the cones must be given explicitly —, ``generatrix`` is unknown, or a loop
    lies more than :data:`AXIS_FIT_LIMIT` from every cone and profile about ``axis`` (the
    axis is not the blade's).
    """
    if generatrix not in ("cone", "profile", "auto"):
        raise ConeError(f"generatrix must be 'cone', 'profile' or 'auto', got {generatrix!r}")
    loops = [lp for lp in mesh.boundary_loops() if len(lp) >= 3]
    if len(loops) < 2:
        raise ConeError(
            f"the blade mesh has {len(loops)} open boundary loop(s), need two (hub and tip) to "
            "fit the cones: delete the hub and tip caps of a closed blade, or give the cones "
            "explicitly (--cone1/--cone2, or the Region panel)"
        )
    # the two longest loops are hub and tip; others are holes
    lengths = [
        np.linalg.norm(np.diff(mesh.V[np.r_[lp, lp[:1]]], axis=0), axis=1).sum() for lp in loops
    ]
    order = np.argsort(lengths)[::-1]
    a, b = loops[order[0]], loops[order[1]]
    ra = meridional(mesh.V[a], axis)[0].mean()
    rb = meridional(mesh.V[b], axis)[0].mean()
    hub, tip = (a, b) if ra <= rb else (b, a)
    chosen = []
    straight = []
    for loop in (hub, tip):
        cone, res, rms = fit_cone(mesh.V[loop], axis, extend=extend)
        straight.append((cone, res))
        pick = (cone, res, rms)
        if generatrix == "profile" or (generatrix == "auto" and res > threshold):
            prof = fit_profile(mesh.V[loop], axis, spacing=spacing, extend=extend)
            if generatrix == "profile" or prof[1] < res:
                pick = prof
        chosen.append(pick)
        _check_revolution(mesh, axis, loop, res, "hub" if loop is hub else "tip", spacing,
                          extend)
    (c1, res1, rms1), (c2, res2, rms2) = chosen
    return ConeFit(
        c1, c2, res1, res2, hub, tip, other_loops=len(loops) - 2,
        straight1=straight[0][0], straight2=straight[1][0],
        straight_residual1=straight[0][1], straight_residual2=straight[1][1], rms1=rms1, rms2=rms2,
    )
