"""A verdict from the verifier's figures: PASS or FAIL per tolerance bound, and where.

:func:`.verify.verify_path` measures a path (mm): the material left on the machined surface
and how deep the swept cutter dips below it. Its figures say nothing about whether they are
good enough; this module compares them with the bounds that the two tolerances imply:

* **material left ≤ cusp + chord** — the passes are spaced so that the scallop between two
  neighbouring passes is at most the cusp height h; the tool moves in straight lines between
  poses, and the chord tolerance e lets those lines stand off the exact curve by up to e,
  which adds to what is left. (With a bull-nose, flat or taper cutter the passes are spaced
  for an equivalent ball; see :data:`NON_BALL_NOTE`.)
* **gouge ≤ chord** — at every pose the cutter touches the surface; only the straight moves
  between poses may cut into it, by at most the chord tolerance.
* **nothing uncovered** — holes of the mesh inside the region (``report.uncovered_area``,
  mm²) have no surface to measure: the check "uncovered" fails whenever there are any.

A semi-finishing path leaves the allowance a (``report.allowance``, :mod:`.allowance`): the
bounds move with it — **material left on the blade ≤ a + cusp + chord** and **cut into the
allowance ≤ chord** (material left ≥ a − chord); the links likewise may cut into the
allowance by the chord at most.

``judge`` returns a :class:`Verdict`; :func:`verdict_dict` is its JSON form (the paths JSON's
top-level ``"verify"`` key), :func:`verdict_lines` the console lines. The worst point of each
bound is located as xyz (from the report) and, given the path, as the pass and pose nearest
to it. The report is read by attribute only (``max_material_left``, ``max_material_left_at``,
``max_gouge``, ``max_gouge_at``, ``pair_s``, ``pair_cusp``, ``tool``), so any object with
those fields works.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ToleranceError

__all__ = [
    "BoundCheck",
    "Verdict",
    "NON_BALL_NOTE",
    "judge",
    "verdict_dict",
    "verdict_from_dict",
    "verdict_lines",
]

#: the explanation shown with a bull-nose, flat or taper cutter (formatted with the figures)
NON_BALL_NOTE = (
    "A {kind} is not a ball: across the feed its swept envelope curves with an effective "
    "radius that differs from its radius {radius:g} mm and changes with lead and tilt, so "
    "the passes are spaced for the ball that leaves the same scallop at the same step{rho}. "
    "The verifier measures the material left against the true swept {kind}, including the "
    "sag of the straight moves between poses, which the chord tolerance allows on top of the "
    "scallop: the bound is cusp + chord = {bound:g} mm, not the cusp alone, so a measured "
    "figure of, say, {example:.4f} mm against a cusp of {cusp:g} mm is within it. The gouge "
    "bound is the chord tolerance {chord:g} mm: the {kind} touches the surface at every pose, "
    "only the straight moves between poses may dip below it."
)

_KIND = {"bull": "bull-nose cutter", "flat": "flat end mill", "taper": "taper cutter"}


@dataclass
class BoundCheck:
    """One bound: ``value`` (mm, measured) against ``bound`` (mm).

    ``at`` (3,) xyz of the worst point (None when unknown); ``curve``/``pose``/``s`` the pass
    (index into ``path.curves``), the pose in it and its ratio nearest to ``at`` (None without
    a path); ``between`` the ratios of the two passes whose scallop it is (material left only,
    when the worst point is a scallop between neighbouring passes); ``row`` the program row
    (the link check: the non-cut move ending at that row)."""

    name: str
    value: float
    bound: float
    passed: bool
    at: np.ndarray | None = None
    curve: int | None = None
    pose: int | None = None
    s: float | None = None
    between: tuple[float, float] | None = None
    row: int | None = None  # program row (the link check: the move ending there)

    @property
    def margin(self) -> float:
        """bound − value (mm; < 0 when failed)."""
        return self.bound - self.value


@dataclass
class Verdict:
    """PASS when every check passes. ``note`` explains the bounds for non-ball cutters."""

    passed: bool
    checks: list[BoundCheck]
    cusp: float
    chord: float
    tool: dict = field(default_factory=dict)
    note: str | None = None
    allowance: float = 0.0  # mm of stock the path leaves (the bounds move with it)

    @property
    def status(self) -> str:
        return "PASS" if self.passed else "FAIL"


def _finite_tolerance(name, x) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise ToleranceError(f"verdict: {name} must be a number in mm, got {x!r}") from None
    if not (math.isfinite(v) and v > 0):
        raise ToleranceError(f"verdict: {name} must be a positive length in mm, got {x!r}")
    return v


def _tool_dict(cutter, report) -> dict:
    if cutter is None:
        cutter = getattr(report, "tool", None) or {}
    if isinstance(cutter, dict):
        return dict(cutter)
    if hasattr(cutter, "as_dict"):
        return dict(cutter.as_dict())
    raise ToleranceError(f"verdict: the cutter must be a Cutter or its dict, got {cutter!r}")


def _point(x):
    if x is None:
        return None
    p = np.asarray(x, dtype=np.float64).reshape(-1)
    return p[:3].copy() if len(p) >= 3 and np.all(np.isfinite(p[:3])) else None


def _locate(path, at):
    """(curve index, pose index, s) of the cutting pose nearest to ``at``."""
    best = (math.inf, None, None, None)
    for i, c in enumerate(path.curves):
        cc = np.asarray(c.cc, dtype=np.float64)
        if len(cc) == 0:
            continue
        cut = np.nonzero(np.asarray(c.move) == 0)[0] if c.move is not None else np.arange(len(cc))
        if len(cut) == 0:
            continue
        d = np.einsum("ij,ij->i", cc[cut] - at, cc[cut] - at)
        k = int(np.argmin(d))
        if d[k] < best[0]:
            best = (float(d[k]), i, int(cut[k]), float(c.ratios[cut[k]]))
    return best[1:]


def judge(report, cusp: float, chord: float, cutter=None, path=None,
          allowance: float | None = None) -> Verdict:
    """The verdict on a verify report.

    Parameters
    ----------
    report : VerifyReport (:func:`.verify.verify_path`)
    cusp, chord : float, mm > 0 — the path's tolerances
    cutter : Cutter, its dict, or None (the report's ``tool``)
    path : ToolPath or None — to name the pass and pose nearest each worst point
    allowance : float, mm ≥ 0, or None (the report's ``allowance``, else 0) — the stock the
        path leaves: the material left is then judged on the blade against a + cusp + chord
        and the gouges as cuts into the allowance (the report measures them so)

    A figure that could not be measured (NaN: no surface samples) fails its bound.
    """
    h = _finite_tolerance("cusp", cusp)
    e = _finite_tolerance("chord", chord)
    tool = _tool_dict(cutter, report)
    a = float(getattr(report, "allowance", 0.0) or 0.0) if allowance is None else allowance
    if not (math.isfinite(a) and a >= 0):
        raise ToleranceError(f"verdict: the allowance must be a length ≥ 0 mm, got {a!r}")
    checks = []
    for name, value, at, bound in (
        ("material_left", a + report.max_material_left, report.max_material_left_at,
         a + h + e),
        ("gouge", report.max_gouge, report.max_gouge_at, e),
    ):
        v = float(value)
        ok = bool(math.isfinite(v) and v <= bound)
        chk = BoundCheck(name, v, float(bound), ok, at=_point(at))
        if path is not None and chk.at is not None:
            chk.curve, chk.pose, chk.s = _locate(path, chk.at)
        if name == "material_left":
            pc = np.asarray(getattr(report, "pair_cusp", []), dtype=np.float64)
            ps = np.asarray(getattr(report, "pair_s", []), dtype=np.float64).reshape(-1, 2)
            if len(pc) and np.any(np.isfinite(pc)) and len(ps) == len(pc):
                j = int(np.nanargmax(pc))
                if math.isfinite(v) and abs(a + pc[j] - v) <= 1e-9 * max(1.0, abs(v)):
                    chk.between = (float(ps[j, 0]), float(ps[j, 1]))
        checks.append(chk)
    link = getattr(report, "link_gouge", None)
    if link is not None and int(getattr(report, "link_rows", 0) or 0) > 0:
        # every row of the program is judged: the links, approaches, retracts and rapids
        # may not cut into the part beyond the chord either (issue 28)
        v = float(link)
        row = getattr(report, "link_gouge_row", None)
        checks.append(BoundCheck("link_gouge", v, float(e), bool(math.isfinite(v) and v <= e),
                                 at=_point(getattr(report, "link_gouge_at", None)),
                                 row=None if row is None else int(row)))
    holes = int(getattr(report, "uncovered_holes", 0) or 0)
    if holes:
        # holes of the mesh inside the region: no sample there, so no figure covers them;
        # never a PASS over surface that was not measured (issue 28)
        checks.append(BoundCheck("uncovered", float(report.uncovered_area), 0.0, False,
                                 at=_point(getattr(report, "uncovered_at", None))))
    note = None
    kind = str(tool.get("type", "ball")).lower()
    if kind in _KIND:
        rho = ""
        stats = getattr(path, "stats", None) or {}
        if isinstance(stats.get("expansion_radius"), (int, float)):
            rho = f" (radius {float(stats['expansion_radius']):.3g} mm)"
        note = NON_BALL_NOTE.format(
            kind=_KIND[kind], radius=float(tool.get("radius", float("nan"))), rho=rho,
            bound=h + e, example=h + e - 1e-4 if h + e > 1e-4 else h + e, cusp=h, chord=e,
        )
    return Verdict(all(c.passed for c in checks), checks, h, e, tool, note, a)


def _f(x):
    return None if x is None or not math.isfinite(float(x)) else float(x)


def verdict_dict(verdict: Verdict) -> dict:
    """JSON-ready form (for the paths JSON's ``"verify"`` key); NaN becomes null.

    ``{"status": "PASS"|"FAIL", "cusp": h, "chord": e, "checks": {"material_left": {"value",
    "bound", "status", "at": [x, y, z], "curve", "pose", "s", "between": [s0, s1]}, "gouge":
    {...}}, "note": text}`` — keys whose value is unknown are left out."""
    checks = {}
    for c in verdict.checks:
        d = {"value": _f(c.value), "bound": c.bound, "status": "PASS" if c.passed else "FAIL"}
        if c.at is not None:
            d["at"] = [float(x) for x in c.at]
        for k in ("curve", "pose"):
            if getattr(c, k) is not None:
                d[k] = int(getattr(c, k))
        if c.s is not None:
            d["s"] = float(c.s)
        if c.between is not None:
            d["between"] = [float(x) for x in c.between]
        if c.row is not None:
            d["row"] = int(c.row)
        checks[c.name] = d
    out = {"status": verdict.status, "cusp": verdict.cusp, "chord": verdict.chord,
           **({"allowance": verdict.allowance} if verdict.allowance else {}),
           "checks": checks}
    if verdict.note:
        out["note"] = verdict.note
    return out


def verdict_from_dict(d: dict) -> Verdict:
    """The :class:`Verdict` of a :func:`verdict_dict` (e.g. a paths JSON's ``"verify"``), so
    a reader of the file can print :func:`verdict_lines`. ToleranceError when malformed."""
    try:
        checks = []
        for name, c in d["checks"].items():
            value = float("nan") if c.get("value") is None else float(c["value"])
            checks.append(BoundCheck(
                name, value, float(c["bound"]), c["status"] == "PASS",
                at=_point(c.get("at")), curve=c.get("curve"), pose=c.get("pose"),
                s=c.get("s"), between=tuple(c["between"]) if c.get("between") else None,
                row=c.get("row"),
            ))
        return Verdict(d["status"] == "PASS", checks, float(d["cusp"]), float(d["chord"]),
                       note=d.get("note"), allowance=float(d.get("allowance", 0.0)))
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        raise ToleranceError(f"verify verdict is incomplete or malformed: {err}") from err


_LABEL = {"material_left": "material left", "gouge": "gouge",
          "link_gouge": "gouge of the links, approaches, retracts and rapids"}
_RULE = {"material_left": "cusp + chord", "gouge": "chord", "link_gouge": "chord"}


#: the labels and rules of a path that leaves an allowance (semi-finishing)
_LABEL_ALLOWANCE = {"material_left": "material left on the blade",
                    "gouge": "cut into the allowance",
                    "link_gouge": "cut into the allowance by the links, approaches, retracts "
                                  "and rapids"}
_RULE_ALLOWANCE = {"material_left": "allowance + cusp + chord",
                   "gouge": "chord: left ≥ allowance − chord",
                   "link_gouge": "chord"}


def verdict_lines(verdict: Verdict) -> list[str]:
    """Console lines: the overall status, one line per bound with where, then the note."""
    a = verdict.allowance
    head = f"allowance {a:g} mm, " if a else ""
    lines = [f"verify: {verdict.status} ({head}cusp {verdict.cusp:g} mm, chord "
             f"{verdict.chord:g} mm)"]
    labels, rules = (_LABEL_ALLOWANCE, _RULE_ALLOWANCE) if a else (_LABEL, _RULE)
    for c in verdict.checks:
        label, rule = labels.get(c.name, c.name), rules.get(c.name, "")
        if c.name == "uncovered":
            text = (f"  FAIL {c.value:.1f} mm² of the region not measured: the mesh has holes "
                    "there (fill them, or move the cones off them)")
        elif not math.isfinite(c.value):
            text = f"  FAIL {label} not measured (no surface samples), bound {c.bound:.4f} mm"
        else:
            rel = "≤" if c.passed else ">"
            text = (f"  {'PASS' if c.passed else 'FAIL'} {label} {c.value:.4f} mm {rel} "
                    f"{c.bound:.4f} mm ({rule})")
        where = []
        if c.between is not None:
            where.append(f"between the passes at s = {c.between[0]:.4f} and {c.between[1]:.4f}")
        if c.curve is not None:
            where.append(f"near pass {c.curve} (s = {c.s:.4f}) pose {c.pose}")
        if c.row is not None and not (c.passed and c.value == 0.0):
            where.append(f"on the move to program row {c.row}")
        if c.at is not None:
            where.append("at ({:.3f}, {:.3f}, {:.3f}) mm".format(*c.at))
        if where:
            text += ", worst " + ", ".join(where)
        lines.append(text)
    if verdict.note:
        lines.append(verdict.note)
    return lines
