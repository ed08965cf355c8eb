"""What every post shares: the context, number formatting, header text (ASCII: controllers
read no other), safe file writing (atomic, with the user's umask)."""

from __future__ import annotations

import math
import os
import unicodedata
from dataclasses import dataclass

import numpy as np

from .. import files
from ..errors import PostError
from ..machine.description import Machine
from ..toolpath.types import MOVE_RAPID, ToolPath
from ..version import __version__
from .blocks import SAFE, Blocks, NcOptions

__all__ = ["POSTS", "PostContext", "ascii_text", "fmt", "frame_lines", "fvec", "header_lines",
           "tool_text", "version", "write_atomic", "write_program_folder"]

#: the posts, by the name the user gives (``--post``, the panel); :mod:`.export` runs them.
#: Named here, below the machines' solver, so that a command line that only declares its
#: ``--post`` flag does not import the export and interpolation modules
POSTS = ("linuxcnc", "fanuc", "siemens", "heidenhain", "apt")

#: a file holding this text (in its first 4 kB) was written by Blisk CAM and may be replaced
OWN_MARK = "Blisk CAM"

#: what the program text writes for the characters the project's messages use (controllers
#: read ASCII only: a Fanuc comment with Ø is rejected or garbled)
ASCII = {"Ø": "D", "ø": "D", "°": " deg", "≤": "<=", "≥": ">=", "≈": "~", "µ": "u", "μ": "u",
         "…": "...", "–": "-", "—": "-", "−": "-", "·": "*", "×": "x", "→": "->", "←": "<-",
         "±": "+/-", "²": "^2", "³": "^3", "‰": "/1000", "’": "'", "‘": "'", "“": '"',
         "”": '"'}

DECIMALS = 4  # mm and degrees
VEC_DECIMALS = 7  # unit vector components


def version() -> str:
    """Product version, as the program header states it (:mod:`..version`)."""
    return __version__


def fmt(x: float, decimals: int = DECIMALS) -> str:
    """Fixed-point number, no negative zero; PostError for nan or inf (no controller reads
    them, and a program must never stop mid-cut on one)."""
    if not math.isfinite(float(x)):
        raise PostError(f"a program word would be {float(x)!r}: the path holds a number that is "
                        "not finite; nothing was written")
    s = f"{float(x):.{decimals}f}"
    return "0." + "0" * decimals if float(s) == 0.0 else s


def fvec(v) -> list[str]:
    return [fmt(c, VEC_DECIMALS) for c in v]


def ascii_text(text: str) -> str:
    """``text`` in ASCII: the characters of :data:`ASCII` spelled out, accents dropped
    (NFKD), anything else "?"."""
    if text.isascii():
        return text
    out = "".join(ASCII.get(ch, ch) for ch in text)
    out = unicodedata.normalize("NFKD", out)
    return "".join(ch if ch.isascii() else ("" if unicodedata.combining(ch) else "?")
                   for ch in out)


def tool_text(tool) -> str:
    """"Ø12 ball", "Ø12 R2 bull nose", "Ø12 flat end", "Ø12 taper 3° ball"."""
    d = f"Ø{tool.d:g}"
    if tool.type == "ball":
        return f"{d} ball"
    if tool.type == "bull":
        return f"{d} R{tool.r:g} bull nose"
    if tool.type == "flat":
        return f"{d} flat end"
    return f"{d} tapered ball {math.degrees(tool.beta):g}°"


@dataclass
class PostContext:
    path: ToolPath
    machine: Machine
    options: NcOptions
    blocks: Blocks
    post: str

    @property
    def rotary_names(self) -> tuple[str, str]:
        return self.machine.axis_names


def header_lines(ctx: PostContext, *, tcp: bool) -> list[str]:
    """Header comment text lines (without comment delimiters), ASCII (:func:`ascii_text`:
    the tool is "D12 ball")."""
    o = ctx.options
    p = ctx.path
    m = ctx.machine
    lines = [
        f"Blisk CAM {version()} - 5-axis blade finishing",
        f"blade: {o.blade_name}  blades: {ctx.blocks.blades}",
        f"tool T{o.tool_number}: {tool_text(p.tool)}",
        f"tolerances: cusp {p.cusp:g} mm, chord {p.chord:g} mm, "
        f"linearization chord {(o.chord or p.chord):g} mm"
        + (f", allowance {p.allowance:g} mm left on the blade (semi-finishing)"
           if getattr(p, "allowance", 0.0) else ""),
        f"machine: {m.name} ({m.kinematics}, {'/'.join(m.axis_names)})",
        f"post: {ctx.post}  units: mm, degrees",
        *getattr(o, "notes", ()),
    ]
    lines += frame_lines(ctx, tcp=tcp)
    return [ascii_text(line) for line in lines]


def _xyz(v) -> str:
    return " ".join(f"{a}{fmt(c)}" for a, c in zip("XYZ", v, strict=True))


