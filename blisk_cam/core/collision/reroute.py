"""Re-routing of colliding links through the clearance surface (issue 10; the cutting poses
are corrected first, :mod:`.avoid`, paper 004 §3).

A **link run** is a maximal run of program rows that are not pass poses
(``Program.curve < 0``): the retract, the rapids and the approach point between two passes,
an on-surface link, the rapids before the first pass, the retract and rapid after the last.
Once the cutting poses are corrected, a run with a colliding row (clearance < ds) is replaced
by a route built from the corrected poses it connects — A, the last pose of the pass before
(tip t_A, unit axis a_A), and B, the first pose of the pass after:

1. **retract** up A's axis, ``t_A + t a_A`` for 0 < t ≤ T_A, T_A where the tip meets the
   clearance surface;
2. **rapids** on the clearance surface from there to the point where B's axis line meets it:
   the angle about the blisk axis (the shorter way round) and the height linear in
   u ∈ [0, 1], the radius that of the surface at that height, the tool axis the slerp
   a_A → a_B;
3. **approach** down B's axis onto B (a pass reached by an on-surface link is then reached by
   an approach).

The first run of a program (no A) is a rapid to B's point on the surface and the approach;
the last (no B) the retract. The retract needs an axis that leads out of the blisk: the
radius must grow along it by at least ``MIN_RADIAL`` mm per mm (the axis within ~84° of the
radial direction), else that run has no route.

**Clearance surface** — the cone ``r(z) = R + slope (z − z0)`` of :mod:`..paths.linking`, read back
from the program (:func:`clearance_surface`: its rapid rows on the surface), so a path read
from a file is re-routed on the surface it was linked with.

**Densification** — consecutive route poses are spaced so that no point of the tool
assembly moves by more than s = max(ds, 0.5 mm): |Δtip| + H · Δangle ≤ s, H the distance
of its farthest point from the tip, √(top² + largest radius²); and the axis turns by at most
δ (``CollisionOptions.max_turn``, default 2°) per step. The clearance is 1-Lipschitz in the
motion of the tool, so between two poses that clear ds the moving tool keeps at least
ds − s/2 (ds/2 for ds ≥ 0.5 mm): no contact between the checked poses.

**Check and tries** — every route pose is checked with the same detection
(:meth:`.collision.CollisionScene.detect`); on the rapids the cutter (flute) must clear the
blade it machines too (there it does not cut: it would gouge it), so they are checked with
``flute_on_target``. A route with a colliding pose is built
again on the surface raised by Δ_k (a longer retract and approach): Δ_1 puts the tip beyond
the blades' largest radius by the cutter radius and ds (the flute then clears every blade;
Δ_1 = g where the surface is that far out already), each later try g = max(the body's
largest radius, ds, 5 mm) more, ``ROUTE_TRIES`` tries in all. A run that no try clears keeps
its planned rows — never dropped — its colliding rows unresolved (status 2), and is named in
the report with the reason. A pass pose left unresolved collides whatever its axis, so the
retract out of it (the approach into it) starts colliding: there the route's leading
retract rows (trailing approach rows) that collide are left out — the tool goes straight
along the axis to the first clear row, a move that belongs to that pose's unresolved range
(as the motion out of an unresolved pose on a pass does) — and every other row must
clear.

Status of a route row: 1 (corrected); its rotation is the angle from the planned axis — A's
planned axis on the retract, B's on the approach, the slerp of the two on the rapids.

Lengths mm, angles radians (``Program.rotation_deg`` holds degrees, as the paths JSON).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..geometry.axis import Axis, cylindrical, from_cylindrical, meridional
from ..geometry.vectors import angle_between, slerp, unit
from ..paths.linking import Clearance
from ..toolpath.types import (
    MOVE_APPROACH,
    MOVE_RAPID,
    MOVE_RETRACT,
    STATUS_CORRECTED,
    STATUS_UNRESOLVED,
    Program,
)

__all__ = [
    "MIN_RADIAL",
    "ROUTE_TRIES",
    "LinkRun",
    "clearance_surface",
    "link_runs",
    "reroute_links",
]

#: clearance surfaces tried per colliding run (the program's, then raised)
ROUTE_TRIES = 4
#: the retract/approach axis must gain at least this much radius per mm along it
MIN_RADIAL = 0.1
#: largest step of any point of the tool between route poses when ds is smaller, mm
_MIN_STEP = 0.5
#: route poses per run beyond which a run counts as having no route (a guard, not a limit
#: a sane route reaches: 20 m of travel at 1 mm)
_MAX_ROUTE_POSES = 20000


@dataclass(frozen=True)
class LinkRun:
    """Rows ``start:stop`` of a program that are not pass poses, between the pass pose at
    row ``before`` (−1: the program's start) and the one at row ``after`` (−1: its end)."""

    start: int
    stop: int
    before: int
    after: int


def link_runs(program: Program) -> list[LinkRun]:
    """The maximal runs of non-pass rows (``curve < 0``) of a program, in order."""
    off = np.asarray(program.curve) < 0
    m = len(off)
    if not off.any():
        return []
    d = np.diff(np.concatenate([[0], off.astype(np.int8), [0]]))
    starts, stops = np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]
    return [LinkRun(int(a), int(b), int(a) - 1, int(b) if b < m else -1)
            for a, b in zip(starts, stops, strict=True)]


