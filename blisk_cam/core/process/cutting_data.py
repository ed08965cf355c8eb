"""Cutting data from the part's material: surface speed, feed per tooth, and the spindle speed
and feed at the cutter's *effective* cutting diameter.

A ball or bull nose does not cut at its nominal diameter: at a small depth of cut ap and with
the axis at an angle β from the surface normal, the largest diameter in the cut is

    D_eff = 2 (e + r sin(min(β + arccos(1 − ap / r), π/2 − β_side)))

with r the corner radius (the ball radius for a ball), e = d/2 − r the corner centre's offset
from the axis and β_side the side (taper) angle (0 but for a tapered ball). For a ball this is
the tool makers' D_eff = D sin(β + arccos((D − 2 ap)/D)) (Sandvik Coromant, *Milling — ball
nose end mills, effective cutting diameter*); for a bull nose with its axis along the normal,
D_eff = D − 2 r + 2 √(ap (2 r − ap)) (the same guide, toroidal cutters); a flat end cuts at D.
Programming the spindle for the nominal diameter would run the edge at a fraction of the
surface speed the material wants (a Ø12 ball at 0.2 mm depth and 10° lead cuts at Ø5.8: half
the speed), so the spindle speed is

    n = 1000 · vc / (π · D_eff)       (rpm, rounded to a whole rpm; vc in m/min, D_eff mm)

and the feed vf = n · z · fz (mm/min; z flutes, fz feed per tooth in mm).

The table (:data:`MATERIALS`) gives, per material and cutter family, the *typical range* of vc
and fz for solid carbide, coated end mills of about Ø6–Ø20 in finishing and semi-finishing
(small radial engagement), and the value used (the middle of the range). They are starting
values as the handbooks and catalogues give them, not tuned data; a shop overrides them per
operation (``vc``, ``fz``, ``spindle``, ``feed`` in the job file). Sources:

* Machinery's Handbook, 31st ed. (Industrial Press, 2020), "Speeds and feeds for milling":
  titanium alloys (Ti-6Al-4V, annealed), nickel-base superalloys (Inconel 718, aged) and
  wrought aluminium alloys, carbide end mills;
* Sandvik Coromant, *Machining Guide / Technical Guide, Milling*: ISO S (HRSA, titanium) and
  ISO N (aluminium) cutting data for solid carbide end mills, and the effective-diameter
  formulas above;
* tool makers' catalogue ranges for ball and bull nose end mills in aerospace alloys
  (e.g. Kennametal, Seco Jabro, Walter): Ti-6Al-4V vc ≈ 40–100 m/min, Inconel 718
  vc ≈ 20–50 m/min, aluminium vc ≈ 300–900 m/min (spindle-limited), fz ≈ 0.02–0.15 mm.

Units: mm, m/min, rpm, mm/min; angles radians.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

from ..errors import BliskCamError

__all__ = ["CUTTER_FAMILY", "MATERIALS", "CuttingData", "CuttingRange", "cutting_data",
           "effective_diameter", "material_key"]


@dataclass(frozen=True)
class CuttingRange:
    """Typical range of surface speed vc (m/min) and feed per tooth fz (mm); the value used
    is the middle of each range."""

    vc: tuple[float, float]
    fz: tuple[float, float]

    @property
    def vc_mid(self) -> float:
        return 0.5 * (self.vc[0] + self.vc[1])

    @property
    def fz_mid(self) -> float:
        return 0.5 * (self.fz[0] + self.fz[1])


#: cutter type → the family the tables give data for (a taper is a ball at its tip)
CUTTER_FAMILY = {"ball": "ball", "taper": "ball", "bull": "end", "flat": "end"}

#: material → {cutter family: CuttingRange}: solid carbide, coated, finishing/semi-finishing
#: (sources in the module docstring; typical ranges, the middle used)
MATERIALS = {
    "Ti-6Al-4V": {"ball": CuttingRange((50.0, 100.0), (0.03, 0.08)),
                  "end": CuttingRange((40.0, 80.0), (0.03, 0.10))},
    "Inconel 718": {"ball": CuttingRange((25.0, 50.0), (0.02, 0.06)),
                    "end": CuttingRange((20.0, 40.0), (0.02, 0.07))},
    "Al 7075": {"ball": CuttingRange((300.0, 600.0), (0.05, 0.12)),
                "end": CuttingRange((300.0, 600.0), (0.05, 0.15))},
    "Al 6061": {"ball": CuttingRange((300.0, 700.0), (0.05, 0.12)),
                "end": CuttingRange((300.0, 700.0), (0.05, 0.15))},
}

_ALIASES = {"ti64": "Ti-6Al-4V", "ti6al4v": "Ti-6Al-4V", "ti-6-4": "Ti-6Al-4V",
            "in718": "Inconel 718", "inconel718": "Inconel 718", "alloy718": "Inconel 718",
            "7075": "Al 7075", "al7075": "Al 7075", "aluminium7075": "Al 7075",
            "aluminum7075": "Al 7075", "6061": "Al 6061", "al6061": "Al 6061",
            "aluminium6061": "Al 6061", "aluminum6061": "Al 6061"}


def material_key(name: str) -> str:
    """The table's name of a material typed by a user ('Ti-6Al-4V', 'ti64', 'Inconel 718',
    'IN718', 'Al 7075', '6061' …); BliskCamError naming the known ones (and the nearest)."""
    text = str(name).strip()
    for key in MATERIALS:
        if text.lower() == key.lower():
            return key
    squeezed = "".join(ch for ch in text.lower() if ch.isalnum() or ch == "-").replace("-", "")
    for alias, key in _ALIASES.items():
        if squeezed == alias.replace("-", ""):
            return key
    close = difflib.get_close_matches(text, list(MATERIALS), n=1, cutoff=0.5)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    raise BliskCamError(f"unknown material {name!r}{hint} (known: {', '.join(MATERIALS)}; "
                        "or give vc and fz per operation)")


def effective_diameter(cutter, depth: float, tilt: float) -> float:
    """The largest cutting diameter (mm) of ``cutter`` (:class:`..tool.cutter.Cutter`) in a cut
    of depth ``depth`` (mm, along the surface normal) with its axis ``tilt`` radians from the
    surface normal (module docstring). The nominal diameter for a flat end or where the cut
    reaches the periphery."""
    d, r = float(cutter.d), float(cutter.r)
    if not (math.isfinite(depth) and depth > 0.0):
        raise BliskCamError(f"the depth of cut must be > 0 mm, got {depth!r}")
    if r <= 0.0:
        return d
    e = 0.5 * d - r
    side = float(getattr(cutter, "beta", 0.0) or 0.0)
    top = 0.5 * math.pi - side
    theta = abs(float(tilt)) + math.acos(max(-1.0, 1.0 - depth / r))
    return 2.0 * (e + r * math.sin(min(theta, top)))


@dataclass(frozen=True)
class CuttingData:
    """One operation's cutting data.

    vc : m/min; fz : mm; flutes : z; d_eff : mm (effective cutting diameter); depth : mm (ap);
    tilt : rad (axis from the surface normal); spindle : rpm; feed : mm/min; source : str —
    where vc/fz came from ("Ti-6Al-4V ball nose table", "operation override"); limited : str —
    why the spindle was capped ("" when it was not)."""

    vc: float
    fz: float
    flutes: int
    d_eff: float
    depth: float
    tilt: float
    spindle: float
    feed: float
    source: str
    limited: str = ""


def cutting_data(cutter, flutes: int, material: str | None, depth: float, tilt: float, *,
                 vc: float | None = None, fz: float | None = None,
                 spindle: float | None = None, feed: float | None = None,
                 max_spindle: float | None = None) -> CuttingData:
    """Spindle speed and feed of a cutter in a material at its effective diameter.

    ``vc`` (m/min) and ``fz`` (mm) override the material's table; ``spindle`` (rpm) and
    ``feed`` (mm/min) override the results. Without a material, vc and fz (or spindle and
    feed) must be given. The spindle is capped at ``max_spindle`` (rpm; the feed follows the
    capped speed)."""
    family = CUTTER_FAMILY.get(cutter.type, "end")
    source = "operation override"
    if vc is None or fz is None:
        if material is None:
            if spindle is None or feed is None:
                raise BliskCamError("no material given: give vc and fz (or spindle and feed)")
        else:
            rng = MATERIALS[material_key(material)][family]
            word = "ball nose" if family == "ball" else "end mill / bull nose"
            source = f"{material_key(material)} {word} table"
            vc = rng.vc_mid if vc is None else vc
            fz = rng.fz_mid if fz is None else fz
    d_eff = effective_diameter(cutter, depth, tilt)
    limited = ""
    if spindle is None:
        n = float(round(1000.0 * float(vc) / (math.pi * d_eff)))  # whole rpm, as programmed
        if max_spindle is not None and n > max_spindle:
            limited = (f"{n:.0f} rpm for vc {vc:g} m/min at Ø{d_eff:.2f} is above the "
                       f"spindle's {max_spindle:g} rpm")
            n = float(math.floor(max_spindle))
    else:
        n = float(spindle)
        source = "operation override" if vc is None else source
    f = float(feed) if feed is not None else n * int(flutes) * float(fz)
    return CuttingData(vc=float(vc) if vc is not None else math.pi * d_eff * n / 1000.0,
                       fz=float(fz) if fz is not None else f / (n * int(flutes)),
                       flutes=int(flutes), d_eff=d_eff, depth=float(depth), tilt=float(tilt),
                       spindle=n, feed=f, source=source, limited=limited)
