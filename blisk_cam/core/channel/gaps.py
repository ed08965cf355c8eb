"""The program of several gaps of a blisk in the order asked: by gap or by level.

Channel roughing plans one gap (between blade 0 and blade 1); gap k is that gap turned by
k · 2π/N about the blisk axis (the part is periodic). The gap's program comes as **blocks**
— linked programs that start with a rapid to the safe radius and end with a retract to it
(:func:`.patterns.link_program` makes them): the whole gap as one block, or one block per
level. :func:`pattern_gaps` lays the blocks of every gap in order:

* ``"gap"`` — every block of gap 0, then every block of gap 1, … (all levels of a gap
  before the next gap: the tool stays in one channel, the fewest moves round the axis);
* ``"level"`` — block 1 (the top level) in every gap, then block 2 in every gap, … (every
  channel reaches a level before any goes deeper: each blade is roughed from both sides
  level by level, the blisk stays balanced).

The post does the same with a one-gap program of per-level blocks (``stats["level_blocks"]``,
:func:`..post.blocks.build_blocks`), a safe retract of the machine between blocks; this
module makes the program itself hold the gaps (the roughing's ``gaps``), e.g. to simulate it.

Between two blocks the tool is at the safe radius (the previous block's retract) and goes
**round the axis** there as rapids: the shorter way round, in steps of at most
min(pitch, 1 rad) about the axis. A straight move between two points at radius ρ ≥ r_safe
whose angles about the axis differ by φ stays at least ρ cos(φ/2) from the axis, so with
r_safe = (top + clearance) / cos(min(pitch, 1)) (the roughing's safe radius) every rapid
stays at least the clearance above the blank's top; the tool points away from the axis
there. Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BliskCamError
from ..geometry.axis import Axis
from ..geometry.vectors import rotate_about
from ..toolpath.types import MOVE_RAPID

__all__ = ["GAP_ORDERS", "block_sequence", "pattern_gaps", "round_the_axis"]

#: the orders of the gaps' blocks (module docstring)
GAP_ORDERS = ("gap", "level")


def block_sequence(n_blocks: int, n_gaps: int, order: str) -> list[tuple[int, int]]:
    """[(block, gap)] in machining order for ``order`` "gap" (gap-major) or "level"
    (block-major). BliskCamError for another order."""
    if order not in GAP_ORDERS:
        raise BliskCamError(f"order must be one of {', '.join(GAP_ORDERS)}, got {order!r}")
    if order == "gap":
        return [(b, g) for g in range(n_gaps) for b in range(n_blocks)]
    return [(b, g) for b in range(n_blocks) for g in range(n_gaps)]


def round_the_axis(p0, a0, p1, axis: Axis, max_step: float):
    """Poses (k, 3), unit axes (k, 3) strictly between ``p0`` and ``p1`` (mm) going round
    ``axis`` the shorter way: the angle about the axis, the height along it and the distance
    from it interpolated linearly, each step at most ``max_step`` rad about the axis; the
    axis ``a0`` turned with the position. k = 0 when one step suffices."""
    e1, e2, d = axis.angular_frame()
    q0, q1 = np.asarray(p0, float) - axis.o, np.asarray(p1, float) - axis.o
    t0, t1 = math.atan2(q0 @ e2, q0 @ e1), math.atan2(q1 @ e2, q1 @ e1)
    dt = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi
    n = math.ceil(abs(dt) / max_step - 1e-9) if dt else 0
    if n <= 1:
        return np.zeros((0, 3)), np.zeros((0, 3))
    f = np.arange(1, n) / n
    h0, h1 = q0 @ d, q1 @ d
    r0 = math.hypot(q0 @ e1, q0 @ e2)
    r1 = math.hypot(q1 @ e1, q1 @ e2)
    th, h, r = t0 + f * dt, h0 + f * (h1 - h0), r0 + f * (r1 - r0)
    pts = axis.o + (r * np.cos(th))[:, None] * e1 + (r * np.sin(th))[:, None] * e2 \
        + h[:, None] * d
    axes = np.stack([rotate_about(np.asarray(a0, float)[None], d, float(x))[0]
                     for x in f * dt])
    return pts, axes / np.linalg.norm(axes, axis=1)[:, None]


def pattern_gaps(blocks, axis: Axis, pitch: float, n_gaps: int, order: str,
                 n_curves: int):
    """The program of ``n_gaps`` gaps from gap 0's ``blocks`` in ``order`` (module
    docstring).

    Parameters
    ----------
    blocks : list of (tip (m, 3) mm, axis (m, 3), move (m,), curve (m,), index (m,)) — gap
        0's linked blocks, each starting with a rapid and ending with a retract at the safe
        radius; ``curve`` indexes gap 0's passes (−1 for a link pose)
    axis : Axis — the blisk axis; pitch : float, rad — 2π/N; n_gaps : int (1 … N)
    order : "gap" | "level"
    n_curves : int — gap 0's pass count: gap g's pass c becomes pass g · n_curves + c

    Returns
    -------
    tip (M, 3), axis (M, 3), move (M,) int8, curve (M,) int64, index (M,) int64,
    gap (M,) int64 — the gap of each row, block (M,) int64 — the block of each row
    """
    if not blocks:
        raise BliskCamError("no block to pattern: the gap has no program")
    if not (1 <= int(n_gaps)):
        raise BliskCamError(f"the gaps to pattern must be at least 1, got {n_gaps}")
    d = axis.d
    step = min(float(pitch), 1.0)
    out = {k: [] for k in ("tip", "axis", "move", "curve", "index", "gap", "block")}
    last = None
    for b, g in block_sequence(len(blocks), int(n_gaps), order):
        tip, ax, move, curve, index = (np.asarray(x) for x in blocks[b])
        turn = g * float(pitch)
        if g:
            tip = rotate_about(np.asarray(tip, float), d, turn, axis.o)
            ax = rotate_about(np.asarray(ax, float), d, turn)
        if last is not None:  # round the axis at the safe radius, as rapids
            pts, axs = round_the_axis(last[0], last[1], tip[0], axis, step)
            k = len(pts)
            for key, val in (("tip", pts), ("axis", axs),
                             ("move", np.full(k, MOVE_RAPID, np.int8)),
                             ("curve", np.full(k, -1, np.int64)),
                             ("index", np.full(k, -1, np.int64)),
                             ("gap", np.full(k, g, np.int64)),
                             ("block", np.full(k, b, np.int64))):
                out[key].append(val)
        m = len(tip)
        out["tip"].append(np.asarray(tip, float))
        out["axis"].append(np.asarray(ax, float))
        out["move"].append(np.asarray(move, np.int8))
        out["curve"].append(np.where(np.asarray(curve) >= 0,
                                     np.asarray(curve) + g * int(n_curves), -1).astype(np.int64))
        out["index"].append(np.asarray(index, np.int64))
        out["gap"].append(np.full(m, g, np.int64))
        out["block"].append(np.full(m, b, np.int64))
        last = (tip[-1], ax[-1])
    cat = {k: np.concatenate(v) for k, v in out.items()}
    return (cat["tip"].reshape(-1, 3), cat["axis"].reshape(-1, 3), cat["move"], cat["curve"],
            cat["index"], cat["gap"], cat["block"])
