"""Polishing process values of the force-controlled head (paper 004 §4: the removal depth).

Preston's law: the depth removed is ``h = K_p · p · v · t`` — pressure p (N/mm²) times the
relative speed v (mm/s) of the abrasive over the surface times the time t (s) a surface
point spends under the contact. A contact patch of width w (across the feed) and length L
(along it), pressed with the force F, at feed v_f: ``p = F / (w L)``, ``t = L / v_f``, so

    h = K_p · F · v / (w · v_f)                (L cancels)

with v = π · D · n / 60 for a wheel of diameter D at n rev/min. ``K_p`` (mm²/N) is the
Preston coefficient of the abrasive and the alloy, measured on a test coupon (the paper
controls the removal depth; it does not publish K_p). Each pose in contact (cutting and
on-surface link moves) removes h; approach, retract and rapid poses remove nothing.

Units: N, mm, rev/min, mm/min in; mm and MPa out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..toolpath.types import MOVE_CUT, MOVE_LINK, ToolPath
from .description import RobotError

__all__ = ["PolishingProcess", "removal_per_pose"]


@dataclass(frozen=True)
class PolishingProcess:
    """force N; head_rpm rev/min; head_diameter mm; contact_width mm (across the feed);
    preston K_p mm²/N; feed mm/min."""

    force: float
    head_rpm: float
    head_diameter: float
    contact_width: float
    preston: float
    feed: float

    def __post_init__(self):
        for name in ("force", "head_rpm", "head_diameter", "contact_width", "preston", "feed"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise RobotError(f"polishing: {name.replace('_', ' ')} must be > 0, got {v!r}")

    @property
    def surface_speed(self) -> float:
        """Relative speed of the abrasive over the surface, mm/s (π D n / 60)."""
        return math.pi * self.head_diameter * self.head_rpm / 60.0

    @property
    def removal_depth(self) -> float:
        """Depth removed by one pass, mm: ``K_p F v / (w v_f)`` (module docstring)."""
        return (self.preston * self.force * self.surface_speed
                / (self.contact_width * self.feed / 60.0))

    def pressure(self, contact_length: float) -> float:
        """Mean contact pressure, N/mm² (MPa), for a patch ``contact_length`` mm long."""
        if not contact_length > 0:
            raise RobotError(f"polishing: contact length must be > 0 mm, got {contact_length}")
        return self.force / (self.contact_width * contact_length)

    def summary(self) -> str:
        return (f"force {self.force:g} N, head Ø{self.head_diameter:g} at {self.head_rpm:g} "
                f"rev/min ({self.surface_speed / 1000:.2f} m/s), contact width "
                f"{self.contact_width:g} mm, feed {self.feed:g} mm/min: Preston removal "
                f"{1000 * self.removal_depth:.2f} µm per pass")


def removal_per_pose(process: PolishingProcess, path: ToolPath) -> np.ndarray:
    """(m,) mm removed at each pose of the linked program: the pass depth where the head is in
    contact (cut and link moves), 0 elsewhere."""
    if path.program is None:
        raise RobotError("the path has no linked program; link the passes first")
    contact = np.isin(path.program.move, (MOVE_CUT, MOVE_LINK))
    return np.where(contact, process.removal_depth, 0.0)
