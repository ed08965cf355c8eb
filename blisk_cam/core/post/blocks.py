"""The one block stream every post writes: poses of the program solved for a machine.

:func:`build_blocks` turns a linked :class:`~..toolpath.ToolPath` program into
:class:`Blocks` once: inverse kinematics (:mod:`..kinematics`), linearization, feeds per move
type, and the N blades (paper 003 §V.A: one blade's program rotated to all blades). Blade k is
the blade-0 program turned by +k·360°/N right-handed about the paths' blisk axis. Where that
axis is the innermost table rotary's line and the post can call a subprogram with a parameter
(``indexed``), the blade-0 blocks are written once and called N times with the rotary offset;
otherwise the CL data are rotated and solved again per blade. A roughing program ordered by
level (``stats["order"]``) runs each level's block (``stats["level_blocks"]``, from and back
to the safe radius) in every gap before the next level, a safe retract before each; one that
already holds several gaps (``stats["gaps_in_program"]``) is posted once.

Arrays, one row per block (n blocks):

=========  ===========  ==============================================================
kind       (n,) int8    move code (:data:`..toolpath.MOVE_NAMES`) or ``SAFE`` (5): retract
                        to the safe machine Z (no pose)
tip        (n, 3) mm    tool tip, paths' frame
axis       (n, 3)       unit tool axis, paths' frame
xyz        (n, 3) mm    programmed X, Y, Z (machine tip position)
angles     (n, 2) rad   rotary 1, rotary 2
feed       (n,) mm/min  tip feed (0 for rapids and SAFE)
blade      (n,) int     blade index
source     (n,) int     index of the program pose, −1 for an inserted block or SAFE
singular   (n,) bool    singular orientation (rotary kept from the previous block)
=========  ===========  ==============================================================
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import PostError
from ..geometry.vectors import rotate_about
from ..machine.description import Machine
from ..machine.kinematics import LinearizeReport, linearize, solve_poses
from ..options import Choice, OptionGroup, check_group, option
from ..toolpath.types import MOVE_APPROACH, MOVE_CUT, MOVE_LINK, MOVE_RAPID, MOVE_RETRACT, ToolPath

__all__ = ["SAFE", "Blocks", "NcOptions", "build_blocks"]

SAFE = 5


@dataclass(frozen=True)
class NcOptions(OptionGroup):
    """What the NC program needs besides the path and the machine (options declared once,
    :mod:`..options`): feeds mm/min per move type (None: feed, feed/2, feed for link,
    approach, retract), spindle rpm and direction, tool number, coolant, the number of
    blades, the linearization chord (None: the path's chord tolerance) and the largest rotary
    step between feed blocks. Not user options: ``safe_z`` (mm machine Z of the safe retract;
    None: the Z travel maximum, else 100), ``rapid_rate`` (mm/min) and ``rotary_rate``
    (deg/min) for the time estimate and inverse-time blocks, ``program_number``,
    ``blade_name`` (header), ``tool_length`` (mm gauge length, head pivot limits),
    ``use_subprogram`` (index blades by a subprogram call where possible),
    ``allow_collisions`` (post despite unresolved collisions, :mod:`.gate`).
    """

    title = "NC program"
    error = PostError

    feed: float = option(1000.0, "Feed", "Cutting feed, mm/min", unit="mm/min", lo=0.0,
                         lo_open=True, soft_max=20000.0, precision=0)
    link_feed: float | None = option(
        None, "Link Feed", "Feed of the links between passes, mm/min (0 or not given: the "
        "cutting feed)", unit="mm/min", lo=0.0, none_as=0.0, precision=0)
    approach_feed: float | None = option(
        None, "Approach Feed", "Feed of the approach moves, mm/min (0 or not given: half the "
        "cutting feed)", unit="mm/min", lo=0.0, none_as=0.0, precision=0)
    retract_feed: float | None = option(
        None, "Retract Feed", "Feed of the retract moves, mm/min (0 or not given: the cutting "
        "feed)", unit="mm/min", lo=0.0, none_as=0.0, precision=0)
    spindle: float = option(10000.0, "Spindle", "Spindle speed, rpm", unit="rpm", lo=0.0,
                            lo_open=True, soft_max=40000.0, precision=0)
    spindle_cw: bool = option(
        True, "Spindle Direction", "Spindle direction: cw (M03, the climb milling the paths "
        "assume) or ccw (M04)", flag="--spindle-direction",
        choices=(Choice(True, "CW (M03)", cli="cw"), Choice(False, "CCW (M04)", cli="ccw")))
    tool_number: int = option(1, "Tool Number", "Tool number T in the magazine", lo=0)
    coolant: bool = option(True, "Coolant", "Coolant (M08) on or off",
                           choices=(Choice(True, "On", cli="on"), Choice(False, "Off", cli="off")))
    # the blade count is entered once (issue 28): the front ends fill it from their one blade
    # count (CLI --blade-count, the panel's Blade Count), so no flag or property of its own
    blades: int = option(1, "Blades", "Repeat the blade's moves for N blades, blade k turned "
                         "by k·360°/N about the blisk axis", lo=1, flag=None, blender=False)
    chord: float | None = None
    max_rotary_step: float = option(
        math.radians(5.0), "Max Rotary Step", "Largest rotary-axis turn between consecutive "
        "feed blocks, degrees (blocks are inserted)", unit="deg", lo=0.0, lo_open=True,
        hi=math.radians(90.0))
    safe_z: float | None = None
    rapid_rate: float = 10000.0
    rotary_rate: float = 7200.0
    program_number: int = 1000
    blade_name: str = "blade"
    tool_length: float = 0.0
    use_subprogram: bool = True
    interpolation: str | None = option(
        None, "Interpolation", "How the cut blocks are chosen: planned (the planned poses, "
        "linearized), constant-error (paper 002: every block's machining error bound ≤ the "
        "max error) or chord (tip chord height ≤ the chord height)",
        choices=(Choice(None, "Planned", "The planned poses, linearized", ident="PLANNED",
                        cli="planned"),
                 Choice("constant-error", "Constant Error", "Paper 002: blocks keep the "
                        "machining error near the bound", ident="CONSTANT_ERROR"),
                 Choice("chord", "Chord Height", "Blocks by the tip path's chord height",
                        ident="CHORD")))
    max_error: float | None = option(
        None, "Max Error", "Permissible machining error [dM] of constant-error blocks, mm",
        unit="mm", lo=0.0, lo_open=True, none_as=0.0, precision=4)
    chord_height: float | None = option(
        None, "Chord Height", "Chord height of chord-height blocks, mm", unit="mm", lo=0.0,
        lo_open=True, none_as=0.0, precision=4)
    notes: tuple = ()  # extra header lines (the interpolation's result)
    #: post a path with unresolved collisions (``--allow-collisions``, Export Anyway); the
    #: header then marks them (:mod:`.gate`)
    allow_collisions: bool = False

    def check(self):
        """Bounds of every option (raised on construction too)."""
        check_group(self)
        if self.interpolation == "constant-error" and self.max_error is None:
            raise PostError("interpolation constant-error needs the max error "
                            "(--max-error MM)")
        if self.interpolation == "chord" and self.chord_height is None:
            raise PostError("interpolation chord needs the chord height (--chord-height MM)")
        if self.interpolation is None and (self.max_error or self.chord_height):
            raise PostError("--max-error / --chord-height choose blocks only with "
                            "--interpolation constant-error / chord")
        for name in ("rapid_rate", "rotary_rate"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise PostError(f"NC option {name} must be a positive number, got {v!r}")
        if self.chord is not None and not (math.isfinite(self.chord) and self.chord > 0):
            raise PostError(f"NC option chord must be a positive number, got {self.chord!r}")
        if int(self.blades) != self.blades:
            raise PostError(f"blades must be a whole number ≥ 1, got {self.blades!r}")
        if int(self.tool_number) != self.tool_number:
            raise PostError(f"tool number must be a whole number ≥ 0, got {self.tool_number}")

    def __post_init__(self):
        self.check()

    def feeds(self) -> np.ndarray:
        """(5,) feed per move code (rapid 0)."""
        f = float(self.feed)
        out = np.zeros(6)
        out[MOVE_CUT] = f
        out[MOVE_LINK] = self.link_feed or f
        out[MOVE_APPROACH] = self.approach_feed or 0.5 * f
        out[MOVE_RETRACT] = self.retract_feed or f
        return out


@dataclass
class Blocks:
    """The block stream (module docstring). ``offsets`` (N,) radians: with ``indexed`` the
    rotary-2 offset of blade k's call (blocks hold blade 0 only), else zeros."""

    kind: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    xyz: np.ndarray
    angles: np.ndarray
    feed: np.ndarray
    blade: np.ndarray
    source: np.ndarray
    singular: np.ndarray
    blades: int = 1
    indexed: bool = False  # blade 0 only, the post repeats it (see ``offsets``, ``pitch``)
    offsets: np.ndarray = field(default_factory=lambda: np.zeros(1))
    blisk_axis: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))
    safe_z: float = 100.0
    inserted: int = 0
    max_deviation: float = 0.0
    unresolved: int = 0

    def __len__(self) -> int:
        return len(self.kind)

    @property
    def z_turns(self) -> np.ndarray:
        """(N,) radians: blade k's rotation about the paths' +z (indexed streams whose blisk
        axis is ±z)."""
        sign = 1.0 if self.blisk_axis[1][2] >= 0 else -1.0
        return sign * 2 * math.pi * np.arange(self.blades) / self.blades

    def expanded(self) -> Blocks:
        """The stream as the machine runs it: an indexed stream repeated per blade (tip/axis
        rotated, rotary 2 offset); an unrolled stream as is."""
        if not self.indexed or self.blades == 1:
            return self
        parts = []
        o, d = (np.asarray(x) for x in self.blisk_axis)
        for k in range(self.blades):
            turn = 2 * math.pi * k / self.blades
            q = self.angles.copy()
            q[:, 1] += self.offsets[k]
            parts.append(
                dict(kind=self.kind, tip=rotate_about(self.tip, d, turn, o),
                     axis=rotate_about(self.axis, d, turn),
                     xyz=self.xyz, angles=q, feed=self.feed, blade=np.full(len(self), k),
                     source=self.source, singular=self.singular)
            )
        cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        return Blocks(**cat, blades=self.blades, blisk_axis=self.blisk_axis,
                      safe_z=self.safe_z, offsets=np.zeros(self.blades))

    @property
    def poses(self) -> np.ndarray:
        """(n,) bool — blocks that are tool poses (not SAFE retracts)."""
        return self.kind != SAFE