def clearance_surface(program: Program, axis: Axis) -> Clearance:
    """The clearance surface a :mod:`..paths.linking` program was built with, from its rows on it:
    rapid rows followed by another rapid (out to, along and down the surface) and a last
    rapid row. r = R + slope · z fitted by least squares (a cylinder when the radii agree to
    1 µm; where the rows lie on no one surface — a program re-routed before — a cylinder
    through the lowest); with no such rows, a cylinder 5 mm outside every row (the linking
    default)."""
    mv = np.asarray(program.move)
    m = len(mv)
    on = np.zeros(m, bool)
    on[:-1] = (mv[:-1] == MOVE_RAPID) & (mv[1:] == MOVE_RAPID)
    if m and mv[-1] == MOVE_RAPID:
        on[-1] = True
    r_all, _ = meridional(np.asarray(program.tip, float).reshape(-1, 3), axis)
    if not on.any():
        return Clearance(float(r_all.max(initial=0.0)) + 5.0)
    r, z = meridional(np.asarray(program.tip, float)[on], axis)
    if r.max() - r.min() <= 1e-6 or z.max() - z.min() <= 1e-6:
        return Clearance(float(r.max()))
    slope, icpt = np.polyfit(z, r, 1)
    if np.abs(icpt + slope * z - r).max() > 1e-6 * max(1.0, float(r.max())):
        # not one surface (a program re-routed before, on raised surfaces): the lowest
        return Clearance(float(r.min()))
    return Clearance(float(icpt), 0.0, float(slope))


def _exit_length(tip, a, axis: Axis, clear: Clearance, lift: float):
    """Length T ≥ 0 along the unit axis ``a`` from ``tip`` to the clearance surface raised by
    ``lift`` mm, or (None, reason) when the axis does not lead out of the blisk."""
    p = tip - axis.o
    d = axis.d
    pz, az = float(p @ d), float(a @ d)
    pp, ap = p - pz * d, a - az * d
    rp = float(np.linalg.norm(pp))
    rate = float(pp @ ap) / rp if rp > 0 else 0.0
    if rate < MIN_RADIAL:
        lean = math.degrees(math.acos(max(-1.0, min(1.0, rate))))
        return None, (f"its tool axis leans {lean:.0f}° from the radial direction, so retracting "
                      "along it does not lead out to the clearance surface")
    k = float(clear.slope)
    c0 = float(clear.r_at(pz)) + lift
    if rp >= c0:
        return 0.0, ""
    # |pp + t ap|² = (c0 + k az t)²: the first root t > 0 (the tip starts inside)
    a2 = float(ap @ ap) - (k * az) ** 2
    a1 = 2.0 * (float(pp @ ap) - k * az * c0)
    a0 = rp * rp - c0 * c0
    roots = np.roots([a2, a1, a0]) if abs(a2) > 1e-15 else np.array([-a0 / a1])
    roots = np.real(roots[np.abs(np.imag(roots)) < 1e-9])
    roots = roots[(roots > 0) & (c0 + k * az * roots >= 0)]
    if len(roots) == 0:
        return None, "the retract along its tool axis never reaches the clearance surface"
    return float(roots.min()), ""


