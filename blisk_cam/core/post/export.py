"""Export a tool path as an NC program: machine + post + options → file and report.

``export_nc(path, machine, post, options, filename) -> NcReport`` is what the Blender operator
and the ``nc`` CLI call: it solves the program for the machine once (:mod:`.post.blocks`:
inverse kinematics, linearization, blades), lets the post write the text and writes it
atomically.
"""

from __future__ import annotations

import importlib
import os
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import PostError
from ..machine.description import Machine, load_machine
from ..machine.interpolation import interpolate_program
from ..toolpath.types import ToolPath
from .blocks import Blocks, NcOptions, build_blocks
from .common import POSTS, PostContext, ascii_text, block_minutes, write_atomic
from .gate import GateResult, collision_gate

__all__ = ["POSTS", "NcReport", "export_nc", "get_post", "nc_program"]


def get_post(name: str):
    """The post module called ``name`` (PostError listing the known posts)."""
    key = str(name).strip().lower()
    if key not in POSTS:
        raise PostError(f"unknown post {name!r}; known: {', '.join(POSTS)}")
    return importlib.import_module(f"{__package__}.{key}")


@dataclass
class NcReport:
    """What was written.

    filename : str; post : str; machine : str; blocks : int — pose blocks written (a
    subprogram's blocks count once per call); inserted : int — blocks added by
    linearization; gate : the :class:`.gate.GateResult` (header notes, console warning,
    unresolved collision poses posted); axis_ranges : {name: (min, max)} — mm for X Y Z,
    degrees for rotaries
    (joint posts; the paths' X Y Z for TCP posts); singular : list[int] — program poses with a
    singular orientation; minutes : float — time estimate; max_deviation : mm — sampled tip
    deviation of joint-linear motion after linearization; blades : int; indexed : bool;
    unresolved : int — segments still beyond the chord after the insertion round limit (0
    normally; the summary warns otherwise); interpolation : the
    :class:`..machine.interpolation.InterpolationReport` when the cut blocks were interpolated.
    """

    filename: str
    post: str
    machine: str
    blocks: int
    inserted: int
    axis_ranges: dict
    singular: list = field(default_factory=list)
    minutes: float = 0.0
    max_deviation: float = 0.0
    blades: int = 1
    indexed: bool = False
    unresolved: int = 0
    interpolation: object = None
    gate: GateResult = field(default_factory=GateResult)

    def summary(self) -> str:
        rng = ", ".join(f"{k} {lo:.3f}…{hi:.3f}" for k, (lo, hi) in self.axis_ranges.items())
        return (
            f"{self.filename}: {self.post} for {self.machine}, {self.blocks} blocks "
            f"({self.inserted} inserted), {self.blades} blade(s), ≈ {self.minutes:.1f} min; "
            f"{rng}; singular poses: {len(self.singular)}"
            + (f"; WARNING: {self.unresolved} segments beyond the chord tolerance"
               if self.unresolved else "")
            + (f"\n{self.interpolation.summary()}" if self.interpolation is not None else "")
            + (f"\n{self.interpolation.budget_line()}"
               if self.interpolation is not None and self.interpolation.budget_line() else "")
        )


def interpolate_for_nc(path: ToolPath, machine: Machine, options: NcOptions, part=None):
    """``options.interpolation`` set: the path with its cut blocks chosen by
    :func:`..machine.interpolation.interpolate_program` (rotary steps ≤
    ``options.max_rotary_step``),
    the options with the header note, and the InterpolationReport; else (path, options, None).
    Constant-error keeps ``--max-error`` against the part (issue 28): the planned path's own
    deviation from ``part`` (the part's mesh, TriMesh or MeshDistance) is budgeted in every
    block; without the mesh its chord tolerance is budgeted whole."""
    if not options.interpolation:
        return path, options, None

    new, rep = interpolate_program(path, machine, options.interpolation,
                                   max_error=options.max_error,
                                   chord_height=options.chord_height,
                                   max_rotary_step=options.max_rotary_step,
                                   mesh=part,
                                   part=("chord" if part is None else True))
    notes = (rep.summary(), rep.budget_line()) if rep.budget_line() else (rep.summary(),)
    return new, replace(options, notes=(*options.notes, *notes)), rep


