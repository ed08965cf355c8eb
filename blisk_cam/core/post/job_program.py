"""One NC program for a job: operations in order, each a (tool, path) section (paper 003 §5:
the blisk made in operations, posted as one program).

Each section is solved for the machine exactly as a single program is (the collision gate,
the optional interpolation, :func:`.blocks.build_blocks`: inverse kinematics, linearization,
every blade); the post then writes the sections one after another with a tool change where
the tool differs from the one in the spindle, the section's spindle speed, feed and coolant,
and the safe retract between operations. A post writes job programs when it has
``write_job(sections, header)``; :data:`JOB_POSTS` lists them.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import BliskCamError, PostError
from ..machine.description import Machine, load_machine
from ..toolpath.types import ToolPath
from .blocks import Blocks, NcOptions, build_blocks
from .common import PostContext, ascii_text, block_minutes, frame_lines, tool_text, version
from .export import check_finite, get_post, interpolate_for_nc
from .gate import collision_gate

__all__ = ["JOB_POSTS", "JobSection", "SolvedSection", "check_job_post", "job_program"]

#: the posts that write a job program (several tools in one program)
JOB_POSTS = ("linuxcnc", "fanuc", "siemens", "heidenhain", "apt")


@dataclass(frozen=True)
class JobSection:
    """One operation of the program: ``title`` (a comment line), ``path`` (a linked
    ToolPath), ``options`` (its NcOptions: tool number, spindle rpm, feed mm/min, coolant,
    blades …)."""

    title: str
    path: ToolPath
    options: NcOptions


@dataclass
class SolvedSection:
    """A section as posted: its ``blocks`` (one blade or indexed, :meth:`Blocks.expanded`
    gives every blade), the ``options`` with the gate's notes, and ``minutes`` (time
    estimate of the section's blocks)."""

    title: str
    path: ToolPath
    options: NcOptions
    blocks: Blocks
    minutes: float


def check_job_post(post: str) -> None:
    """PostError unless ``post`` writes job programs (names the ones that do)."""
    get_post(post)  # unknown post: its own message
    if str(post).strip().lower() not in JOB_POSTS:
        raise PostError(f"post {post!r} cannot write a program of several operations with tool "
                        f"changes yet; job programs: {', '.join(JOB_POSTS)}")


def job_program(sections, machine: Machine | str, post: str, *,
                header: list[str] = ()) -> tuple[str, list[SolvedSection]]:
    """(program text, [SolvedSection]) of ``sections`` (JobSection, in order) for
    ``machine`` with ``post``; ``header`` lines head the program (comments). Raises
    PostError (post without job programs, a section not linked, unresolved collisions not
    allowed), ReachError (an unreachable pose, naming it)."""
    check_job_post(post)
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    mod = get_post(post)
    mod.check(machine)
    if not sections:
        raise PostError("the job has no operation to post")
    solved, contexts = [], []
    for k, sec in enumerate(sections):
        try:
            check_finite(sec.path)
            options = sec.options
            gate = collision_gate(sec.path, options.allow_collisions)
            if gate.notes:
                options = replace(options, notes=(*gate.notes, *options.notes))
            path, options, _ = interpolate_for_nc(sec.path, machine, options)
            blocks = build_blocks(path, machine, options, indexable=mod.INDEXABLE,
                                  solve=getattr(mod, "SOLVE", True))
        except BliskCamError as exc:
            msg = f"operation {k + 1} ({sec.title}): {exc}"
            try:
                err = type(exc)(msg)
            except TypeError:
                err = PostError(msg)
            raise err from exc
        ctx = PostContext(path=path, machine=machine, options=options, blocks=blocks,
                          post=mod.NAME)
        minutes = float(block_minutes(blocks.expanded(), options).sum())
        solved.append(SolvedSection(sec.title, path, options, blocks, minutes))
        contexts.append((sec.title, ctx))
    head = [f"Blisk CAM {version()} - job of {len(sections)} operation(s)",
            f"machine: {machine.name} ({machine.kinematics}, {'/'.join(machine.axis_names)})",
            f"post: {mod.NAME}  units: mm, degrees",
            *(f"T{s.options.tool_number}: {tool_text(s.path.tool)} - {s.title}"
              for s in solved),
            *frame_lines(contexts[0][1], tcp=mod.TCP),  # the frame the program is in
            *header]
    text = mod.write_job(contexts, [ascii_text(h) for h in head])
    return ascii_text(text), solved