def _line(tip, a, t0, t1, n):
    """Points tip + t a for t from t0 to t1 in n equal steps, t0 excluded."""
    t = t0 + (t1 - t0) * np.arange(1, n + 1) / n
    return tip + t[:, None] * a


# long on purpose: one route (retract, rapids on the surface, approach) with its move codes and
# planned axes, the three legs sharing the step rule
def _route(A, B, A0, B0, axis: Axis, clear: Clearance, lift, step, turn, height):
    """One route for a run: (tips (k, 3), axes (k, 3), moves (k,), planned axes (k, 3)) of the
    rows replacing the run (B itself excluded), or (None, reason).

    A, B : (tip, unit axis) of the corrected poses the run connects (None at the program's
    start / end); A0, B0 : their planned unit axes."""
    if A is not None:
        ta, why = _exit_length(A[0], A[1], axis, clear, lift)
        if ta is None:
            return None, f"the pass end before it: {why}"
        U = A[0] + ta * A[1]
    if B is not None:
        tb, why = _exit_length(B[0], B[1], axis, clear, lift)
        if tb is None:
            return None, f"the pass start after it: {why}"
        W = B[0] + tb * B[1]
    tips, axes, moves, plan = [], [], [], []

    def add(t, a, m, a0):
        tips.append(np.atleast_2d(t))
        axes.append(np.broadcast_to(a, np.atleast_2d(t).shape))
        moves.append(np.full(len(tips[-1]), m, dtype=np.int8))
        plan.append(np.broadcast_to(a0, np.atleast_2d(t).shape))

    if A is not None:  # retract up A's axis to the surface (pure translation along it)
        n = max(1, math.ceil(ta / step)) if ta > 0 else 0
        if n:
            add(_line(A[0], A[1], 0.0, ta, n), A[1], MOVE_RETRACT, A0)
    if A is not None and B is not None:  # rapids on the surface, the axis slerped
        _, th1, z1, fr = cylindrical(U[None], axis)
        _, th2, z2, _ = cylindrical(W[None], axis)
        dth = float((th2[0] - th1[0] + math.pi) % (2 * math.pi) - math.pi)
        # each of r, θ, z is linear in u: a step moves the tip by at most
        # (r_max |Δθ| + |Δr| + |Δz|) / n
        dz = abs(float(z2[0] - z1[0]))
        r_max = float(np.max(clear.r_at(np.array([z1[0], z2[0]])))) + lift
        length = r_max * abs(dth) + (abs(float(clear.slope)) + 1.0) * dz
        ang = float(angle_between(A[1][None], B[1][None])[0])
        n = max(1, math.ceil((length + height * ang) / step), math.ceil(ang / turn))
        if n > _MAX_ROUTE_POSES:
            return None, f"the rapid on the clearance surface would need {n} poses"
        u = np.arange(1, n + 1) / n
        zz = z1[0] + u * (z2[0] - z1[0])
        pts = from_cylindrical(clear.r_at(zz) + lift, th1[0] + u * dth, zz, axis, fr)
        pts[-1] = W  # the exact point above B
        add(pts, slerp(A[1], B[1], u), MOVE_RAPID, slerp(A0, B0, u))
    if B is not None:  # (program start: a rapid to the point above B) then down B's axis
        if A is None:
            add(W, B[1], MOVE_RAPID, B0)
        n = max(1, math.ceil(tb / step)) if tb > 0 else 0
        if n > 1:
            add(_line(B[0], B[1], tb, 0.0, n)[:-1], B[1], MOVE_APPROACH, B0)
    if not tips:
        return None, "the pose lies outside the clearance surface and has nothing to link"
    tips, axes = np.vstack(tips), unit(np.vstack(axes))
    if len(tips) > _MAX_ROUTE_POSES:
        return None, f"the route would need {len(tips)} poses"
    return (tips, axes, np.concatenate(moves), unit(np.vstack(plan))), ""


