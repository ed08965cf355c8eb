"""The math of the cone gizmos: cone end points (r, z) ↔ handle matrices in the 3D viewport.

Pure numpy (no ``bpy`` / ``mathutils``), so it is tested in a plain Python process
(``tests/core/test_gizmo_math.py``); :mod:`.cone_gizmos` wraps it for Blender.

The handles of the four generatrix end points P1, P2 (cone 1) and Q1, Q2 (cone 2), paper 001
(Zhang, Hu, Tang 2015) §2.2 Fig. 2, live in one *meridional half-plane*: the half-plane that
contains the blisk axis and makes the angle θ with the reference direction e1 about it,

    X(r, z) = o + z d + r e_r(θ),   e_r(θ) = cos θ e1 + sin θ e2,   r ≥ 0,

with (e1, e2, d) the frame of :func:`axis_frame` (e1 = world X projected normal to the axis, the
same convention as ``blender.objects.cone_to_object``'s ``theta``). θ is usually the angle of the
blade's centroid (:func:`half_plane_angle`) so the handles sit next to the blade.

Units: (r, z), the axis and cone values are millimetres (core convention); world positions and
matrices are **Blender units** (BU), ``mm = BU × mm_per_unit``
(``blender.objects.mm_per_blender_unit``). Angles in radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.errors import BliskCamError
from ..core.geometry.axis import Axis
from ..core.part.cones import Cone, MorphingCones

__all__ = [
    "GizmoError",
    "HANDLES",
    "Handle",
    "MIN_GENERATRIX",
    "MeridionalPlane",
    "axis_frame",
    "cone_wire_lines",
    "half_plane_angle",
    "handle",
    "is_cone_set",
    "middle_cone",
    "move_end_point",
    "pair_problem",
    "polyline_lines",
    "ray_plane_intersection",
]

#: Shortest generatrix (mm) a handle drag may leave: P1 and P2 of one cone must stay apart
#: (``Cone`` refuses coincident end points).
MIN_GENERATRIX = 1e-3


class GizmoError(BliskCamError):
    """A gizmo input is unusable (non-finite or non-positive unit scale, bad angle, unknown
    handle name, wrong array shape)."""


@dataclass(frozen=True)
class Handle:
    """One draggable generatrix end point.

    Attributes
    ----------
    name : "P1", "P2" (cone 1) or "Q1", "Q2" (cone 2), as in paper 001 Fig. 2
    prop : "cone1" or "cone2" — the scene setting (r1, z1, r2, z2 in mm) it edits
    end : 0 (first end point: indices 0, 1 of the setting) or 1 (indices 2, 3)
    """

    name: str
    prop: str
    end: int

    @property
    def indices(self) -> tuple[int, int]:
        """Indices of (r, z) of this end point in the four-number cone setting."""
        return 2 * self.end, 2 * self.end + 1


HANDLES = (
    Handle("P1", "cone1", 0),
    Handle("P2", "cone1", 1),
    Handle("Q1", "cone2", 0),
    Handle("Q2", "cone2", 1),
)


def handle(name: str) -> Handle:
    """The :class:`Handle` called ``name`` (P1, P2, Q1, Q2)."""
    for h in HANDLES:
        if h.name == name:
            return h
    raise GizmoError(f"unknown cone handle {name!r}; the handles are P1, P2, Q1 and Q2")


def axis_frame(axis: Axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal right-handed frame (e1, e2, d) about the axis.

    e1 is world X projected normal to the axis (world Y when the axis is within ~26° of X), so
    for the axis +Z the angle θ about it is the usual ``atan2(y, x)``; e2 = d × e1. Same
    convention as ``Axis.angular_frame`` (``cone_to_object``'s ``theta``).

    Returns
    -------
    e1, e2, d : (3,) float64 unit vectors
    """
    return axis.angular_frame()


def half_plane_angle(axis: Axis, point) -> float:
    """Angle θ (radians, in (−π, π]) of the meridional half-plane through ``point`` (mm).

    A point on the axis (within 1e-9 mm) has no half-plane of its own: θ = 0 then.
    """
    p = np.asarray(point, dtype=np.float64)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise GizmoError(f"half_plane_angle needs one finite 3-D point in mm, got {point!r}")
    e1, e2, _ = axis_frame(axis)
    q = p - axis.o
    x, y = float(q @ e1), float(q @ e2)
    if math.hypot(x, y) < 1e-9:
        return 0.0
    return math.atan2(y, x)


