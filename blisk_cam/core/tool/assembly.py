"""The tool assembly for collision checking: the cutter's flute and the non-cutting body
(shank, neck, holder) above it, as a revolved (z, r) profile.

Tool frame as in :mod:`.cutter`: the tip (CL point) at the origin, z along the unit tool axis
(tip → spindle), r the distance from the axis. The **flute** is the cutting part from the tip
to ``flute_length`` (its shape is the :class:`~.cutter.Cutter`'s); the **body** is the
revolution of the profile ``[(z0, r0), (z1, r1), ...]`` with

* ``z0 == flute_length`` (the body starts where the flute ends; rule "profile starts at the
  flute length"),
* z non-decreasing (two equal z = a flat shoulder, the radius steps there),
* r ≥ 0 (mm), finite.

Consecutive profile points bound one frustum (a cylinder when r is constant, a cone when it
tapers); the body is their union, closed at the top by the last point's disc. The safety
distance ``safety`` (paper 004's ds, Eq. 9) is the clearance every pose must keep.

Presets: :meth:`ToolAssembly.plain_shank` (a shank of the tool diameter) and
:meth:`ToolAssembly.shrink_fit` (shank, then a shrink-fit holder with a tapered nose).
User-facing text gives tool sizes by diameter (Ø). Units mm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import CollisionError
from ..geometry.axis import Axis, revolve
from .cutter import as_cutter

__all__ = ["AssemblyError", "ToolAssembly", "DEFAULT_SAFETY", "assembly_mesh", "holder_profile"]

#: default safety distance ds, mm (paper 004 Eq. 9)
DEFAULT_SAFETY = 1.0
#: default half-angle of a shrink-fit nose, radians (4.5°: typical shrink-fit chucks)
SHRINK_FIT_NOSE_ANGLE = math.radians(4.5)


class AssemblyError(CollisionError):
    """The tool assembly (flute length, holder profile, safety distance) is impossible."""


def _num(name, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise AssemblyError(f"tool assembly {name} must be a number (mm), got {value!r}") from None
    if not math.isfinite(v):
        raise AssemblyError(f"tool assembly {name} must be a finite number (mm), got {value!r}")
    return v


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def holder_profile(text: str, name: str = "holder") -> tuple[tuple[float, float], ...]:
    """A holder profile typed by the user, ``'z r z r ...'`` (mm, commas or spaces), as
    ``((z, r), ...)``. :class:`AssemblyError` starting with ``name '<text>'`` (the flag or
    the panel field the user typed it in) when it is not pairs of numbers."""
    try:
        values = [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise AssemblyError(f"{name} '{text}': expected numbers 'z r z r ...' in mm") from None
    if len(values) < 2 or len(values) % 2:
        raise AssemblyError(f"{name} '{text}': expected pairs 'z r', got {len(values)} "
                            "number(s)")
    return tuple(zip(values[::2], values[1::2], strict=True))


@dataclass(frozen=True)
class ToolAssembly:
    """Flute length, body profile and safety distance (see the module docstring).

    Attributes
    ----------
    flute_length : float, mm — length of the cutting part above the tip (> 0)
    profile : tuple of (z, r) pairs, mm — the body outline; first z = ``flute_length``, z
        non-decreasing, r ≥ 0; at least two points with different z
    safety : float, mm — safety distance ds ≥ 0 (paper 004 Eq. 9)
    """

    flute_length: float
    profile: tuple
    safety: float = DEFAULT_SAFETY

    def __post_init__(self):
        fl = _num("flute length", self.flute_length)
        if not fl > 0:
            raise AssemblyError(f"flute length must be > 0 mm, got {_fmt(fl)}")
        ds = _num("safety distance", self.safety)
        if ds < 0:
            raise AssemblyError(
                f"safety distance must be ≥ 0 mm, got {_fmt(ds)}; give the clearance the "
                "tool must keep from the blades (e.g. 1 mm)"
            )
        try:
            P = np.asarray(self.profile, dtype=np.float64)
        except (TypeError, ValueError):
            raise AssemblyError(
                f"holder profile must be a list of (z, r) pairs in mm, got {self.profile!r}"
            ) from None
        if P.ndim != 2 or P.shape[1] != 2 or len(P) < 2:
            raise AssemblyError(
                "holder profile must be at least two (z, r) pairs in mm (z along the tool axis "
                f"from the tip, r the radius), got shape {P.shape}"
            )
        if not np.all(np.isfinite(P)):
            raise AssemblyError("holder profile: every z and r must be a finite number (mm)")
        tol = 1e-9 * max(1.0, fl)
        if abs(P[0, 0] - fl) > tol:
            rel = "above" if P[0, 0] > fl else "below"
            raise AssemblyError(
                f"holder profile must start at the flute length {_fmt(fl)} mm (rule: first z = "
                f"flute length), but its first z {_fmt(P[0, 0])} mm lies {rel} it; start the "
                "body where the flute ends"
            )
        P[0, 0] = fl
        dz = np.diff(P[:, 0])
        if np.any(dz < 0):
            j = int(np.nonzero(dz < 0)[0][0])
            raise AssemblyError(
                f"holder profile z must not decrease (equal z = a flat shoulder), but point "
                f"{j + 1} has z {_fmt(P[j + 1, 0])} mm after {_fmt(P[j, 0])} mm; list the "
                "points from the flute up to the spindle"
            )
        if np.any(P[:, 1] < 0):
            j = int(np.nonzero(P[:, 1] < 0)[0][0])
            raise AssemblyError(
                f"holder profile radius must be ≥ 0 mm, point {j} has r = {_fmt(P[j, 1])} mm "
                "(r is a radius, not a diameter offset)"
            )
        if not P[-1, 0] > P[0, 0]:
            raise AssemblyError("holder profile has no length: its last z equals its first")
        object.__setattr__(self, "flute_length", fl)
        object.__setattr__(self, "safety", ds)
        object.__setattr__(self, "profile", tuple((float(z), float(r)) for z, r in P))

    # ------------------------------------------------------------------ presets
    @classmethod
    def plain_shank(cls, tool_diameter: float, flute_length: float, shank_length: float,
                    safety: float = DEFAULT_SAFETY) -> ToolAssembly:
        """A plain shank of the tool diameter (Ø = ``tool_diameter`` mm) from the flute to
        ``flute_length + shank_length`` (the holder is not modelled)."""
        d = _num("tool diameter", tool_diameter)
        fl = _num("flute length", flute_length)
        sl = _num("shank length", shank_length)
        if not d > 0 or not sl > 0:
            raise AssemblyError(f"tool diameter and shank length must be > 0 mm, got Ø{_fmt(d)}, "
                                f"{_fmt(sl)}")
        return cls(fl, ((fl, d / 2), (fl + sl, d / 2)), safety)

    @classmethod
    def shrink_fit(cls, tool_diameter: float, flute_length: float, shank_length: float,
                   holder_diameter: float, holder_length: float,
                   nose_angle: float = SHRINK_FIT_NOSE_ANGLE,
                   safety: float = DEFAULT_SAFETY) -> ToolAssembly:
        """Shank Ø``tool_diameter`` out of a shrink-fit holder: the shank from the flute
        for ``shank_length`` mm (the stick-out above the flute), then the holder's tapered
        nose (half-angle ``nose_angle`` rad, from a wall of 2.5 mm around the shank) widening
        toward Ø``holder_diameter`` over at most half the holder, a shoulder to
        Ø``holder_diameter``, which continues to ``holder_length`` mm above the nose start."""
        d = _num("tool diameter", tool_diameter)
        fl = _num("flute length", flute_length)
        sl = _num("shank length", shank_length)
        hd = _num("holder diameter", holder_diameter)
        hl = _num("holder length", holder_length)
        na = _num("nose angle", nose_angle)
        if not (d > 0 and sl >= 0 and hl > 0):
            raise AssemblyError("tool diameter and holder length must be > 0 mm, shank length "
                                f"≥ 0 mm; got Ø{_fmt(d)}, {_fmt(hl)}, {_fmt(sl)}")
        if not 0 <= na < math.radians(60):
            raise AssemblyError(f"shrink-fit nose angle must lie in [0°, 60°), got "
                                f"{math.degrees(na):.3g}°")
        r_nose = d / 2 + 2.5
        if not hd / 2 >= r_nose:
            raise AssemblyError(f"holder Ø{_fmt(hd)} must be at least the nose Ø{_fmt(2 * r_nose)}"
                                f" (tool Ø{_fmt(d)} + 2 × 2.5 mm wall)")
        z1 = fl + sl
        nose = (hd / 2 - r_nose) / math.tan(na) if na > 0 else 0.0
        nose = min(nose, 0.5 * hl)  # at most half the holder: then a shoulder to its Ø
        r_top = min(r_nose + nose * math.tan(na), hd / 2)
        pts = [(fl, d / 2), (z1, d / 2), (z1, r_nose), (z1 + nose, r_top),
               (z1 + nose, hd / 2), (z1 + hl, hd / 2)]
        keep = [pts[0]] + [p for a, p in zip(pts, pts[1:], strict=False) if p != a]
        return cls(fl, tuple(keep), safety)

    # ------------------------------------------------------------------ JSON, text
    def as_dict(self) -> dict:
        """The paths JSON ``"tool" → "assembly"`` object: ``{"flute_length", "profile":
        [[z, r], ...], "safety"}`` (mm)."""
        return {"flute_length": self.flute_length,
                "profile": [[z, r] for z, r in self.profile],
                "safety": self.safety}

    @classmethod
    def from_dict(cls, d: dict) -> ToolAssembly:
        if not isinstance(d, dict) or "flute_length" not in d or "profile" not in d:
            raise AssemblyError(f"a tool assembly needs 'flute_length' and 'profile', got {d!r}")
        return cls(d["flute_length"], tuple(map(tuple, d["profile"])),
                   d.get("safety", DEFAULT_SAFETY))

    def describe(self) -> str:
        """Readable summary, e.g. ``"flute 24 mm, Ø12 shank to 40 mm, Ø32 holder to 120 mm"``:
        constant-radius stretches by diameter and where they end, tapers as Ø a→b."""
        parts = [f"flute {_fmt(self.flute_length)} mm"]
        P = self.profile
        names = []
        for (z0, r0), (z1, r1) in zip(P, P[1:], strict=False):
            if z1 == z0:
                continue
            if r0 == r1:
                names.append(f"Ø{_fmt(2 * r0)} to {_fmt(z1)} mm")
            else:
                names.append(f"taper Ø{_fmt(2 * r0)}→Ø{_fmt(2 * r1)} to {_fmt(z1)} mm")
        if names:
            names[0] = names[0].replace(" to", " shank to", 1) if P[1][1] == P[0][1] else names[0]
        if len(names) > 1 and "taper" not in names[-1]:
            names[-1] = names[-1].replace(" to", " holder to", 1)
        return ", ".join(parts + names) + f"; safety {_fmt(self.safety)} mm"

    # ------------------------------------------------------------------ geometry
    @property
    def top(self) -> float:
        """z of the body's top (mm)."""
        return self.profile[-1][0]

    @property
    def max_radius(self) -> float:
        """Largest body radius (mm)."""
        return max(r for _, r in self.profile)

    def frustums(self) -> np.ndarray:
        """(q, 4) float ``[z0, r0, z1, r1]`` of the body's frustums (z1 > z0; flat shoulders
        and zero-radius stretches left out — the neighbouring frustums' discs close them)."""
        P = np.asarray(self.profile)
        seg = np.hstack([P[:-1], P[1:]])[:, [0, 1, 2, 3]]
        keep = (seg[:, 2] > seg[:, 0]) & ((seg[:, 1] > 0) | (seg[:, 3] > 0))
        return seg[keep]

    def radius_at(self, z) -> np.ndarray:
        """(k,) body radius (mm) at heights ``z`` (the larger one at a shoulder; 0 outside)."""
        z = np.asarray(z, dtype=np.float64)
        out = np.zeros(z.shape)
        for z0, r0, z1, r1 in self.frustums():
            inside = (z >= z0) & (z <= z1)
            rr = r0 + (np.clip(z, z0, z1) - z0) * (r1 - r0) / (z1 - z0)
            out = np.where(inside, np.maximum(out, rr), out)
        return out

    def outline(self, cutter) -> np.ndarray:
        """(k, 2) meridional outline (r, z), mm, of the whole tool in the tool frame: from the
        tip (0, 0) up the cutter's profile to the flute length, then the body profile, closed
        on the axis at the top — the revolution column order of
        :func:`..geometry.axis.revolve`."""

        cutter = as_cutter(cutter)
        try:
            flute = replace(cutter, h=float(self.flute_length)).profile(24)
        except Exception as err:  # ToolError: flute shorter than the corner
            raise AssemblyError(f"flute length {_fmt(self.flute_length)} mm is impossible for "
                                f"the cutter: {err}") from None
        body = np.asarray(self.profile, dtype=np.float64)[:, ::-1]  # (z, r) → (r, z)
        top = np.array([[0.0, self.top]])
        out = np.vstack([flute, body, top])
        keep = np.ones(len(out), bool)
        keep[1:] = np.any(np.abs(np.diff(out, axis=0)) > 1e-12, axis=1)
        return out[keep]


def assembly_mesh(assembly: ToolAssembly, cutter, segments: int = 48):
    """The tool assembly (cutter flute and body) as a quad mesh in the tool frame: tip at the
    origin, the tool axis along +z (mm). Returns V (n, 3) float64 and F (m, 4) int64; the
    first ``segments`` vertices are the tip (exactly (0, 0, 0))."""
    return revolve(assembly.outline(cutter), Axis((0.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
                   segments=segments)