def _indexable(machine: Machine, o, d) -> float:
    """σ = ±1 when the blisk axis (paths' frame o, d) is the innermost table rotary's line
    (same or opposite direction), else 0."""
    if not machine.tables[1]:
        return 0.0
    r2 = machine.rotaries[1]
    om = machine.part_to_machine0(o[None])[0]
    dm = machine.part_rotation @ d
    if np.linalg.norm(np.cross(dm, r2.axis)) > 1e-9:
        return 0.0
    v = om - r2.point
    if np.linalg.norm(v - (v @ r2.axis) * r2.axis) > 1e-6:
        return 0.0
    return float(np.sign(dm @ r2.axis))


def _solve_blade(path_tip, path_axis, move, machine, opts, chord, prev, labels):
    ik = solve_poses(machine, path_tip, path_axis, prev=prev, labels=labels, moves=move,
                     tool_length=opts.tool_length)
    keep = (np.asarray(move) == MOVE_CUT) if opts.interpolation else None
    return linearize(machine, path_tip, path_axis, move, ik, chord=chord,
                     max_step=opts.max_rotary_step, tool_length=opts.tool_length, keep=keep)


def build_blocks(path: ToolPath, machine: Machine, options: NcOptions, *,
                 indexable: bool | str = True, solve: bool = True) -> Blocks:
    """Solve the path's program for the machine (module docstring). ``indexable``: the post
    can write a subprogram called per blade with the rotary offset as parameter; ``"z"``: it
    can, when the blisk axis is also the paths' z axis (a TCP post rotating its coordinates
    about Z). ``solve``
    False: CL data only (no kinematics; xyz = tip, angles 0) for machine-independent posts.

    Raises ReachError (pose, axis, value) for an unreachable pose, BliskCamError when the
    path has no linked program."""
    options.check()
    prog = path.program
    if prog is None or len(prog) == 0:
        raise PostError("the paths have no linked program (link the passes before posting)")
    chord = float(options.chord or path.chord)
    feeds = options.feeds()
    n_bl = int(options.blades)
    stats = path.stats or {}
    held = int(stats.get("gaps_in_program", 1) or 1)
    if held > 1:  # a roughing program that holds several gaps itself: not repeated
        if n_bl not in (1, held):
            raise PostError(f"the program already holds {held} gaps of the blisk (a roughing "
                            f"program of several gaps); it cannot be repeated for {n_bl} "
                            f"blades: give the blade count {held} or 1")
        n_bl = 1
    # roughing ordered by level: each level's block (from and back to the safe radius) in
    # every gap before the next level
    by_level = ([(int(a), int(b)) for a, b in stats.get("level_blocks") or []]
                if n_bl > 1 and stats.get("order") == "level" else [])
    if n_bl > 1 and stats.get("order") == "level" and not by_level:
        raise PostError("the roughing program is ordered by level but records no level "
                        "blocks (an older paths file): plan the roughing again")
    o, d = path.axis.o, path.axis.d
    sigma = _indexable(machine, o, d) if (indexable and solve and options.use_subprogram) else 0.0
    if indexable == "z" and (np.linalg.norm(np.cross(d, [0.0, 0, 1])) > 1e-9
                             or np.hypot(o[0], o[1]) > 1e-6):
        sigma = 0.0
    if by_level:  # the gaps interleave level by level: every block solved where it runs
        sigma = 0.0
    lim_z = machine.linear.get("Z")
    safe_z = options.safe_z if options.safe_z is not None else (lim_z[1] if lim_z else 100.0)
    labels = np.arange(len(prog))
    offsets = np.zeros(n_bl)
    if n_bl > 1 and sigma != 0.0:
        offsets = -sigma * 2 * math.pi * np.arange(n_bl) / n_bl
        lim = machine.rotaries[1].limits
        if lim is not None:
            res = _solve_blade(prog.tip, prog.axis, prog.move, machine, options, chord, None,
                               labels)
            q2 = res[4][:, 1]
            ok = all(lim[0] <= q2.min() + off and q2.max() + off <= lim[1] for off in offsets)
            if not ok:
                sigma = 0.0
                offsets = np.zeros(n_bl)
    indexed = n_bl > 1 and sigma != 0.0
    parts = []
    prev = None
    reps = []
    segments = ([(k, a, b) for a, b in by_level for k in range(n_bl)] if by_level
                else [(k, 0, len(prog)) for k in range(1 if indexed else n_bl)])
    for k, lo, hi in segments:
        if by_level and k == 0 and machine.rotaries[1].limits is not None:
            prev = None  # a limited rotary: each level starts afresh, not wound on by N gaps
        tip, ax, move = prog.tip[lo:hi], prog.axis[lo:hi], prog.move[lo:hi]
        if k:
            turn = 2 * math.pi * k / n_bl
            tip, ax = rotate_about(tip, d, turn, o), rotate_about(ax, d, turn)
        if solve:
            t, a, m, x, q, s, src, rep = _solve_blade(
                tip, ax, move, machine, options, chord, prev, labels[lo:hi]
            )
        else:
            t, a, m, x, q = tip, ax, np.asarray(move), tip, np.zeros((len(tip), 2))
            s, src, rep = np.zeros(len(tip), bool), labels[lo:hi], LinearizeReport(0, 0.0, 0)
        reps.append(rep)
        prev = q[-1]
        # safe retract before every blade; the posts turn the rotaries to the next pose's at
        # the safe height (the index), then the first rapid follows
        parts.append(dict(kind=np.array([SAFE], np.int8), tip=np.full((1, 3), np.nan),
                          axis=np.full((1, 3), np.nan), xyz=np.full((1, 3), np.nan),
                          angles=np.full((1, 2), np.nan), feed=np.zeros(1),
                          blade=np.array([k]), source=np.array([-1]),
                          singular=np.zeros(1, bool)))
        parts.append(dict(kind=m.astype(np.int8), tip=t, axis=a, xyz=x, angles=q,
                          feed=np.where(m == MOVE_RAPID, 0.0, feeds[m]),
                          blade=np.full(len(t), k), source=src, singular=s))
    cat = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
    return Blocks(
        **cat, blades=n_bl, indexed=indexed, offsets=offsets,
        blisk_axis=(tuple(o), tuple(d)), safe_z=float(safe_z),
        inserted=sum(r.inserted for r in reps),
        max_deviation=max(r.max_deviation for r in reps),
        unresolved=sum(r.unresolved for r in reps),
    )
