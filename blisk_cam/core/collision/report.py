"""What a collision run found: per-pose status, the rows of colliding and
unresolved poses, the worst pose and the next unresolved one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..toolpath.types import (
    STATUS_UNRESOLVED,
    ToolPath,
)

__all__ = [
    "CollisionReport",
    "collision_rows",
    "pose_collision_status",
    "unresolved_rows",
    "worst_pose",
    "next_unresolved",
]


@dataclass
class CollisionReport:
    """Result of :func:`run_collisions` / :func:`avoid_collisions`.

    Counts are over the program rows (every pose the machine visits; a closed pass's closing
    pose counts twice), or over the pass poses when the path has no program.

    Attributes
    ----------
    mode : str; safety : float, mm
    n_checked, n_colliding_before, n_corrected, n_unresolved : int
    min_clearance : float, mm — after avoidance (before, in check mode)
    min_clearance_before : float, mm
    obstacles : dict — names, triangle counts, blade count, neighbours
    assembly : dict — :meth:`ToolAssembly.as_dict`; assembly_text : str
    curve_status : list of (k,) int8 per pass; curve_clearance : list of (k,) float, mm
    curve_rotation : list of (k,) float, rad — angle between the final and the planned axis
    curve_rotation_normal : list of (k,) float, rad — the rotation toward the obstacle normal
        the same clearance would need (paper 004 Table 1), NaN where the pose did not collide
    curve_rotation_first : list of (k,) float, rad — the first (Eq. 12) rotation of every
        colliding pose, NaN elsewhere: compare with ``curve_rotation_normal``
    curve_lift : list of (k,) float, mm — lift along the normal (Eq. 15)
    program_status : (m,) int8 or None; program_clearance : (m,) float or None
    n_turn_over : int — consecutive pass poses whose axes turn past the limit after
        avoidance: method "plan", the planner's (the planned turn + turn_per_mm × the tool
        path's length, :func:`.axis_field.turn_limits`); method "rotate", max(max_turn, the
        planned turn there) (mostly a corrected pose next to an unresolved one, which keeps
        its planned axis); max_turn_deg : the largest such turn
    n_turn_unresolved : int — turns past the planner's limit between two unresolved poses
        (only with ``CollisionOptions.turn_jumps`` the planner may jump there), not in
        ``n_turn_over``
    links : dict — the link runs checked, colliding, re-routed and unresolved
        (:func:`.reroute.reroute_links`); empty without a program
    method : str — "plan" or "rotate" in mode "avoid", else ""
    unresolved_ranges : list of {"pass", "from", "to", "why", "min_clearance"} — the runs
        of unresolved pass poses (:func:`.ranges.unresolved_ranges`)
    planner : dict — the axis planner's figures (poses planned, candidates evaluated, turn
        limit in °/mm, reference); empty for "rotate"
    tool_hint : str — which holder diameter or stick-out would clear the unresolved poses
        (:func:`.ranges.holder_hint`), "" when none are unresolved
    """

    mode: str
    safety: float
    n_checked: int = 0
    n_colliding_before: int = 0
    n_corrected: int = 0
    n_unresolved: int = 0
    min_clearance: float = math.nan
    min_clearance_before: float = math.nan
    obstacles: dict = field(default_factory=dict)
    assembly: dict = field(default_factory=dict)
    assembly_text: str = ""
    curve_status: list = field(default_factory=list)
    curve_clearance: list = field(default_factory=list)
    curve_rotation: list = field(default_factory=list)
    curve_rotation_normal: list = field(default_factory=list)
    curve_rotation_first: list = field(default_factory=list)
    curve_lift: list = field(default_factory=list)
    program_status: np.ndarray | None = None
    program_clearance: np.ndarray | None = None
    n_turn_over: int = 0
    max_turn_deg: float = 0.0
    n_turn_unresolved: int = 0
    links: dict = field(default_factory=dict)
    method: str = ""
    unresolved_ranges: list = field(default_factory=list)
    planner: dict = field(default_factory=dict)
    tool_hint: str = ""

    def summary(self) -> dict:
        """JSON-ready top-level ``"collision"`` object of the paths file."""

        def fin(x):
            return float(x) if math.isfinite(x) else None

        def cat(x):
            return np.concatenate(x) if x else np.zeros(0)

        rot, rn, r1 = cat(self.curve_rotation), cat(self.curve_rotation_normal), \
            cat(self.curve_rotation_first)
        both = np.isfinite(rn) & np.isfinite(r1)
        return {
            "mode": self.mode,
            "checked_poses": int(self.n_checked),
            "colliding_before": int(self.n_colliding_before),
            "corrected": int(self.n_corrected),
            "unresolved": int(self.n_unresolved),
            "min_clearance": fin(self.min_clearance),
            "min_clearance_before": fin(self.min_clearance_before),
            "max_rotation_deg": float(np.degrees(rot.max())) if len(rot) else 0.0,
            "mean_first_rotation_deg": float(np.degrees(r1[both].mean())) if both.any()
            else None,
            "mean_rotation_normal_deg": float(np.degrees(rn[both].mean())) if both.any()
            else None,
            "turn_over_limit": int(self.n_turn_over),
            "max_turn_over_deg": float(self.max_turn_deg),
            **({"turns_between_unresolved": int(self.n_turn_unresolved)}
               if self.n_turn_unresolved else {}),
            "obstacles": self.obstacles,
            "assembly": self.assembly,
            "assembly_text": self.assembly_text,
            "safety": float(self.safety),
            **self.links,
            **({"method": self.method} if self.method else {}),
            **({"unresolved_ranges": list(self.unresolved_ranges)}
               if self.unresolved_ranges else {}),
            **({"planner": dict(self.planner)} if self.planner else {}),
            **({"tool_hint": self.tool_hint} if self.tool_hint else {}),
        }


# ====================================================================== reading a checked path
def pose_collision_status(path: ToolPath) -> np.ndarray | None:
    """(n_poses,) int8 status of every pass pose (curve order, as the point cloud of the
    Blender output), 0 for a curve without collision data; None when no curve was checked."""
    if not any(c.collision is not None for c in path.curves):
        return None
    parts = [np.asarray(c.collision["status"], dtype=np.int8) if c.collision is not None
             else np.zeros(len(c), dtype=np.int8) for c in path.curves]
    return np.concatenate(parts) if parts else np.zeros(0, dtype=np.int8)


def collision_rows(path: ToolPath):
    """(tips (m, 3), axes (m, 3), status (m,), clearance (m,)) of every checked pose: the
    program rows when the program carries the collision data (links included), else the
    pass poses of the checked curves; None when the path was not checked."""
    prog = path.program
    if prog is not None and prog.collision_status is not None and prog.clearance is not None:
        return (np.asarray(prog.tip, float), np.asarray(prog.axis, float),
                np.asarray(prog.collision_status, np.int8), np.asarray(prog.clearance, float))
    curves = [c for c in path.curves if c.collision is not None]
    if not curves:
        return None
    return (np.vstack([c.tip for c in curves]), np.vstack([c.axis for c in curves]),
            np.concatenate([np.asarray(c.collision["status"], np.int8) for c in curves]),
            np.concatenate([np.asarray(c.collision["clearance"], float) for c in curves]))


def worst_pose(path: ToolPath):
    """(tip (3,), unit axis (3,), clearance mm, row) of the checked pose with the smallest
    clearance (the first one on a tie); None when the path was not checked."""
    rows = collision_rows(path)
    if rows is None or len(rows[3]) == 0:
        return None
    tips, axes, _, clr = rows
    i = int(np.argmin(np.where(np.isfinite(clr), clr, np.inf)))
    a = axes[i] / np.linalg.norm(axes[i])
    return tips[i].copy(), a, float(clr[i]), i


def unresolved_rows(path: ToolPath) -> np.ndarray:
    """Indices (into :func:`collision_rows`) of the unresolved poses, in machining order."""
    rows = collision_rows(path)
    if rows is None:
        return np.zeros(0, dtype=np.int64)
    return np.nonzero(rows[2] == STATUS_UNRESOLVED)[0]


def next_unresolved(path: ToolPath, current=None, tol: float = 1e-3):
    """The unresolved pose after the one at ``current`` (a point, mm: e.g. the 3D cursor),
    in machining order, wrapping around; the first one when ``current`` is at none of them.
    Poses at the same tip (a closed pass's closing pose) count once.

    Returns (tip (3,), unit axis (3,), row, k, n) — k-th (0-based) of n distinct unresolved
    tips — or None when no pose is unresolved."""
    rows = collision_rows(path)
    idx = unresolved_rows(path)
    if rows is None or len(idx) == 0:
        return None
    tips = rows[0][idx]
    keep = []
    for j in range(len(idx)):  # distinct tips, first occurrence, machining order
        if not any(np.linalg.norm(tips[j] - tips[i]) <= tol for i in keep):
            keep.append(j)
    n = len(keep)
    k = 0
    if current is not None:
        d = np.linalg.norm(tips[keep] - np.asarray(current, dtype=np.float64), axis=1)
        at = np.nonzero(d <= tol)[0]
        if len(at):
            k = (int(at[0]) + 1) % n
    j = keep[k]
    a = rows[1][idx[j]]
    return tips[j].copy(), a / np.linalg.norm(a), int(idx[j]), k, n