def _lifts(scene, axis: Axis, clear: Clearance, z_range):
    """The ROUTE_TRIES raises of the clearance surface, mm (module docstring)."""
    blade = scene.obstacles.meshes[0]
    r_blade, _ = meridional(blade.V, axis)
    need = float(r_blade.max()) + float(scene.cutter.radius) + float(scene.safety)
    lowest = float(np.min(clear.r_at(np.asarray(z_range, float))))
    g = max(float(scene.assembly.max_radius), float(scene.safety), 5.0)
    base = need - lowest if need - lowest > 1e-6 else g
    return [0.0] + [base + k * g for k in range(ROUTE_TRIES - 1)]


def _where(program: Program, row: int):
    if row < 0:
        return None
    return {"curve": int(program.curve[row]), "index": int(program.index[row])}


def reroute_links(scene, program: Program, planned: Program, axis: Axis, curve_rotation,
                  *, reroute: bool = True, max_turn: float | None = None):
    """Re-route the colliding link runs of a checked program (module docstring).

    Generator: yields progress fractions in [0, 1], returns ``(Program, summary dict)``.

    Parameters
    ----------
    scene : CollisionScene
    program : Program — after the cutting poses were corrected, with ``collision_status``
        and ``clearance`` per row (:func:`.avoid.iter_avoid_collisions`)
    planned : Program — the planned program (same rows): the planned axes
    axis : Axis — the blisk axis
    curve_rotation : list of (k,) float, rad — per pass, the angle of each pose's axis from
        the planned one (the pass rows' rotation)
    reroute : bool — False (check mode): count the colliding runs, change nothing
    max_turn : float or None, rad — largest axis turn between route poses (None: 2°)

    Returns
    -------
    (Program with ``rotation_deg`` set, dict) — the dict holds the summary's link figures:
    ``link_runs``, ``links_colliding``, ``links_rerouted``, ``links_unresolved``,
    ``link_poses_colliding``, ``link_poses_rerouted`` and ``unresolved_links`` (per
    unresolved run: its first colliding ``row`` in the returned program, ``rows``
    [start, stop), the pass poses it connects ``from``/``to`` ({curve, index} or None), the
    ``tip`` of that row and the ``reason``).
    """
    st = np.asarray(program.collision_status, dtype=np.int8)
    ax0 = unit(planned.axis)
    rot = _row_rotation(program, ax0, curve_rotation)
    runs = link_runs(program)
    hit = [r for r in runs if np.any(st[r.start:r.stop] == STATUS_UNRESOLVED)]
    info = {"link_runs": len(runs), "links_colliding": len(hit), "links_rerouted": 0,
            "links_unresolved": len(hit),
            "link_poses_colliding": int(sum(np.sum(st[r.start:r.stop] == STATUS_UNRESOLVED)
                                            for r in hit)),
            "link_poses_rerouted": 0}
    routes, reasons = {}, {}
    if reroute and hit:
        yield from _try_routes(scene, program, planned, axis, ax0, hit, max_turn, routes,
                               reasons)
    out, new_start = _spliced(program, runs, routes, st, rot)
    bad = [r for r in hit if r not in routes]
    info.update(links_rerouted=len(routes), links_unresolved=len(bad),
                link_poses_rerouted=int(sum(len(v[0]) for v in routes.values())))
    listed = []
    for r in bad:
        s0 = new_start[r]
        j = s0 + int(np.argmax(st[r.start:r.stop] == STATUS_UNRESOLVED))
        listed.append({
            "row": j, "rows": [s0, s0 + r.stop - r.start],
            "from": _where(program, r.before), "to": _where(program, r.after),
            "tip": [float(x) for x in out.tip[j]],
            "reason": reasons.get(r, "not re-routed (collision check mode)" if not reroute
                                  else "no route was tried"),
        })
    info["unresolved_links"] = listed
    return out, info


