"""The collision gate of every NC export: one function all front ends go through.

:func:`collision_gate` is called by :func:`.export.nc_program` (so by ``export_nc``, the ``nc``
and ``paths --nc`` commands and Blender's Export NC): a path whose collision check left
unresolved poses is refused (:class:`CollisionGateError`) unless the user allowed it
(``--allow-collisions``, "Export Anyway"), and then the program header says how many and where
(pass and pose ranges, link rows). A path that was never checked for collisions is posted with
a header line saying so and a warning for the console. Header text is ASCII (every controller
reads it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import PostError
from ..toolpath.types import STATUS_UNRESOLVED, ToolPath

__all__ = ["CollisionGateError", "GateResult", "collision_gate", "unresolved_ranges"]

#: at most this many ranges are listed in a header or a message (then "and k more")
MAX_RANGES = 12

NOT_CHECKED = ("COLLISIONS NOT CHECKED: holder and shank were never checked against the blade "
               "and its neighbours")


class CollisionGateError(PostError):
    """A path with unresolved collisions, posted without the user's consent."""


@dataclass(frozen=True)
class GateResult:
    """What the gate lets through.

    notes : tuple[str] — header lines for the program (ASCII); warning : str or None — a line
    for the console (stderr, the operator's report); unresolved : int — unresolved poses
    posted (0 unless allowed); checked : bool — whether the path was checked at all.
    """

    notes: tuple = ()
    warning: str | None = None
    unresolved: int = 0
    checked: bool = True


def _count(path: ToolPath) -> int:
    summary = path.collision or {}
    n = int(summary.get("unresolved", 0) or 0)
    prog = path.program
    if prog is not None and prog.collision_status is not None:
        n = max(n, int(np.count_nonzero(np.asarray(prog.collision_status) == STATUS_UNRESOLVED)))
    if prog is None:
        n = max(n, sum(int(np.count_nonzero(np.asarray(c.collision["status"])
                                            == STATUS_UNRESOLVED))
                       for c in path.curves if c.collision is not None))
    return n


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[(first, last)] inclusive runs of True in ``mask``."""
    idx = np.flatnonzero(mask)
    if len(idx) == 0:
        return []
    breaks = np.flatnonzero(np.diff(idx) != 1)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    stops = np.concatenate([idx[breaks], [idx[-1]]])
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


def unresolved_ranges(path: ToolPath) -> list[str]:
    """Where the unresolved poses are, as text: ``"pass 3 poses 10-25"`` (pass = index of the
    curve in the paths), ``"link rows 120-130"`` (program rows of links, approaches,
    retracts); in program order. From the per-curve status when the path has no program."""
    prog = path.program
    out: list[str] = []
    if prog is not None and prog.collision_status is not None:
        bad = np.asarray(prog.collision_status) == STATUS_UNRESOLVED
        curve = np.asarray(prog.curve)
        index = np.asarray(prog.index)
        # split runs where the curve changes
        key = np.where(bad, curve, -2)
        for a, b in _runs(bad):
            start = a
            for j in range(a, b + 1):
                if j == b or key[j + 1] != key[j]:
                    c = int(curve[start])
                    if c >= 0:
                        i0, i1 = int(index[start]), int(index[j])
                        if i1 < i0:  # a closed pass ends on its first pose again
                            last = int(index[j - 1])
                            out.append((f"pass {c} pose {i0}" if last == i0
                                        else f"pass {c} poses {i0}-{last}")
                                       + " and its closing pose")
                        else:
                            out.append(f"pass {c} pose {i0}" if i0 == i1
                                       else f"pass {c} poses {i0}-{i1}")
                    else:
                        out.append(f"link row {start}" if start == j
                                   else f"link rows {start}-{j}")
                    start = j + 1
        return out
    for c_i, c in enumerate(path.curves):
        if c.collision is None:
            continue
        for a, b in _runs(np.asarray(c.collision["status"]) == STATUS_UNRESOLVED):
            out.append(f"pass {c_i} pose {a}" if a == b else f"pass {c_i} poses {a}-{b}")
    return out


def _listed(ranges: list[str]) -> str:
    shown = "; ".join(ranges[:MAX_RANGES])
    more = len(ranges) - MAX_RANGES
    return shown + (f"; and {more} more range(s)" if more > 0 else "")


def collision_gate(path: ToolPath, allow_collisions: bool = False) -> GateResult:
    """Judge ``path`` before it is posted.

    Unresolved collisions and not ``allow_collisions``: :class:`CollisionGateError` naming
    how many and where, and what to do. Allowed: the header notes mark the program (count and
    ranges). Never checked (``path.collision`` is None): a header note and a console warning.
    Checked and clear: nothing to add."""
    if path.collision is None:
        return GateResult(
            notes=(NOT_CHECKED,),
            warning="the path was never checked for collisions (holder, shank, neighbours): "
                    "the program is marked 'COLLISIONS NOT CHECKED'; check them with "
                    "'paths --collisions check --blade-count N' (or Check Collisions)",
            checked=False)
    n = _count(path)
    if n == 0:
        return GateResult()
    where = _listed(unresolved_ranges(path))
    if not allow_collisions:
        raise CollisionGateError(
            f"{n} pose(s) are unresolved collisions ({where}): the program could crash the "
            "machine, so it was not written. Correct them (--collisions avoid, another "
            "holder or tilt) or post anyway with --allow-collisions (Export Anyway)")
    return GateResult(
        notes=(f"WARNING: EXPORTED ANYWAY WITH {n} UNRESOLVED COLLISION POSE(S) "
               "(--allow-collisions / Export Anyway)",
               f"unresolved collisions at: {where}"),
        warning=f"{n} unresolved collision pose(s) posted on request; the program header "
                f"marks them ({where})",
        unresolved=n)
