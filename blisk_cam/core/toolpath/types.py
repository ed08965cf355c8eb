"""Tool-path result types: passes of cutter-contact (CC) points with their tool poses, and the
linked program (every move in machining order, links included).

A pose (ARCHITECTURE.md, conventions) is: CC point, unit surface normal (out of the
material, toward the tool), tool tip point (CL) and unit tool axis (tip → spindle). The tip
follows from the cutter touching the CC point (:meth:`..tool.cutter.Cutter.cl_points`); for a ball
of radius ρ the ball centre is ``tip + ρ a``. The path generator, which spaces the passes for a
ball, puts the centre at ``cc + (ρ + λ) n``, λ ≥ 0 being the few-µm lift that clears the facets
around the CC point, so ``tip = cc + λ n`` there.

Move types (``MOVE_*``; ``PassCurve.move`` and ``Program.move`` hold these int8 codes, the
paths JSON their names). The code of pose j is the kind of the motion that *ends* at pose j:

=====  ==========  =====  ==================================================================
code   name        feed?  meaning
=====  ==========  =====  ==================================================================
0      cut         feed   cutting along a pass (the tool touches the surface at the CC point)
1      link        feed   a step between passes with the tool kept on the surface
2      approach    feed   down the tool axis onto the first pose of a pass
3      retract     feed   up the tool axis off the last pose of a pass
4      rapid       rapid  positioning through the air (at or to the clearance surface)
=====  ==========  =====  ==================================================================

Pose flags (``FLAG_*``, a uint8 bit mask per pose): ``FLAG_LOCAL_GOUGE`` the cutter's
curvature exceeds the surface's at the contact and lead/tilt could not fix it within the
limits (:mod:`..paths.gouge`); ``FLAG_ZERO_SPEED`` the contact lies on the rotation axis
(zero cutting speed, paper 003 §I); ``FLAG_GOUGE_FIXED`` lead/tilt were raised to clear a local
gouge; ``FLAG_AXIS_SMOOTHED`` axis smoothing moved the axis away from the requested lead/tilt.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry.axis import Axis
from ..part.cones import Cone
from ..part.profiles import Profile
from ..tool.cutter import Cutter

__all__ = [
    "BallTool",
    "FLAG_AXIS_SMOOTHED",
    "FLAG_GOUGE_FIXED",
    "FLAG_LOCAL_GOUGE",
    "FLAG_NAMES",
    "FLAG_ZERO_SPEED",
    "MOVE_APPROACH",
    "MOVE_CUT",
    "MOVE_LINK",
    "MOVE_NAMES",
    "MOVE_RAPID",
    "MOVE_RETRACT",
    "PassCurve",
    "Program",
    "ToolPath",
    "move_codes",
    "STATUS_CLEAR",
    "STATUS_CORRECTED",
    "STATUS_UNRESOLVED",
]

MOVE_CUT, MOVE_LINK, MOVE_APPROACH, MOVE_RETRACT, MOVE_RAPID = 0, 1, 2, 3, 4
#: code → name (the paths JSON writes the names)
MOVE_NAMES = ("cut", "link", "approach", "retract", "rapid")

FLAG_LOCAL_GOUGE = 1
FLAG_ZERO_SPEED = 2
FLAG_GOUGE_FIXED = 4
FLAG_AXIS_SMOOTHED = 8

#: collision status of a pose (the collision check writes it per pose): clear, corrected by
#: avoidance, unresolved
STATUS_CLEAR, STATUS_CORRECTED, STATUS_UNRESOLVED = 0, 1, 2

#: flag bit → name
FLAG_NAMES = {
    FLAG_LOCAL_GOUGE: "local_gouge",
    FLAG_ZERO_SPEED: "zero_speed",
    FLAG_GOUGE_FIXED: "gouge_fixed",
    FLAG_AXIS_SMOOTHED: "axis_smoothed",
}


def move_codes(names) -> np.ndarray:
    """(k,) int8 codes of move names (or codes) — ValueError naming an unknown one."""
    out = []
    for x in names:
        if isinstance(x, str):
            if x not in MOVE_NAMES:
                raise ValueError(f"unknown move type {x!r}; known: {', '.join(MOVE_NAMES)}")
            out.append(MOVE_NAMES.index(x))
        else:
            if not 0 <= int(x) < len(MOVE_NAMES):
                raise ValueError(f"unknown move code {x!r}; known 0..{len(MOVE_NAMES) - 1}")
            out.append(int(x))
    return np.asarray(out, dtype=np.int8)


def BallTool(radius: float, type: str = "ball") -> Cutter:  # noqa: N802 - kept for old callers
    """A ball-end cutter of ``radius`` mm: the former ``BallTool`` class, now a
    :class:`~..tool.cutter.Cutter` (``Cutter.ball(radius)``)."""
    return Cutter.from_spec(type, radius)


@dataclass
class PassCurve:
    """One cutting pass: CC points in machining order with their poses.

    Attributes
    ----------
    s : float — morph ratio of the LMC it lies on (0 = cone 1, 1 = cone 2); for a spiral, the
        ratio of its first pose (``ratio`` gives every pose's)
    closed : bool — a closed loop (the last point connects to the first; not repeated)
    cc : (k, 3) float, mm — cutter-contact points, on the mesh and on the LMC
    normal : (k, 3) float — unit smooth surface normals at the CC points
    tip : (k, 3) float, mm — tool tip (CL) points
    axis : (k, 3) float — unit tool axes (tip → spindle)
    face : (k,) int — mesh face of each CC point (empty or −1 where unknown)
    move : (k,) int8 — move code of each pose (module table); default all ``MOVE_CUT``
    flags : (k,) uint8 — pose flags (module table); default 0
    ratio : (k,) float or None — per-pose morph ratio where it varies along the pass (a
        spiral); None means every pose lies on the LMC at ``s``
    collision : dict or None — collision figures per pose (:mod:`..collision.avoid`): ``status``
        (k,) int8 (0 clear, 1 corrected, 2 unresolved), ``clearance`` (k,) float mm,
        ``rotation`` (k,) float rad (angle of the axis from the planned one); None when the
        path was not checked
    """

    s: float
    closed: bool
    cc: np.ndarray
    normal: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    face: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    move: np.ndarray | None = None
    flags: np.ndarray | None = None
    ratio: np.ndarray | None = None
    collision: dict | None = None

    def __post_init__(self):
        k = len(self.cc)
        if self.move is None:
            self.move = np.full(k, MOVE_CUT, dtype=np.int8)
        else:
            self.move = np.asarray(self.move, dtype=np.int8)
        if self.flags is None:
            self.flags = np.zeros(k, dtype=np.uint8)
        else:
            self.flags = np.asarray(self.flags, dtype=np.uint8)
        if self.ratio is not None:
            self.ratio = np.asarray(self.ratio, dtype=np.float64)

    def __len__(self) -> int:
        return len(self.cc)

    @property
    def ratios(self) -> np.ndarray:
        """(k,) morph ratio of every pose."""
        return self.ratio if self.ratio is not None else np.full(len(self.cc), float(self.s))

    @property
    def is_cut(self) -> np.ndarray:
        """(k,) bool — poses reached by a cutting move."""
        return self.move == MOVE_CUT

    def centres(self, radius: float) -> np.ndarray:
        """(k, 3) ball centres of the tool as posed, ``tip + radius · axis`` (mm)."""
        return self.tip + radius * self.axis


@dataclass
class Program:
    """The linked program: every pose in machining order, cutting and linking.

    Walk it in order: pose j is reached from pose j−1 by a motion of kind ``move[j]`` (the
    first pose by a rapid from wherever the machine is). Rapid moves are ``move == MOVE_RAPID``;
    everything else is at feed.

    Attributes
    ----------
    tip : (m, 3) float, mm — tool tip (CL) points
    axis : (m, 3) float — unit tool axes
    move : (m,) int8 — move codes (see the module table)
    curve : (m,) int64 — index into ``ToolPath.curves`` of a pass pose, −1 for a link pose
    index : (m,) int64 — pose index within that pass (−1 for a link pose); a closed pass ends
        with its first pose again (the closing cut)
    flags : (m,) uint8 — pose flags (pass poses carry their pass's flags)
    collision_status : (m,) int8 or None — 0 clear, 1 corrected, 2 unresolved collision
        (:mod:`..collision.avoid`); None when the path was not checked
    clearance : (m,) float or None, mm — signed clearance of the tool assembly per pose
    rotation_deg : (m,) float or None, degrees — angle of each pose's axis from its planned
        axis (:mod:`..collision.avoid`, :mod:`..collision.reroute`; degrees, as the paths JSON
        writes them, so a file reads back exactly); None when not checked
    """

    tip: np.ndarray
    axis: np.ndarray
    move: np.ndarray
    curve: np.ndarray
    index: np.ndarray
    flags: np.ndarray
    collision_status: np.ndarray | None = None
    clearance: np.ndarray | None = None
    rotation_deg: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.tip)

    @property
    def is_rapid(self) -> np.ndarray:
        return self.move == MOVE_RAPID

    def runs(self):
        """[(move code, start, stop)] maximal runs of poses with one move type (stop exclusive)."""
        m = np.asarray(self.move)
        if len(m) == 0:
            return []
        b = np.nonzero(np.diff(m) != 0)[0] + 1
        starts = np.concatenate([[0], b])
        stops = np.concatenate([b, [len(m)]])
        return [(int(m[a]), int(a), int(z)) for a, z in zip(starts, stops, strict=True)]

    def length(self, moves=None) -> float:
        """Travelled length (mm) of the motions whose code is in ``moves`` (default all)."""
        if len(self.tip) < 2:
            return 0.0
        seg = np.linalg.norm(np.diff(self.tip, axis=0), axis=1)
        m = self.move[1:]
        keep = np.ones(len(seg), bool) if moves is None else np.isin(m, list(moves))
        return float(seg[keep].sum())


@dataclass
class ToolPath:
    """A finishing path between two cones: passes in machining order, and the linked program.

    ``tool`` is a :class:`~..tool.cutter.Cutter` (``BallTool(ρ)`` builds a ball). ``program`` is
    None until the passes are linked (:mod:`..paths.linking`). ``warnings`` are messages for the
    user
    about the path as a whole that the planning adds (e.g. zero cutting speed,
    :mod:`..process.blade_finish`); the generator's own warnings stay in ``stats["warnings"]``.
    until the passes are linked (:mod:`..paths.linking`). ``collision`` is the collision summary
    (:meth:`..collision.report.CollisionReport.summary`, JSON-ready) once the path was checked, else
    None.
    """

    axis: Axis
    cone1: Cone | Profile  # a Profile when the hub/tip is a curved generatrix (LMRS)
    cone2: Cone | Profile
    tool: Cutter
    cusp: float
    chord: float
    curves: list[PassCurve]
    stats: dict = field(default_factory=dict)
    program: Program | None = None
    warnings: list[str] = field(default_factory=list)
    collision: dict | None = None
    verify: dict | None = None  # the verdict of an independent check (.verdict.verdict_dict)
    #: mm of stock left on the surface (semi-finishing): the CC points lie on the surface
    #: offset outward by it and the cutter touches that offset surface; 0 = finished to size
    allowance: float = 0.0
    #: the operation that made the path ("rough", "hub-finish", "fillet-finish"; None: blade
    #: finishing, written as before)
    operation: str | None = None

    @property
    def n_poses(self) -> int:
        return int(sum(len(c) for c in self.curves))

    @property
    def levels(self) -> np.ndarray:
        """(p,) distinct s of the passes in order."""
        return np.unique([c.s for c in self.curves])

    def length(self) -> float:
        """Total cutting length of the tip polylines, mm (closed curves include the closing
        move)."""
        total = 0.0
        for c in self.curves:
            p = np.vstack([c.tip, c.tip[:1]]) if c.closed else c.tip
            total += float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())
        return total