def _finite_positive(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise GizmoError(f"{name} must be a number, got {value!r}") from None
    if not (math.isfinite(v) and v > 0.0):
        raise GizmoError(f"{name} must be a positive finite number, got {value!r}")
    return v


@dataclass(frozen=True)
class MeridionalPlane:
    """The half-plane of the handles: the blisk axis, an angle about it and the unit scale.

    Parameters
    ----------
    axis : Axis — in mm
    theta : float, radians — angle of the half-plane about the axis (see :func:`axis_frame`)
    mm_per_unit : float > 0 — millimetres per Blender unit of the scene
    """

    axis: Axis
    theta: float = 0.0
    mm_per_unit: float = 1.0

    def __post_init__(self):
        if not isinstance(self.axis, Axis):
            raise GizmoError(f"MeridionalPlane needs a core Axis, got {type(self.axis).__name__}")
        try:
            theta = float(self.theta)
        except (TypeError, ValueError):
            raise GizmoError(f"theta must be an angle in radians, got {self.theta!r}") from None
        if not math.isfinite(theta):
            raise GizmoError(f"theta must be a finite angle in radians, got {self.theta!r}")
        object.__setattr__(self, "theta", theta)
        object.__setattr__(self, "mm_per_unit", _finite_positive("mm_per_unit", self.mm_per_unit))
        e1, e2, d = axis_frame(self.axis)
        radial = math.cos(theta) * e1 + math.sin(theta) * e2
        object.__setattr__(self, "_radial", radial)
        object.__setattr__(self, "_normal", np.cross(radial, d))

    # --- frame ---------------------------------------------------------------------------
    @property
    def radial(self) -> np.ndarray:
        """(3,) unit radial direction e_r(θ) of the half-plane (world)."""
        return self._radial.copy()

    @property
    def direction(self) -> np.ndarray:
        """(3,) unit axis direction d (world)."""
        return self.axis.d

    @property
    def normal(self) -> np.ndarray:
        """(3,) unit normal of the plane, e_r × d (so (e_r, d, normal) is right-handed)."""
        return self._normal.copy()

    @property
    def origin_bu(self) -> np.ndarray:
        """(3,) the axis origin in Blender units."""
        return self.axis.o / self.mm_per_unit

    def rotation(self) -> np.ndarray:
        """(3, 3) rotation whose columns are e_r, d, normal: local X radial, Y along the axis,
        Z normal to the half-plane."""
        return np.stack([self._radial, self.axis.d, self._normal], axis=1)

    # --- (r, z) mm ↔ world BU --------------------------------------------------------------
    def to_world(self, r, z) -> np.ndarray:
        """World positions (BU) of meridional points (mm).

        Parameters
        ----------
        r, z : float or (n,) float, mm (r is used as given, also if negative)

        Returns
        -------
        (3,) or (n, 3) float64, Blender units
        """
        r = np.asarray(r, dtype=np.float64)
        z = np.asarray(z, dtype=np.float64)
        p = self.axis.o + z[..., None] * self.axis.d + r[..., None] * self._radial
        return p / self.mm_per_unit

    def from_world(self, points, *, clamp: bool = True):
        """Meridional coordinates (mm) of world points (BU) projected into this half-plane.

        The point is projected orthogonally onto the plane (its component along
        :attr:`normal` is dropped) and ``r`` is the signed distance along e_r(θ), clamped to
        ≥ 0 when ``clamp`` (a point beyond the axis lands on the axis).

        Parameters
        ----------
        points : (3,) or (n, 3) float, Blender units

        Returns
        -------
        r, z : float or (n,) float, mm
        """
        p = np.asarray(points, dtype=np.float64)
        if p.shape[-1:] != (3,) or p.ndim > 2:
            raise GizmoError(f"world points must be (3,) or (n, 3), got shape {p.shape}")
        if not np.all(np.isfinite(p)):
            raise GizmoError("world points must be finite (got NaN or infinity)")
        q = p * self.mm_per_unit - self.axis.o
        r = q @ self._radial
        z = q @ self.axis.d
        if clamp:
            r = np.maximum(r, 0.0)
        if p.ndim == 1:
            return float(r), float(z)
        return r, z

    def out_of_plane(self, points) -> np.ndarray | float:
        """Signed distance (mm) of world points (BU) from the plane, along :attr:`normal`."""
        p = np.asarray(points, dtype=np.float64)
        d = (p * self.mm_per_unit - self.axis.o) @ self._normal
        return float(d) if p.ndim == 1 else d

    # --- handle matrices ---------------------------------------------------------------
    def handle_matrix(self, r: float, z: float) -> np.ndarray:
        """(4, 4) world matrix of a handle at (r, z) mm: rotation :meth:`rotation` (local Z =
        plane normal, so a handle drags in its local XY plane), translation in BU."""
        m = np.eye(4)
        m[:3, :3] = self.rotation()
        m[:3, 3] = self.to_world(r, z)
        return m

    def matrix_to_rz(self, matrix) -> tuple[float, float]:
        """(r, z) mm of the translation of a (4, 4) world matrix (BU), projected and clamped
        as in :meth:`from_world`."""
        m = np.asarray(matrix, dtype=np.float64)
        if m.shape != (4, 4):
            raise GizmoError(f"a handle matrix is 4 × 4, got shape {m.shape}")
        return self.from_world(m[:3, 3])

    def handle_matrices(self, cone1, cone2) -> dict[str, np.ndarray]:
        """World matrices of P1, P2, Q1, Q2 for two four-number cone settings (r1, z1, r2, z2
        in mm). Returns ``{name: (4, 4) float64}``."""
        values = {"cone1": _four(cone1, "cone1"), "cone2": _four(cone2, "cone2")}
        out = {}
        for h in HANDLES:
            i, j = h.indices
            v = values[h.prop]
            out[h.name] = self.handle_matrix(v[i], v[j])
        return out

    def intersect_ray(self, origin, direction, *, min_cos=1e-6, forward_only=False):
        """Where a view ray (BU) meets the plane, or None if it is (nearly) parallel to it
        (or, with ``forward_only``, meets it behind its origin: a perspective view looking
        away from the plane).

        Parameters
        ----------
        origin, direction : (3,) float, Blender units (direction need not be unit)
        min_cos : float — rays with |cos(ray, normal)| below this count as parallel
        forward_only : bool — only t ≥ 0 along ``direction`` counts

        Returns
        -------
        (3,) float64 world point (BU) on the plane, or None
        """
        return ray_plane_intersection(
            origin,
            direction,
            self.origin_bu,
            self._normal,
            min_cos=min_cos,
            forward_only=forward_only,
        )


def ray_plane_intersection(
    origin, direction, plane_point, plane_normal, *, min_cos=1e-6, forward_only=False
):
    """Intersection of the line ``origin + t direction`` with a plane; None when the line is
    parallel to it (|cos| < ``min_cos``) or, with ``forward_only``, when t < 0. Orthographic
    views put the ray origin anywhere on the view line, so they use the whole line.

    Returns
    -------
    (3,) float64 or None
    """
    o = np.asarray(origin, dtype=np.float64)
    u = np.asarray(direction, dtype=np.float64)
    p = np.asarray(plane_point, dtype=np.float64)
    n = np.asarray(plane_normal, dtype=np.float64)
    for name, a in (("origin", o), ("direction", u), ("plane point", p), ("plane normal", n)):
        if a.shape != (3,) or not np.all(np.isfinite(a)):
            raise GizmoError(f"ray/plane {name} must be a finite 3-vector, got {a!r}")
    lu, ln = float(np.linalg.norm(u)), float(np.linalg.norm(n))
    if lu == 0.0 or ln == 0.0:
        return None
    denom = float(u @ n)
    if abs(denom) < min_cos * lu * ln:
        return None
    t = float((p - o) @ n) / denom
    if forward_only and t < 0.0:
        return None
    return o + t * u


# --- cone settings -----------------------------------------------------------------------
def _four(values, name="cone") -> np.ndarray:
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if v.shape != (4,) or not np.all(np.isfinite(v)):
        raise GizmoError(f"{name} must be four finite numbers r1, z1, r2, z2 (mm), got {values!r}")
    return v


def is_cone_set(values) -> bool:
    """True when four numbers make a usable generatrix (finite, r ≥ 0, P1 ≠ P2)."""
    try:
        Cone(*_four(values))
    except BliskCamError:
        return False
    return True


def move_end_point(values, end: int, r: float, z: float, *, min_length: float = MIN_GENERATRIX):
    """The cone setting with end point ``end`` (0: P1/Q1, 1: P2/Q2) moved to (r, z) mm.

    ``r`` is clamped to ≥ 0 (the half-plane). Returns the new four numbers as a tuple, or
    None when the move would put the end point within ``min_length`` mm of the other one (the
    generatrix would vanish; the caller keeps the old setting).
    """
    v = _four(values).copy()
    if end not in (0, 1):
        raise GizmoError(f"a cone end point is 0 (P1/Q1) or 1 (P2/Q2), got {end!r}")
    r, z = float(r), float(z)
    if not (math.isfinite(r) and math.isfinite(z)):
        raise GizmoError(f"a handle position must be finite, got r={r!r}, z={z!r}")
    r = max(r, 0.0)
    other = v[2 - 2 * end : 4 - 2 * end]
    if math.hypot(r - other[0], z - other[1]) < min_length:
        return None
    v[2 * end], v[2 * end + 1] = r, z
    return tuple(float(x) for x in v)


def middle_cone(cone1, cone2, s: float = 0.5) -> Cone:
    """The linear morphing cone at ratio ``s`` (paper 001 Eqs. 1–4; s = 0.5 is the middle cone
    of Fig. 2) of two four-number settings. Raises ConeError for an unusable pair (crossing,
    coincident), exactly as path generation would."""
    mc = MorphingCones(Cone(*_four(cone1, "cone1")), Cone(*_four(cone2, "cone2")))
    return mc.cone_at(float(s))


def pair_problem(cone1, cone2) -> str | None:
    """None if the two settings make a usable LMC family, else the reason (one line)."""
    try:
        MorphingCones(Cone(*_four(cone1, "cone1")), Cone(*_four(cone2, "cone2")))
    except BliskCamError as exc:
        return str(exc)
    return None


# --- draw geometry -----------------------------------------------------------------------
def cone_wire_lines(
    plane: MeridionalPlane,
    cone,
    *,
    generatrices: int = 12,
    circle_segments: int = 96,
) -> np.ndarray:
    """Line segments (pairs of points, for a ``LINES`` batch) drawing a cone in world space.

    Both end circles (radius r1 at z1 and r2 at z2) and ``generatrices`` straight lines P1 → P2
    evenly spaced about the axis, the first in the handle half-plane (so it joins the two
    handles). A circle of radius 0 (an end point on the axis) is left out.

    Parameters
    ----------
    plane : MeridionalPlane — axis, handle angle θ and unit scale
    cone : Cone or four numbers r1, z1, r2, z2 (mm)
    generatrices : int ≥ 1
    circle_segments : int ≥ 3

    Returns
    -------
    (2k, 3) float64, Blender units: segment i is rows 2i, 2i + 1
    """
    v = np.array(cone.as_list()) if isinstance(cone, Cone) else _four(cone)
    Cone(*v)  # the same checks as everywhere (r ≥ 0, P1 ≠ P2)
    g = int(generatrices)
    n = int(circle_segments)
    if g < 1 or n < 3:
        raise GizmoError(f"need ≥ 1 generatrix and ≥ 3 circle segments, got {g} and {n}")
    e1, e2, d = axis_frame(plane.axis)
    o = plane.axis.o
    f = plane.mm_per_unit

    def ring(th):
        return np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2  # (k, 3)

    th_g = plane.theta + 2.0 * np.pi * np.arange(g) / g
    rg = ring(th_g)
    a = o + v[1] * d + v[0] * rg
    b = o + v[3] * d + v[2] * rg
    parts = [np.stack([a, b], axis=1).reshape(-1, 3)]
    th_c = plane.theta + 2.0 * np.pi * np.arange(n + 1) / n
    rc = ring(th_c)
    for r, z in ((v[0], v[1]), (v[2], v[3])):
        if r > 0.0:
            c = o + z * d + r * rc  # (n + 1, 3)
            parts.append(np.stack([c[:-1], c[1:]], axis=1).reshape(-1, 3))
    return np.concatenate(parts) / f


def polyline_lines(points, closed: bool, mm_per_unit: float = 1.0) -> np.ndarray:
    """Line segments (pairs of points) of a polyline in mm, converted to Blender units.

    Parameters
    ----------
    points : (k, 3) float, mm (k ≥ 2; a closed curve does not repeat its first point)
    closed : bool — also join the last point to the first
    mm_per_unit : float > 0

    Returns
    -------
    (2(k − 1), 3) or (2k, 3) float64, Blender units
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise GizmoError(f"a polyline is a (k, 3) array, got shape {p.shape}")
    f = _finite_positive("mm_per_unit", mm_per_unit)
    if len(p) < 2:
        return np.zeros((0, 3))
    q = np.vstack([p, p[:1]]) if closed else p
    return np.stack([q[:-1], q[1:]], axis=1).reshape(-1, 3) / f