def check_finite(path: ToolPath) -> None:
    """PostError naming the first program row (or pass pose) whose tip or axis is not finite:
    no post writes nan or inf."""
    prog = path.program
    arrays = ([("program row", prog.tip, prog.axis)] if prog is not None else
              [(f"pass {i} pose", c.tip, c.axis) for i, c in enumerate(path.curves)])
    for what, tip, axis in arrays:
        bad = ~(np.isfinite(tip).all(axis=1) & np.isfinite(axis).all(axis=1))
        if bad.any():
            r = int(np.flatnonzero(bad)[0])
            raise PostError(f"{what} {r} has a tip or axis that is not finite "
                            f"(tip {np.asarray(tip[r]).tolist()}, axis "
                            f"{np.asarray(axis[r]).tolist()}): nothing was written")


def nc_program(path: ToolPath, machine: Machine | str, post: str,
               options: NcOptions | None = None, *, reports: list | None = None,
               gates: list | None = None, part=None) -> tuple[str, Blocks]:
    """The NC text and the block stream (no file). The collision gate first
    (:func:`.gate.collision_gate`: CollisionGateError for unresolved collisions unless
    ``options.allow_collisions``; its notes head the program, its result is appended to
    ``gates`` when given). With ``options.interpolation`` the cut blocks are chosen first
    (:func:`interpolate_for_nc`, against the mesh ``part`` when given); its report is appended
    to ``reports`` when given."""
    options = options or NcOptions()
    check_finite(path)
    gate = collision_gate(path, options.allow_collisions)
    if gate.notes:
        options = replace(options, notes=(*gate.notes, *options.notes))
    if gates is not None:
        gates.append(gate)
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    mod = get_post(post)
    mod.check(machine)
    path, options, irep = interpolate_for_nc(path, machine, options, part)
    if reports is not None and irep is not None:
        reports.append(irep)
    blocks = build_blocks(path, machine, options, indexable=mod.INDEXABLE,
                          solve=getattr(mod, "SOLVE", True))
    ctx = PostContext(path=path, machine=machine, options=options, blocks=blocks, post=mod.NAME)
    text = mod.write(ctx)
    if not text.isascii():  # names from the user (machine, blade) can carry any character
        text = ascii_text(text)
    return text, blocks


def export_nc(path: ToolPath, machine: Machine | str, post: str, options: NcOptions | None,
              filename, *, part=None) -> NcReport:
    """Write the NC program of ``path`` for ``machine`` with ``post`` to ``filename``
    (``part``: the part's mesh, for constant-error interpolation, :func:`interpolate_for_nc`).

    Raises MachineError, ReachError (pose/axis/value), PostError (unknown post, unsupported
    machine, missing output directory, unresolved collisions not allowed:
    :class:`.gate.CollisionGateError`), all :class:`.errors.BliskCamError`."""

    options = options or NcOptions()
    folder = os.path.dirname(os.path.abspath(os.fspath(filename)))
    if not os.path.isdir(folder):  # fail before the (longer) solve
        raise PostError(f"cannot write {filename}: the directory {folder} does not exist")
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    ireps: list = []
    gates: list = []
    text, blocks = nc_program(path, machine, post, options, reports=ireps, gates=gates,
                              part=part)
    write_atomic(filename, text)
    mod = get_post(post)
    full = blocks.expanded()
    pose = full.poses
    ranges = {}
    src = full.tip if (mod.TCP or not getattr(mod, "SOLVE", True)) else full.xyz
    for j, name in enumerate("XYZ"):
        ranges[name] = (float(src[pose, j].min()), float(src[pose, j].max()))
    if getattr(mod, "SOLVE", True):
        deg = np.degrees(full.angles[pose])
        for j, name in enumerate(machine.axis_names):
            ranges[name] = (float(deg[:, j].min()), float(deg[:, j].max()))
    sing = sorted({int(s) for s in blocks.source[blocks.singular & (blocks.source >= 0)]})
    return NcReport(
        filename=os.fspath(filename),
        post=mod.NAME,
        machine=machine.name,
        blocks=int(pose.sum()),
        inserted=int(blocks.inserted) * (blocks.blades if blocks.indexed else 1),
        axis_ranges=ranges,
        singular=sing,
        minutes=float(block_minutes(full, options).sum()),
        max_deviation=float(blocks.max_deviation),
        blades=int(blocks.blades),
        indexed=bool(blocks.indexed),
        unresolved=int(blocks.unresolved),
        interpolation=ireps[0] if ireps else None,
        gate=gates[0],
    )