#: per TCP post: (where the work offset is set, what the control's TCP mode is called)
WORK_OFFSET = {
    "fanuc": ("set work offset G54", "TCP (G43.4)"),
    "siemens": ("set the settable frame G54", "TRAORI"),
    "heidenhain": ("set the active preset (preset table row; datum)", "M128"),
}


def frame_lines(ctx: PostContext, *, tcp: bool) -> list[str]:
    """The header lines that say which frame the program is in (ASCII).

    TCP posts: X Y Z are the tool tip in the part (paths) frame, whose origin the work offset
    holds — stated in the controller's terms (:data:`WORK_OFFSET`: G54 for Fanuc and
    Siemens, the preset table for Heidenhain) as the part origin in machine coordinates with
    the rotaries at 0 — and the rotary axis lines the control's kinematic data must hold for
    its TCP mode to place the tool there (direction and a point, machine coordinates,
    rotaries at 0; the part origin from the innermost table rotary's point). Joint programs:
    the machine description's frame and the part origin in it."""
    m = ctx.machine
    po = _xyz(m.part_origin)
    if not tcp:
        return [ascii_text(line) for line in (
            "joint program, no TCP: X Y Z = machine tip position; G54 at the machine "
            "description's origin, part frame from its [part] table",
            f"part origin {po} mm from the machine description's origin (rotaries at 0)")]
    where, mode = WORK_OFFSET.get(ctx.post, ("set the work offset (G54 / preset)", "TCP"))
    controller = ctx.post in WORK_OFFSET  # APT: CL data for a downstream post
    lines = [
        "work offset at the part (paths) origin, axes along the paths x y z; X Y Z = tool tip",
        f"work offset: {where} to the part origin {po} mm (machine coordinates, rotaries at 0)",
    ]
    lines += [f"{mode} needs the control's kinematic data to hold: {r.name} axis "
              f"({', '.join(fvec(r.axis))}) through {_xyz(r.point)} (machine coordinates, "
              "rotaries at 0)" for r in m.rotaries if controller]
    inner = [r for r, on_table in zip(m.rotaries, m.tables, strict=True) if on_table]
    if inner:
        r = inner[-1]
        lines.append(f"part origin from the {r.name} axis point: {_xyz(m.part_origin - r.point)} "
                     "mm")
    return [ascii_text(line) for line in lines]


def block_minutes(blocks: Blocks, options: NcOptions) -> np.ndarray:
    """(n,) minutes per block: feed blocks by tip length / feed (at least the rotary move at
    ``rotary_rate``), rapids by machine distance / rapid rate."""
    n = len(blocks)
    t = np.zeros(n)
    tip = blocks.tip
    q = blocks.angles
    pose = blocks.poses
    idx = np.nonzero(pose)[0]
    for a, b in zip(idx[:-1], idx[1:], strict=True):
        L = float(np.linalg.norm(tip[b] - tip[a]))
        rot = float(np.degrees(np.abs(q[b] - q[a]).max()))
        if blocks.kind[b] == MOVE_RAPID:
            Lm = float(np.linalg.norm(blocks.xyz[b] - blocks.xyz[a]))
            t[b] = max(Lm / options.rapid_rate, rot / (2 * options.rotary_rate))
        else:
            t[b] = max(L / blocks.feed[b], rot / options.rotary_rate, 1e-6)
    t[~pose] = 0.0
    return t


def write_atomic(filename, text: str) -> str:
    """Write ``text`` to ``filename`` atomically (:func:`..files.write_atomic`: a failure never
    leaves a half-written file; the mode a plain ``open`` would give). A missing directory →
    PostError."""
    return files.write_atomic(filename, text, error=PostError)


def write_program_folder(folder, files: dict) -> list[str]:
    """Write a program's ``files`` ({file name: text}) into ``folder`` (created if missing;
    its parent must exist), each atomically (:func:`write_atomic`). A file already there is
    replaced only when Blisk CAM wrote it (:data:`OWN_MARK` in its first 4 kB): otherwise
    PostError naming it, before anything is written. Returns the paths written."""
    folder = os.fspath(folder)
    if os.path.exists(folder) and not os.path.isdir(folder):
        raise PostError(f"{folder} exists and is not a directory: choose an output folder")
    parent = os.path.dirname(os.path.abspath(folder))
    if not os.path.isdir(parent):
        raise PostError(f"cannot write into {folder}: the directory {parent} does not exist")
    targets = []
    for name in files:
        target = os.path.join(folder, name)
        if os.path.exists(target):
            with open(target, encoding="utf-8", errors="replace") as fh:
                if OWN_MARK not in fh.read(4096):
                    raise PostError(f"{target} exists and was not written by Blisk CAM; "
                                    "choose another output folder")
        targets.append(target)
    os.makedirs(folder, exist_ok=True)
    for target, text in zip(targets, files.values(), strict=True):
        write_atomic(target, text)
    return targets


__all__ += ["SAFE", "block_minutes"]