def _row_rotation(program: Program, ax0, curve_rotation):
    """(m,) rad: each row's axis angle from the planned one (pass rows: ``curve_rotation``)."""
    cur, idx = np.asarray(program.curve), np.asarray(program.index)
    rot = np.zeros(len(program))
    on = cur >= 0
    if on.any():
        rot[on] = np.array([curve_rotation[c][i] for c, i in zip(cur[on], idx[on],
                                                                  strict=True)])
    rot[~on] = angle_between(unit(program.axis[~on]), ax0[~on])
    return rot


def _try_routes(scene, program: Program, planned: Program, axis: Axis, ax0, hit, max_turn,
                routes, reasons):
    """Generator: build and check the routes of the colliding runs ``hit`` on the raised
    clearance surfaces, try by try (yields progress); fills ``routes`` (run → (tips, axes,
    moves, planned axes, clearance)) and ``reasons`` (run → why it has no route)."""
    clear = clearance_surface(planned, axis)
    step = max(float(scene.safety), _MIN_STEP)
    turn = math.radians(2.0) if max_turn is None else float(max_turn)
    # the tool's farthest point from the tip: an axis turn by Δ moves it by ≤ height · Δ
    height = math.hypot(float(scene.assembly.top), float(scene.assembly.max_radius))
    _, z_all = meridional(program.tip, axis)
    lifts = _lifts(scene, axis, clear, [z_all.min(), z_all.max()])
    todo = list(hit)
    for k, lift in enumerate(lifts):
        built = []
        for r in todo:
            A = None if r.before < 0 else (program.tip[r.before],
                                           unit(program.axis[r.before]))
            B = None if r.after < 0 else (program.tip[r.after],
                                          unit(program.axis[r.after]))
            A0 = None if r.before < 0 else ax0[r.before]
            B0 = None if r.after < 0 else ax0[r.after]
            res, why = _route(A, B, A0, B0, axis, clear, lift, step, turn, height)
            if res is None:
                reasons[r] = why
            else:
                lost = (r.before >= 0 and program.collision_status[r.before] == STATUS_UNRESOLVED,
                        r.after >= 0 and program.collision_status[r.after] == STATUS_UNRESOLVED)
                built.append((r, res, lost))
        if built:
            _check_routes(scene, built, lift, routes, reasons)
        todo = [r for r in todo if r not in routes]
        yield (k + 1) / len(lifts)
        if not todo:
            break


def _check_routes(scene, built, lift, routes, reasons):
    """Detect the poses of the ``built`` (run, route, lost ends) triples in one go; a route
    that clears (:func:`_out_of_lost_ends`) goes to ``routes``, else its run's reason (the
    worst pose) to ``reasons``."""
    T = np.vstack([b[1][0] for b in built])
    X = np.vstack([b[1][1] for b in built])
    rapid = np.concatenate([b[1][2] for b in built]) == MOVE_RAPID
    clr_r, names = np.empty(len(T)), np.empty(len(T), dtype=object)
    # on the rapids the flute does not cut: it counts against the target too
    for sel, strict in ((~rapid, False), (rapid, True)):
        if sel.any():
            det = scene.detect(T[sel], X[sel], flute_on_target=strict)
            clr_r[sel] = det.clearance
            names[sel] = [scene.obstacles.names[i] if i >= 0 else "an obstacle"
                          for i in det.obstacle]
    o = 0
    for r, res, lost in built:
        n = len(res[0])
        c = clr_r[o:o + n]
        keep = _out_of_lost_ends(c >= scene.safety, res[2], lost)
        if keep is not None:
            routes[r] = tuple(x[keep] for x in res) + (c[keep],)
        else:
            j = int(np.argmin(c))
            name = names[o + j]
            leg = {MOVE_RETRACT: "retract", MOVE_RAPID: "rapid",
                   MOVE_APPROACH: "approach"}[int(res[2][j])]
            how = (f"comes within {c[j]:.3f} mm of" if c[j] >= 0 else
                   f"runs {-c[j]:.3f} mm into")
            reasons[r] = (f"every route collides; on the highest clearance surface "
                          f"tried ({lift:.3f} mm above the linked one) the {leg} "
                          f"{how} '{name}' (ds {scene.safety:g} mm)")
        o += n


