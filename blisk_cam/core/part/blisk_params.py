"""The parameters of the parametric blisk (:class:`DemoParams`), validated
with errors that name the parameter, and the triangle count they give.
Lengths in mm, angles in degrees where the user types them.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..errors import BliskCamError, ConeError
from .cones import Cone

__all__ = ["DemoParameterError", "DemoParams", "blade_grid_shape", "blade_triangle_count"]

TWO_PI = 2.0 * math.pi
_SIDE_STRETCH = 0.95  # share of the cosine law in the chordwise spacing of the sides


class DemoParameterError(BliskCamError):
    """A demo-blisk parameter is out of range; the message names it and the allowed range."""


# ---------------------------------------------------------------------------------- params
def _deg(x: float) -> str:
    return f"{math.degrees(x):.6g}°"


def _fail(name: str, value, allowed: str, hint: str = "") -> None:
    msg = f"demo parameter {name} = {value!r} is out of range: allowed {allowed}"
    if hint:
        msg += f"; {hint}"
    raise DemoParameterError(msg)


def _real(name: str, value, allowed: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
        raise DemoParameterError(
            f"demo parameter {name} = {value!r} is not a finite real number: allowed {allowed}"
        )
    return float(value)


def _in_range(name, value, lo, hi, unit="mm", *, angle=False, lo_open=False):
    rel = "<" if lo_open else "≤"
    if angle:
        allowed = f"{lo:.6g} {rel} {name} ≤ {hi:.6g} rad ({_deg(lo)} … {_deg(hi)})"
    else:
        allowed = f"{lo:.6g} {rel} {name} ≤ {hi:.6g}{' ' + unit if unit else ''}"
    v = _real(name, value, allowed)
    if (v <= lo if lo_open else v < lo) or v > hi:
        _fail(name, value, allowed)
    return v


@dataclass(frozen=True)
class DemoParams:
    """Parameters of the demo blisk (mm, radians). Checked on construction.

    Parameters
    ----------
    blade_count : int, 3 … 200
        Number of blades N; blade pitch 2π/N.
    hub_cone, tip_cone : Cone or 4 floats (r1, z1, r2, z2), mm
        Generatrices of cone 1 (hub) and cone 2 (blade tip) in the meridional half-plane.
        Default hub r 150 → 165 mm over z −25 … 35 mm, tip r 215 → 225 mm.
    chord_hub, chord_tip : float, 5 … 500 mm
        Camber-line chord (LE-circle centre to TE-circle centre) at the hub and tip.
    stagger_hub, stagger_tip : float, −80° … 80° (radians)
        Angle of the chord from the generatrix direction toward +θ (twist: varies with span).
    camber_hub, camber_tip : float, −80° … 80° (radians)
        Camber angle φ (total turning of the circular-arc camber line).
    max_thickness_hub, max_thickness_tip : float, mm
        Maximum thickness (inscribed-circle diameter), > 2.5 max(le_radius, te_radius) and
        ≤ 0.25 chord.
    max_thickness_position : float, 0.35 … 0.65
        Chord fraction (along the camber line) of the maximum thickness.
    le_radius, te_radius : float, 0.05 … 5 mm
        Leading- and trailing-edge radii (the issue asks 0.2–0.5 mm, default 0.3).
    lean : float, −45° … 45° (radians)
        Tangential lean of the stacking line toward +θ.
    stack_position : float, 0 … 1
        Position of the chord midpoint along the LMC generatrix A(v) → B(v).
    fillet : bool
        Add the hub fillet (circular flare of the section near the hub).
    fillet_radius : float, 3 … 50 mm (and ≤ 0.4 of the blade height)
        Fillet radius ρ_f; default 8 mm. The surface's tightest concave principal radius is
        ≈ 0.72 ρ_f (5.7 mm for 8 mm, see **Fillet** above): a 6 mm ball needs ρ_f ≥ 8.5 mm.
    resolution : float, 0.1 … 10
        Mesh density k: ≈ 100 000 k² blade triangles (see :func:`blade_grid_shape`).
    hub_pitches : float, 1 … blade_count
        Circumferential width of the hub strip in blade pitches: it covers the feet of
        blades ``|i| ≤ floor((hub_pitches − 1) / 2)`` (default 3: blades −1, 0, 1) plus
        ``hub_extension``; ``= blade_count`` gives the full ring.
    hub_extension : float, 0 … 500 mm
        Margin of the hub strip beyond the hub-cone segment and the blade feet (meridional
        and circumferential).
    scan_like : bool
        Irregular, noisy, scanner-like triangulation instead of the clean grid.
    scan_noise : float, 0 … 0.1 mm
        Standard deviation of the normal noise in scan-like mode (default 3 µm).
    scan_jitter : float, 0 … 0.45
        Parameter-grid jitter: nodes move by up to ``scan_jitter / 2`` of the smaller
        neighbouring spacing (cells stay convex, so no triangle flips).
    scan_sliver_fraction : float, 0 … 0.2
        Fraction of grid cells split into four with a vertex close to an edge (slivers).
    seed : int ≥ 0
        Seed of ``numpy.random.default_rng`` for scan-like mode.
    """

    blade_count: int = 24
    hub_cone: tuple[float, float, float, float] = (150.0, -25.0, 165.0, 35.0)
    tip_cone: tuple[float, float, float, float] = (215.0, -25.0, 225.0, 35.0)
    chord_hub: float = 50.0
    chord_tip: float = 50.0
    stagger_hub: float = math.radians(30.0)
    stagger_tip: float = math.radians(50.0)
    camber_hub: float = math.radians(40.0)
    camber_tip: float = math.radians(15.0)
    max_thickness_hub: float = 3.5
    max_thickness_tip: float = 2.0
    max_thickness_position: float = 0.45
    le_radius: float = 0.3
    te_radius: float = 0.3
    lean: float = math.radians(5.0)
    stack_position: float = 0.5
    fillet: bool = True
    fillet_radius: float = 8.0
    resolution: float = 1.0
    hub_pitches: float = 3.0
    hub_extension: float = 10.0
    scan_like: bool = False
    scan_noise: float = 0.003
    scan_jitter: float = 0.4
    scan_sliver_fraction: float = 0.02
    seed: int = 0

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        n = self.blade_count
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 3 <= n <= 200:
            _fail("blade_count", n, "an integer 3 ≤ blade_count ≤ 200")
        put("blade_count", int(n))
        for name in ("hub_cone", "tip_cone"):
            c = getattr(self, name)
            if isinstance(c, Cone):
                c = c.as_list()
            allowed = "four finite numbers r1, z1, r2, z2 (mm), r ≥ 0, P1 ≠ P2"
            try:
                vals = [float(x) for x in c]
            except (TypeError, ValueError):
                vals = []
            if len(vals) != 4:
                _fail(name, c, allowed)
            problem = ""
            try:
                Cone(*vals)
            except ConeError as err:
                problem = str(err)
            if problem:
                _fail(name, c, allowed, problem)
            put(name, tuple(vals))
        for name in ("chord_hub", "chord_tip"):
            put(name, _in_range(name, getattr(self, name), 5.0, 500.0))
        lim = math.radians(80.0)
        for name in ("stagger_hub", "stagger_tip", "camber_hub", "camber_tip"):
            put(name, _in_range(name, getattr(self, name), -lim, lim, angle=True))
        put("lean", _in_range("lean", self.lean, -math.pi / 4, math.pi / 4, angle=True))
        for name in ("le_radius", "te_radius"):
            put(name, _in_range(name, getattr(self, name), 0.05, 5.0))
        rmax = max(self.le_radius, self.te_radius)
        for end in ("hub", "tip"):
            name, chord = f"max_thickness_{end}", getattr(self, f"chord_{end}")
            lo, hi = 2.5 * rmax, 0.25 * chord
            allowed = (
                f"2.5·max(le_radius, te_radius) = {lo:.6g} < {name} ≤ 0.25·chord_{end} = "
                f"{hi:.6g} mm"
            )
            t = _real(name, getattr(self, name), allowed)
            if not lo < t <= hi:
                _fail(name, t, allowed, "the edge circles must be clearly thinner than the blade")
            put(name, t)
        put(
            "max_thickness_position",
            _in_range("max_thickness_position", self.max_thickness_position, 0.35, 0.65, ""),
        )
        put("stack_position", _in_range("stack_position", self.stack_position, 0.0, 1.0, ""))
        for name in ("fillet", "scan_like"):
            b = getattr(self, name)
            if not isinstance(b, bool | np.bool_):
                _fail(name, b, "True or False")
            put(name, bool(b))
        put("fillet_radius", _in_range("fillet_radius", self.fillet_radius, 3.0, 50.0))
        put("resolution", _in_range("resolution", self.resolution, 0.1, 10.0, ""))
        put(
            "hub_pitches",
            _in_range("hub_pitches", self.hub_pitches, 1.0, float(self.blade_count), "pitches"),
        )
        put("hub_extension", _in_range("hub_extension", self.hub_extension, 0.0, 500.0))
        put("scan_noise", _in_range("scan_noise", self.scan_noise, 0.0, 0.1))
        put("scan_jitter", _in_range("scan_jitter", self.scan_jitter, 0.0, 0.45, ""))
        put(
            "scan_sliver_fraction",
            _in_range("scan_sliver_fraction", self.scan_sliver_fraction, 0.0, 0.2, ""),
        )
        s = self.seed
        if isinstance(s, bool) or not isinstance(s, numbers.Integral) or s < 0:
            _fail("seed", s, "an integer ≥ 0")
        put("seed", int(s))


# ---------------------------------------------------------------------------------- grid
def blade_grid_shape(resolution: float) -> tuple[int, int, int, int]:
    """Blade grid for a resolution (clean mode).

    Parameters
    ----------
    resolution : float, 0.1 … 10

    Returns
    -------
    n_v : int — rows (hub → tip), n_u : int — points around each section,
    n_a : int — points per edge arc, n_s : int — points per side.
    The clean blade has ``n_u n_v`` vertices and ``2 n_u (n_v − 1)`` triangles.
    """
    k = _in_range("resolution", resolution, 0.1, 10.0, "")
    n_a = max(6, round(50 * k))
    n_s = max(12, round(150 * k))
    n_v = max(8, round(125 * k)) + 1
    return n_v, 2 * (n_a + n_s), n_a, n_s


def blade_triangle_count(resolution: float) -> int:
    """Triangles of one clean blade, ``2 n_u (n_v − 1)`` ≈ 100 000 resolution².

    Scan-like mode adds two per sliver cell (``scan_sliver_fraction`` of the cells).
    """
    n_v, n_u, _, _ = blade_grid_shape(resolution)
    return 2 * n_u * (n_v - 1)
