"""Tool-path result types: passes of cutter-contact (CC) points with their tool poses.

A pose (ARCHITECTURE.md, conventions) is: CC point, unit surface normal (out of the
material, toward the tool), tool tip point (CL) and unit tool axis (tip → spindle).
For a ball of radius ρ the ball centre is ``tip + ρ a`` (the tool as posed). With the axis along
the normal the generator puts the centre at ``cc + (ρ + λ) n``, λ ≥ 0 being the few-µm lift that
clears the facets around the CC point, so ``tip = cc + λ n``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .cones import Axis, Cone

__all__ = ["BallTool", "PassCurve", "ToolPath"]


@dataclass(frozen=True)
class BallTool:
    """A ball-end cutter of ``radius`` mm."""

    radius: float
    type: str = "ball"

    def as_dict(self) -> dict:
        return {"type": self.type, "radius": float(self.radius)}


@dataclass
class PassCurve:
    """One CC curve: the mesh ∩ the LMC at ratio ``s``, sampled for machining.

    Attributes
    ----------
    s : float — morph ratio of the LMC it lies on (0 = cone 1, 1 = cone 2)
    closed : bool — a closed loop (the last point connects to the first; not repeated)
    cc : (k, 3) float, mm — cutter-contact points, on the mesh and on the LMC
    normal : (k, 3) float — unit smooth surface normals at the CC points
    tip : (k, 3) float, mm — tool tip (CL) points
    axis : (k, 3) float — unit tool axes (tip → spindle)
    face : (k,) int — mesh face of each CC point (−1 where unknown)
    """

    s: float
    closed: bool
    cc: np.ndarray
    normal: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    face: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __len__(self) -> int:
        return len(self.cc)

    def centres(self, radius: float) -> np.ndarray:
        """(k, 3) ball centres of the tool as posed, ``tip + radius · axis`` (mm)."""
        return self.tip + radius * self.axis


@dataclass
class ToolPath:
    """A finishing path between two cones: passes in machining order of ``s``."""

    axis: Axis
    cone1: Cone
    cone2: Cone
    tool: BallTool
    cusp: float
    chord: float
    curves: list[PassCurve]
    stats: dict = field(default_factory=dict)

    @property
    def n_poses(self) -> int:
        return int(sum(len(c) for c in self.curves))

    @property
    def levels(self) -> np.ndarray:
        """(p,) distinct s of the passes in order."""
        return np.unique([c.s for c in self.curves])

    def length(self) -> float:
        """Total cutting length of the tip polylines, mm (closed curves include the closing move)."""
        total = 0.0
        for c in self.curves:
            p = np.vstack([c.tip, c.tip[:1]]) if c.closed else c.tip
            total += float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
        return total