def _out_of_lost_ends(clear, moves, lost):
    """(k,) bool rows of a route to keep, or None when the route collides. Every row must
    clear, but for the retract out of (the approach into) a pass pose left unresolved
    (``lost`` = (before, after)): the tool there collides whatever axis it takes, so the
    straight retract along its axis starts colliding; its leading colliding rows are dropped
    (the retract goes straight to its first clear row, a move that starts in that pose's
    collision and belongs to the pose's unresolved range, as the motion out of an unresolved
    pose on a pass does), and so are the approach's trailing ones. Any other colliding row,
    or a retract / approach colliding after a clear row, and the route collides."""
    keep = np.ones(len(clear), bool)
    bad = ~clear
    if lost[0]:
        lead = np.cumprod(bad & (moves == MOVE_RETRACT)).astype(bool)
        if lead.any() and not lead.all():
            keep &= ~lead
    if lost[1]:
        tail = np.cumprod((bad & (moves == MOVE_APPROACH))[::-1])[::-1].astype(bool)
        if tail.any() and not tail.all():
            keep &= ~tail
    return keep if np.all(clear[keep]) else None


def _spliced(program: Program, runs, routes, st, rot):
    """The new program: rerouted runs replaced by their routes, the others kept; returns
    (Program, run → its first row in the new program)."""
    m = len(program)
    clr = np.asarray(program.clearance, dtype=np.float64)
    cur, idx = np.asarray(program.curve), np.asarray(program.index)
    parts = {k: [] for k in ("tip", "axis", "move", "curve", "index", "flags", "st", "clr",
                             "rot")}

    def keep(a, b):
        for key, arr in (("tip", program.tip), ("axis", program.axis), ("move", program.move),
                         ("curve", cur), ("index", idx), ("flags", program.flags),
                         ("st", st), ("clr", clr), ("rot", rot)):
            parts[key].append(np.asarray(arr)[a:b])

    pos = 0
    new_start = {}
    out_len = 0
    for r in runs:
        keep(pos, r.start)
        out_len += r.start - pos
        new_start[r] = out_len
        if r in routes:
            t, a, mv, a0, c = routes[r]
            k = len(t)
            parts["tip"].append(t)
            parts["axis"].append(a)
            parts["move"].append(mv)
            parts["curve"].append(np.full(k, -1, np.int64))
            parts["index"].append(np.full(k, -1, np.int64))
            parts["flags"].append(np.zeros(k, np.uint8))
            parts["st"].append(np.full(k, STATUS_CORRECTED, np.int8))
            parts["clr"].append(c)
            parts["rot"].append(angle_between(a, a0))
            out_len += k
        else:
            keep(r.start, r.stop)
            out_len += r.stop - r.start
        pos = r.stop
    keep(pos, m)
    cat = {k: np.concatenate(v) if v else np.zeros(0) for k, v in parts.items()}
    move = cat["move"].astype(np.int8)
    for r in routes:  # a pass reached by a rerouted run is reached by an approach
        if r.after >= 0:
            move[new_start[r] + len(routes[r][0])] = MOVE_APPROACH
    out = replace(program, tip=np.asarray(cat["tip"], float).reshape(-1, 3),
                  axis=np.asarray(cat["axis"], float).reshape(-1, 3), move=move,
                  curve=cat["curve"].astype(np.int64), index=cat["index"].astype(np.int64),
                  flags=cat["flags"].astype(np.uint8),
                  collision_status=cat["st"].astype(np.int8), clearance=cat["clr"],
                  rotation_deg=np.degrees(cat["rot"]))
    return out, new_start
