"""The generalised milling cutter (DIN 66215 / APT parameters): shape, CC → CL, effective radius.

Paper 003 (Tung & Tso, §II, Fig. 2 and Table I) describes a milling tool by DIN 66215's
parameters d (diameter), r (corner radius), e, f (corner-centre offsets), α, β (bottom and
side angles) and L (length), and gives the CC point on the tool edge as rational functions of
tan(θ/2) (its Eqs. 2–5). The printed coefficients are garbled in the text, so the geometry is
derived here from the profile itself.

Tool frame: the tip (CL point) at the origin, z along the unit tool axis ``a`` (tip → spindle),
ρ the distance from the axis. The cutting part is the revolution about the axis of the convex
meridional profile

* **bottom** — the line from the tip (0, 0) rising at α (0 = flat bottom) to its tangent
  point B on the corner circle;
* **corner** — the circle of radius r about (e, f), e = d/2 − r; the tip on the axis gives
  f = (r + e sin α) / cos α (f = r for a flat bottom);
* **side** — the line at β from the axis (widening toward the spindle: a taper) from its
  tangent point S on the circle up to the flute (cutting) length h;
* **top** — the cap z = h that closes the cutting part (shank, neck and holder are recorded
  for collision checking, not part of the cutting shape).

The profile's outward unit normal is (sin θ, −cos θ) in (ρ, z): θ = 0 points down the axis,
θ = π/2 radially out. The corner arc carries θ ∈ [α, π/2 − β] at the point
(e + r sin θ, f − r cos θ); for r = 0 (a flat end mill) it shrinks to the sharp edge (e, f).

Contact (CC → CL). A surface point ``cc`` with unit normal ``n`` (out of the material,
toward the tool) is touched where the cutter's outward normal is −n, i.e. at θ = arccos(n·a)
in the meridional half-plane of the radial direction u = −(n − (n·a) a)/|n − (n·a) a|. With
(ρ_c, z_c) the profile point of that θ, the cutter point is ``tip + ρ_c u + z_c a = cc``, so

    tip = cc − ρ_c u − z_c a                                      (paper 003, Eqs. 2–3)

For a ball this is ``tip = cc + ρ n − ρ a`` (centre ``cc + ρ n``). With the axis exactly along
n a flat bottom touches with its whole face: the contact is taken at the tip (tip = cc); for
tilts θ below ``_FLUSH_TILT`` (1e-12 rad) it slides continuously along the bottom out to the
ring contact, where u (the direction of a ~θ-long vector) is no longer defined by rounding.

Effective radius. Moving the cutter along the feed direction t (tangent, ⊥ the side
direction s) sweeps an envelope whose cross-section in the plane (n, s) has, at the contact,
the radius of curvature

    R_eff(s) = ρ_m cos²φ + ρ_p sin²φ

where ρ_m = r (meridional radius), ρ_p = ρ_c / sin θ = e / sin θ + r (the parallel circle's
normal-section radius, Meusnier) and φ the angle between s and the meridional tangent. (The
envelope is ruled along t, and its curvature across t is 1 / (sᵀ K⁻¹ s), K the cutter's
second fundamental form — radii, not curvatures, combine.) For a torus tilted by the lead λ
along the feed this is the classic (R − r)/sin λ + r; for a flat bottom with the axis along
n it is ∞; for a ball ρ.

All lengths in mm, angles in radians. numpy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import ToolError
from ..geometry.closest import segment_distance2_2d
from ..geometry.vectors import perpendicular

__all__ = [
    "DEFAULT_TAPER_ANGLE",
    "TOOL_TYPES",
    "ContactInfo",
    "Cutter",
    "as_cutter",
]

TOOL_TYPES = ("ball", "bull", "flat", "taper")
#: taper half-angle used by :meth:`Cutter.from_spec` when none is given (3°)
DEFAULT_TAPER_ANGLE = math.radians(3.0)
_MAX_ANGLE = math.radians(60.0)  # α and β are accepted in [0, 60°)
_ANGLE_TOL = 1e-9  # rad: how far beyond the side angle a contact still counts as on the side
#: rad: below this tilt θ of the axis from n a flat-bottomed cutter (α = 0, e > 0) touches on
#: its bottom disc at ρ = e θ / _FLUSH_TILT along u, so the contact moves continuously from the
#: tip (θ = 0, the whole disc flush; u undefined) out to the ring contact (ρ = e + r sin θ ≈ e)
#: it reaches at θ = _FLUSH_TILT. The point is on the cutter; the cutter dips below the tangent
#: plane by e sin θ (1 − θ / _FLUSH_TILT) ≤ e · _FLUSH_TILT / 4 (2.5e-12 mm for e = 10 mm)
#: and its normal there (−a) is within θ of −n.
_FLUSH_TILT = 1e-12


@dataclass(frozen=True)
class ContactInfo:
    """Where a cutter touches, per pose.

    Attributes
    ----------
    theta : (k,) float, rad — angle of the cutter's outward normal at the contact from −axis
        (arccos(n·a)); clipped into the profile's range
    rho : (k,) float, mm — distance of the contact point from the tool axis
    height : (k,) float, mm — its height above the tip along the axis
    radial : (k, 3) float — unit radial direction u of the contact's meridional half-plane
        (an arbitrary unit vector ⊥ a where the contact is on the axis)
    region : (k,) int8 — 0: on the bottom — the apex of a conical bottom, or a flat bottom
        flush (the tip at θ = 0; within ``_FLUSH_TILT`` of it, a point of the bottom disc);
        1: on the corner arc (on the sharp edge for r = 0)
    point : (k, 3) float, mm — the contact point relative to the tip, ``rho u + height a``
    """

    theta: np.ndarray
    rho: np.ndarray
    height: np.ndarray
    radial: np.ndarray
    region: np.ndarray
    point: np.ndarray


def _unit_rows(x, name):
    """(k, 3) float unit rows of ``x`` ((3,) or (k, 3)); ToolError on zero/NaN rows."""
    v = np.asarray(x, dtype=np.float64)
    v = np.atleast_2d(v)
    if v.shape[-1] != 3:
        raise ToolError(f"{name} must be (k, 3) vectors, got shape {np.shape(x)}")
    n = np.linalg.norm(v, axis=1)
    bad = ~(np.isfinite(n) & (n > 1e-300))
    if np.any(bad):
        raise ToolError(f"{name}: {int(bad.sum())} vector(s) are zero or not finite; "
                        f"give unit {name} vectors")
    return v / n[:, None]


@dataclass(frozen=True)
class Cutter:
    """A milling cutter described by DIN 66215 parameters (see the module docstring).

    Attributes
    ----------
    type : str — "ball" | "bull" | "flat" | "taper" (tapered ball)
    d : float, mm — diameter of the corner circles' outer extent, 2 (e + r)
    r : float, mm — corner radius (ball and tapered ball: d/2; flat: 0)
    e, f : float, mm — corner-circle centre (radial, axial); derived from d, r, α when omitted
    alpha : float, rad — bottom angle from the plane ⊥ the axis, in [0, 60°) (0 for ball/taper)
    beta : float, rad — side (taper) angle from the axis, (0, 60°) for a taper, else 0
    h : float, mm — flute (cutting) length above the tip; default 3 d
    shank_diameter, neck_length, holder_diameter, holder_length : float, mm — for collision
        checking; defaults: the flute-top diameter, 0, 2.5 × shank, 5 d
    """

    type: str
    d: float
    r: float
    e: float | None = None
    f: float | None = None
    alpha: float = 0.0
    beta: float = 0.0
    h: float | None = None
    shank_diameter: float | None = None
    neck_length: float | None = None
    holder_diameter: float | None = None
    holder_length: float | None = None

    # ------------------------------------------------------------------ construction
    def __post_init__(self):
        kind = str(self.type).strip().lower()
        if kind not in TOOL_TYPES:
            raise ToolError(f"tool type must be one of {', '.join(TOOL_TYPES)}; got {self.type!r}")
        set_ = object.__setattr__
        set_(self, "type", kind)

        def num(name, value):
            try:
                v = float(value)
            except (TypeError, ValueError):
                raise ToolError(f"cutter {name} must be a number, got {value!r}") from None
            if not math.isfinite(v):
                raise ToolError(f"cutter {name} must be a finite number, got {v}")
            return v

        d, r = num("diameter d", self.d), num("corner radius r", self.r)
        alpha, beta = num("bottom angle alpha", self.alpha), num("taper angle beta", self.beta)
        if not d > 0:
            raise ToolError(f"cutter diameter d must be > 0 mm, got {d} (tool radius {d / 2})")
        R = 0.5 * d
        if r < 0 or r > R * (1 + 1e-12):
            raise ToolError(f"corner radius r must be in [0, d/2] = [0, {R:g}] mm, got {r:g}")
        tol = 1e-9 * max(d, 1.0)
        if kind in ("ball", "taper") and abs(r - R) > tol:
            raise ToolError(f"a {kind} cutter's corner radius is its radius {R:g} mm, got {r:g}; "
                            "use a bull-nose cutter for a smaller corner radius")
        if kind == "bull" and not (0 < r < R - tol):
            raise ToolError(f"a bull-nose cutter needs 0 < corner radius < radius {R:g} mm, "
                            f"got {r:g}; use 'ball' for r = {R:g} and 'flat' for r = 0")
        if kind == "flat" and r != 0:
            raise ToolError(f"a flat end mill has no corner radius, got {r:g} mm; "
                            "use a bull-nose cutter for a rounded corner")
        if kind in ("ball", "taper"):
            r = R
        if not (0 <= alpha < _MAX_ANGLE) or (kind in ("ball", "taper") and alpha != 0):
            raise ToolError(f"bottom angle alpha must be in [0, 60°) (0 for a {kind}), got "
                            f"{math.degrees(alpha):g}°")
        if kind == "taper":
            if not (0 < beta < _MAX_ANGLE):
                raise ToolError(f"taper angle must be in (0°, 60°), got {math.degrees(beta):g}°")
        elif beta != 0:
            raise ToolError(f"a {kind} cutter has no taper angle, got {math.degrees(beta):g}°; "
                            "use type 'taper'")
        e = R - r
        f = (r + e * math.sin(alpha)) / math.cos(alpha)
        if self.e is not None and abs(num("corner offset e", self.e) - e) > tol:
            raise ToolError(f"corner offset e must be d/2 − r = {e:g} mm, got {self.e}")
        if self.f is not None and abs(num("corner height f", self.f) - f) > tol:
            raise ToolError(f"corner height f must be (r + e sin α)/cos α = {f:g} mm (tip on the "
                            f"axis), got {self.f}")
        s_z = f - r * math.sin(beta)
        h = 3.0 * d if self.h is None else num("flute length h", self.h)
        if not h > s_z + tol:
            raise ToolError(f"flute length h must exceed the corner's top {s_z:g} mm, got {h:g}")
        top = e + r * math.cos(beta) + (h - s_z) * math.tan(beta)
        shank = 2.0 * top if self.shank_diameter is None else num("shank diameter",
                                                                 self.shank_diameter)
        neck = 0.0 if self.neck_length is None else num("neck length", self.neck_length)
        hd = 2.5 * shank if self.holder_diameter is None else num("holder diameter",
                                                                  self.holder_diameter)
        hl = 5.0 * d if self.holder_length is None else num("holder length", self.holder_length)
        if not shank > 0 or neck < 0 or not hd > 0 or not hl > 0:
            raise ToolError("shank diameter, holder diameter and holder length must be > 0 mm "
                            f"and neck length ≥ 0 mm; got {shank:g}, {hd:g}, {hl:g}, {neck:g}")
        for name, v in (("d", d), ("r", r), ("e", e), ("f", f), ("alpha", alpha), ("beta", beta),
                        ("h", h), ("shank_diameter", shank), ("neck_length", neck),
                        ("holder_diameter", hd), ("holder_length", hl)):
            set_(self, name, float(v))

    @classmethod
    def ball(cls, radius: float, **kw) -> Cutter:
        """Ball-end mill of ``radius`` mm."""
        return cls("ball", 2.0 * _radius(radius), _radius(radius), **kw)

    @classmethod
    def bull(cls, radius: float, corner_radius: float, **kw) -> Cutter:
        """Bull-nose (torus) end mill: ``radius`` mm, ``corner_radius`` mm (0 < r < radius)."""
        return cls("bull", 2.0 * _radius(radius), corner_radius, **kw)

    @classmethod
    def flat(cls, radius: float, **kw) -> Cutter:
        """Flat end mill of ``radius`` mm."""
        return cls("flat", 2.0 * _radius(radius), 0.0, **kw)

    @classmethod
    def taper(cls, radius: float, taper_angle: float, **kw) -> Cutter:
        """Tapered ball-end mill: tip ball ``radius`` mm, side ``taper_angle`` rad from the axis."""
        return cls("taper", 2.0 * _radius(radius), _radius(radius), beta=taper_angle, **kw)

    @classmethod
    def from_spec(cls, type: str, radius: float, corner_radius: float | None = 0.0,
                  **kw) -> Cutter:
        """The CLI/properties entry: ``type`` ball|bull|flat|taper (any case, e.g. 'BULL'),
        ``radius`` mm, ``corner_radius`` mm (bull only; 0/None or the radius for a ball).
        A taper takes ``taper_angle`` (rad, default :data:`DEFAULT_TAPER_ANGLE`)."""
        kind = str(type).strip().lower()
        R = _radius(radius)
        cr = 0.0 if corner_radius is None else float(corner_radius)
        if not math.isfinite(cr) or cr < 0:
            raise ToolError(f"corner radius must be a finite number ≥ 0 mm, got {corner_radius}")
        if kind in ("ball", "taper") and cr not in (0.0, R):
            raise ToolError(f"a {kind} cutter's corner radius is its radius; got corner radius "
                            f"{cr:g} mm with radius {R:g} mm (leave the corner radius out, or "
                            "use a bull-nose cutter)")
        if kind == "ball":
            return cls.ball(R, **kw)
        if kind == "bull":
            return cls.bull(R, cr, **kw)
        if kind == "flat":
            if cr != 0:
                raise ToolError(f"a flat end mill has no corner radius, got {cr:g} mm "
                                "(use a bull-nose cutter)")
            return cls.flat(R, **kw)
        if kind == "taper":
            angle = kw.pop("taper_angle", DEFAULT_TAPER_ANGLE)
            return cls.taper(R, angle, **kw)
        raise ToolError(f"tool type must be one of {', '.join(TOOL_TYPES)}; got {type!r}")

    def grown(self, allowance: float) -> Cutter:
        """This cutter grown by ``allowance`` mm: its Minkowski sum with a ball of that radius.

        Ball ρ → ball ρ + a; bull nose (radius R, corner r) → bull nose (R + a, r + a), the
        same flat core e; flat end (R) → bull nose (R + a, corner a); tapered ball → the
        tapered ball of tip radius ρ + a and the same side angle. The corner circles keep
        their centres, so with the grown cutter's tip at ``t`` the cutter itself sits at
        ``t + a · axis`` (same axis); flute, shank and holder grow by a around the same top.

        Why: the surface offset outward by a, machined by this cutter, is exactly the true
        surface machined by the grown cutter (the offset of a swept solid is the sweep of
        the offset solid), so a semi-finishing path is planned on the true surface with the
        grown cutter — contact, spacing, local gouge check — and moved up its axis by a.
        ToolError for a ≤ 0 or a conical bottom (α > 0: its apex would grow into a sphere,
        which DIN 66215 does not describe)."""
        a = float(allowance)
        if not (math.isfinite(a) and a > 0):
            raise ToolError(f"a cutter grows by an allowance > 0 mm, got {allowance!r}")
        if self.alpha != 0.0:
            raise ToolError(f"a {self.type} cutter with a conical bottom (α = "
                            f"{math.degrees(self.alpha):g}°) cannot leave an allowance: its "
                            "grown shape is no DIN 66215 cutter; use a ball, bull-nose or flat")
        kw = dict(h=self.h + a, shank_diameter=self.shank_diameter + 2 * a,
                  neck_length=self.neck_length, holder_diameter=self.holder_diameter + 2 * a,
                  holder_length=self.holder_length)
        R = self.radius + a
        if self.type == "ball":
            return Cutter.ball(R, **kw)
        if self.type == "taper":
            return Cutter.taper(R, self.beta, **kw)
        return Cutter.bull(R, self.r + a, **kw)

    def as_dict(self) -> dict:
        """The paths-JSON "tool" object: {"type", "radius", "corner_radius", DIN fields...}."""
        out = {"type": self.type, "radius": self.radius, "corner_radius": self.r}
        if self.type == "taper":
            out["taper_angle"] = self.beta
        out.update({k: getattr(self, k) for k in (
            "d", "r", "e", "f", "alpha", "beta", "h", "shank_diameter", "neck_length",
            "holder_diameter", "holder_length")})
        return out

    @classmethod
    def from_dict(cls, data: dict) -> Cutter:
        """Read a "tool" object: the version-1 ``{"type": "ball", "radius": 6.0}`` or the full
        :meth:`as_dict` form (the DIN fields, when present, must agree with the short ones)."""
        if not isinstance(data, dict) or "type" not in data:
            raise ToolError(f"a tool must be an object with a 'type', got {data!r}")
        extra = {k: data[k] for k in ("alpha", "h", "shank_diameter", "neck_length",
                                      "holder_diameter", "holder_length")
                 if data.get(k) is not None}
        kind = str(data["type"]).strip().lower()
        if "radius" in data:
            radius = data["radius"]
        elif "d" in data:
            radius = 0.5 * float(data["d"])
        else:
            raise ToolError(f"the tool object needs a 'radius' (mm), got {data!r}")
        if kind == "taper":
            angle = data.get("taper_angle", data.get("beta", DEFAULT_TAPER_ANGLE))
            out = cls.taper(radius, angle, **extra)
        else:
            cr = data.get("corner_radius", data.get("r", 0.0))
            out = cls.from_spec(kind, radius, cr, **extra)
        for k in ("d", "r", "e", "f", "alpha", "beta"):
            if data.get(k) is not None and abs(float(data[k]) - getattr(out, k)) > 1e-9 * out.d:
                raise ToolError(f"tool field {k} = {data[k]} contradicts the rest of the tool "
                                f"({k} = {getattr(out, k):g} for {out.type} radius {out.radius:g})")
        return out

    # ------------------------------------------------------------------ derived shape
    @property
    def radius(self) -> float:
        """Tool radius d/2, mm."""
        return 0.5 * self.d

    @property
    def corner_radius(self) -> float:
        """Corner radius r, mm."""
        return self.r

    @property
    def taper_angle(self) -> float:
        """Side angle β from the axis, rad."""
        return self.beta

    @cached_property
    def _g(self):
        """Profile key points: B (bottom tangent), S (side tangent), T (flute top), the
        corner arc's θ range."""
        e, f, r, al, be, h = self.e, self.f, self.r, self.alpha, self.beta, self.h
        B = (e + r * math.sin(al), f - r * math.cos(al))
        S = (e + r * math.cos(be), f - r * math.sin(be))
        T = (S[0] + (h - S[1]) * math.tan(be), h)
        return {"B": B, "S": S, "T": T, "th_lo": al, "th_hi": 0.5 * math.pi - be}

    @property
    def max_radius(self) -> float:
        """Largest distance of the cutting part from the axis (at the flute top), mm."""
        return float(self._g["T"][0])

    @property
    def bounding_radius(self) -> float:
        """Radius of a sphere about the tip containing the whole cutting part, mm."""
        return float(math.hypot(self._g["T"][0], self.h))

    def profile(self, n: int = 64) -> np.ndarray:
        """(k, 2) meridional outline (ρ, z) in mm from the tip up the bottom, around the
        corner (``n`` arc points) and up the side to the flute length h."""
        g = self._g
        th = np.linspace(g["th_lo"], g["th_hi"], max(int(n), 2))
        arc = np.stack([self.e + self.r * np.sin(th), self.f - self.r * np.cos(th)], axis=1)
        pts = [np.zeros((1, 2)), arc, np.array([g["T"]])]
        out = np.vstack(pts)
        keep = np.ones(len(out), bool)
        keep[1:] = np.any(np.abs(np.diff(out, axis=0)) > 1e-12, axis=1)
        return out[keep]

    # ------------------------------------------------------------------ contact
    def contact(self, normal, axis):
        """CC → CL for k poses: the offset ``tip − cc`` and where the cutter touches.

        Parameters
        ----------
        normal : (k, 3) or (3,) float — unit surface normals (out of the material)
        axis : (k, 3) or (3,) float — unit tool axes (tip → spindle)

        Returns
        -------
        offset : (k, 3) float, mm — ``tip = cc + offset``
        info : ContactInfo

        Raises
        ------
        ToolError — zero/NaN vectors, or an axis tilted beyond the side (θ > π/2 − β): the
            cutting part cannot touch the surface there.
        """
        n = _unit_rows(normal, "normal")
        a = _unit_rows(axis, "axis")
        n, a = np.broadcast_arrays(n, a)
        c = np.einsum("ij,ij->i", n, a)
        # n − (n·a) a as a × (n × a): the subtraction leaves a rounding residue ~1e-16 along a
        # that, divided by |perp| ~ sin θ, tilts u out of the plane ⊥ a by 1e-16 / sin θ
        # (6e-4 mm of contact off the cutter at θ = 1e-12). The double cross product is ⊥ a to
        # rounding relative to its own length, so u stays a unit vector ⊥ a for every θ > 0.
        perp = np.cross(a, np.cross(n, a))
        pl = np.linalg.norm(perp, axis=1)
        theta = np.arctan2(pl, c)  # accurate near 0, unlike arccos
        g = self._g
        if np.any(theta > g["th_hi"] + _ANGLE_TOL):
            bad = int(np.sum(theta > g["th_hi"] + _ANGLE_TOL))
            raise ToolError(
                f"{bad} pose(s) tilt the tool axis {np.degrees(theta.max()):.3g}° from the surface "
                f"normal; a {self.type} cutter touches with its cutting part only up to "
                f"{math.degrees(g['th_hi']):.3g}° — reduce the lead/tilt")
        theta = np.minimum(theta, g["th_hi"])
        on_axis = pl <= 1e-300
        u = -perp / np.where(on_axis, 1.0, pl)[:, None]
        if on_axis.any():  # (a perpendicular of every axis cost more than the rest here)
            u[on_axis] = perpendicular(a[on_axis])
        # bottom contact: a conical bottom's apex (θ < α), or a flat bottom (nearly) flush
        # (α = 0, e > 0, θ < _FLUSH_TILT): see _FLUSH_TILT for the blend to the ring contact
        flush = (self.alpha == 0.0) & (self.e > 0) & (theta < _FLUSH_TILT)
        tip_contact = (theta < g["th_lo"]) | flush
        theta = np.where(tip_contact, theta, np.maximum(theta, g["th_lo"]))
        rho = np.where(tip_contact, 0.0, self.e + self.r * np.sin(theta))
        rho = np.where(flush, self.e * (theta / _FLUSH_TILT), rho)
        z = np.where(tip_contact, 0.0, self.f - self.r * np.cos(theta))
        point = rho[:, None] * u + z[:, None] * a
        info = ContactInfo(theta=theta, rho=rho, height=z, radial=u,
                           region=np.where(tip_contact, 0, 1).astype(np.int8), point=point)
        return -point, info

    def cl_points(self, cc, normal, axis) -> np.ndarray:
        """(k, 3) tool tip (CL) points, mm, of the cutter touching ``cc`` (k, 3) with surface
        normals ``normal`` and tool axes ``axis`` (see :meth:`contact`)."""
        off, _ = self.contact(normal, axis)
        return np.asarray(cc, dtype=np.float64).reshape(-1, 3) + off

    def cl_points_and_zero_speed(self, cc, normal, axis, tol: float = 1e-3):
        """(:meth:`cl_points`, :meth:`zero_speed`) of the same poses from one contact
        computation: the same arrays as the two calls."""
        off, info = self.contact(normal, axis)
        return np.asarray(cc, dtype=np.float64).reshape(-1, 3) + off, info.rho <= float(tol)

    def zero_speed(self, normal, axis, tol: float = 1e-3) -> np.ndarray:
        """(k,) bool: the contact lies within ``tol`` mm of the rotation axis, where the
        cutting speed is (near) zero — a ball's or tapered ball's tip with the axis along n,
        a flat bottom flush with the surface."""
        _, info = self.contact(normal, axis)
        return info.rho <= float(tol)

    def effective_radius(self, normal, axis, side) -> np.ndarray:
        """(k,) mm: radius of curvature, in the plane (n, side), of the envelope the cutter
        sweeps moving along the feed n × side, at the contact (see the module docstring).

        ``side`` (k, 3) or (3,) is projected onto the tangent plane ⊥ n. ∞ for a flat bottom
        flush with the surface; 0 at a sharp apex or edge taken across (flat mill, φ = 0).
        """
        return self.effective_radii(normal, axis, side)[0]

    def effective_radii(self, normal, axis, *sides) -> list[np.ndarray]:
        """:meth:`effective_radius` for several ``sides`` at the same poses: one contact
        computation for all of them (the local gouge check asks two sides of thousands of
        candidate axes per flagged pose). The same values as separate calls."""
        n = _unit_rows(normal, "normal")
        _, info = self.contact(normal, axis)
        a = _unit_rows(axis, "axis")
        n, a = np.broadcast_arrays(n, a)
        th = info.theta
        sin_t = np.sin(th)
        tm = np.cos(th)[:, None] * info.radial + sin_t[:, None] * a
        with np.errstate(divide="ignore", invalid="ignore"):
            rho_p = np.where(sin_t > 0, self.e / np.where(sin_t > 0, sin_t, 1.0) + self.r,
                             np.inf if self.e > 0 else self.r)
        rho_m = np.full(len(th), self.r)
        out = []
        for side in sides:
            s = np.broadcast_to(np.atleast_2d(np.asarray(side, dtype=np.float64)), n.shape)
            s = s - np.einsum("ij,ij->i", s, n)[:, None] * n
            s = _unit_rows(s, "side (projected on the tangent plane)")
            cos2 = np.clip(np.einsum("ij,ij->i", s, tm), -1.0, 1.0) ** 2
            sin2 = 1.0 - cos2
            with np.errstate(invalid="ignore"):
                eff = rho_m * cos2 + np.where(sin2 > 0, rho_p * sin2, 0.0)
            out.append(np.where(info.region == 0, np.inf if self.alpha == 0 else 0.0, eff))
        return out

    # ------------------------------------------------------------------ distance
    def signed_distance_rz(self, rho, z) -> np.ndarray:
        """Exact signed distance (mm, < 0 inside) from meridional points (ρ ≥ 0, z) of the
        tool frame to the cutting part's profile region (the solid is convex, so this is
        the 3-D distance of the revolved solid)."""
        rho = np.abs(np.asarray(rho, dtype=np.float64))
        z = np.asarray(z, dtype=np.float64)
        g = self._g
        e, f, r, h = self.e, self.f, self.r, self.h
        B, S, T = g["B"], g["S"], g["T"]
        d2 = segment_distance2_2d(rho, z, 0.0, 0.0, *B)
        d2 = np.minimum(d2, segment_distance2_2d(rho, z, *S, *T))
        d2 = np.minimum(d2, segment_distance2_2d(rho, z, *T, 0.0, h))
        vr, vz = rho - e, z - f
        vl = np.hypot(vr, vz)
        # the arc's normal sector: θ(v) = atan2(vr, −vz) within [α, π/2 − β], via half-planes
        sa, ca = math.sin(g["th_lo"]), math.cos(g["th_lo"])
        sb, cb = math.sin(g["th_hi"]), math.cos(g["th_hi"])
        in_sector = (vr * ca - vz * sa >= 0) & (vr * cb + vz * sb <= 0)
        arc_d = np.abs(vl - r)
        dist = np.sqrt(d2)
        dist = np.where(in_sector, np.minimum(dist, arc_d), dist)
        inside = (z >= rho * math.tan(self.alpha)) & (z <= h)
        inside &= (rho - S[0]) * math.cos(self.beta) - (z - S[1]) * math.sin(self.beta) <= 0
        inside &= ~(in_sector & (vl > r))
        return np.where(inside, -dist, dist)

    def signed_distance(self, points, tip, axis) -> np.ndarray:
        """Exact signed distance (mm; < 0 inside) from points to the posed cutter solid(s).

        ``points`` (m, 3), ``tip`` (m, 3) or (3,), ``axis`` (m, 3) or (3,) unit — broadcast
        pairwise: point i against the cutter posed at (tip i, axis i)."""
        p = np.asarray(points, dtype=np.float64)
        t = np.asarray(tip, dtype=np.float64)
        a = np.asarray(axis, dtype=np.float64)
        dv = p - t
        z = np.einsum("...j,...j->...", dv, a)
        rr = np.einsum("...j,...j->...", dv, dv) - z * z
        return self.signed_distance_rz(np.sqrt(np.maximum(rr, 0.0)), z)


def _radius(radius) -> float:
    try:
        R = float(radius)
    except (TypeError, ValueError):
        raise ToolError(f"tool radius must be a number of mm, got {radius!r}") from None
    if not (math.isfinite(R) and R > 0):
        raise ToolError(f"tool radius must be a finite number > 0 mm, got {radius}")
    return R


def as_cutter(tool) -> Cutter:
    """A :class:`Cutter` from a Cutter, a legacy ``BallTool`` (``type``/``radius``
    attributes) or a paths-JSON "tool" dict."""
    if isinstance(tool, Cutter):
        return tool
    if isinstance(tool, dict):
        return Cutter.from_dict(tool)
    if hasattr(tool, "as_dict"):
        return Cutter.from_dict(tool.as_dict())
    if hasattr(tool, "radius"):
        return Cutter.from_spec(getattr(tool, "type", "ball"), tool.radius,
                                getattr(tool, "corner_radius", 0.0))
    raise ToolError(f"cannot read a cutter from {tool!r}")
