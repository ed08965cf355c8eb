"""Linking: the order and direction of the passes, the spiral, and the moves between passes.

Two stages, around the orientation and cutter stages of the pipeline:

1. :func:`order_passes` — CC passes (mesh ∩ LMC, in order of s) → the cutting passes in
   machining order, each running in its cutting direction and starting where the previous
   one ended:

   * ``"oneway"`` — every pass in the same sense: the one that mills **climb** (or
     conventional, ``climb=False``) for a clockwise spindle (M03). The unmachined material is
     on the side of the next passes (the direction ``m`` of increasing s, or decreasing s when
     machining tip → hub); climb milling keeps it on the right of the feed, ``m · k > 0`` with
     ``k = f × n`` (the tooth then moves against the feed where it cuts). Closed loops start at
     the pose nearest the previous loop's start, so the step between them is a short link.
   * ``"zigzag"`` — alternate senses (climb, conventional, climb, …; the first as ``climb``
     says); open passes start at the end nearer the previous pass's end.
   * ``"spiral"`` — paper 002's continuous helical finishing: a full loop on the first curve,
     then one turn per pair of neighbouring curves i → i+1 that blends from curve i to curve
     i+1, then a full loop on the last curve — one continuous cut with no link inside. The
     pose at arc-length fraction u ∈ [0, 1] of turn i lies on the mesh **and** on the
     intermediate LMC ``s = s_i + u (s_{i+1} − s_i)``: it is found on the mesh path between
     the curve-i pose and its nearest point on curve i+1 (points of that segment projected onto
     the mesh, the ratio solved by regula falsi), so the tool never leaves the surface and the
     turn ends exactly on curve i+1 where the next turn starts — no plunge mark. The spiral
     pass carries every pose's ratio (``PassCurve.ratio``).

     Only levels made of exactly **one closed loop** can be spiralled. A level with an open
     curve (a single blade side, a hole cutting the band) or several curves ends the spiral:
     such levels are machined one-way with links, and a new spiral starts at the next run of
     two or more single-loop levels. So open curves always need links, even in spiral mode.

2. :func:`build_program` — the oriented passes (tips and axes known) → the :class:`~.toolpath.
   Program`: approach down the tool axis onto the first pose of a pass, cut (closed passes
   end with the closing cut), then either a **link** kept on the surface to the next pass
   when it starts within ``direct_link`` mm (projected onto the mesh, normals within 90°), or
   **retract** up the axis, **rapid** out to the clearance surface (radially, at constant z),
   along it (about the blisk axis) and back in above the next pass, and approach again.

The clearance surface is the cone ``r(z) = radius + slope (z − z0)`` about the blisk axis
(slope 0: a cylinder), outside the blades. Collision with the blades during rapids is not
checked here (wave 2: :mod:`.collision`).

Lengths mm, angles radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import BliskCamError, LinkError
from ..geometry.axis import Axis, meridional
from ..geometry.closest import segment_distance
from ..geometry.distance import NearestFaces
from ..geometry.mesh import TriMesh
from ..geometry.vectors import slerp
from ..part.cones import MorphingCones
from ..toolpath.types import (
    MOVE_APPROACH,
    MOVE_CUT,
    MOVE_LINK,
    MOVE_RAPID,
    MOVE_RETRACT,
    PassCurve,
    Program,
)
from .orientation import feed_directions
from .rapids import ProgramRows, clearance_point, via_axis_exits, via_clearance

__all__ = [
    "LINK_MODES",
    "Clearance",
    "LinkError",
    "LinkOptions",
    "SurfaceProjector",
    "build_program",
    "order_passes",
    "ratio_gradient",
]

LINK_MODES = ("oneway", "zigzag", "spiral")
ORDERS = ("hub_to_tip", "tip_to_hub")


@dataclass(frozen=True)
class Clearance:
    """The clearance surface: the cone ``r(z) = radius + slope · (z − z0)`` about the blisk axis
    (mm; slope dimensionless, 0 = a cylinder)."""

    radius: float
    z0: float = 0.0
    slope: float = 0.0

    def __post_init__(self):
        for name in ("radius", "z0", "slope"):
            if not math.isfinite(float(getattr(self, name))):
                raise LinkError(
                    f"clearance {name} must be a finite number, got {getattr(self, name)!r}"
                )
        if not float(self.radius) > 0:
            raise LinkError(f"clearance radius must be > 0 mm, got {self.radius}")

    def r_at(self, z):
        return float(self.radius) + float(self.slope) * (
            np.asarray(z, dtype=np.float64) - float(self.z0)
        )


@dataclass(frozen=True)
class LinkOptions:
    """How passes are ordered and linked.

    Attributes
    ----------
    mode : "oneway" | "zigzag" | "spiral"
    climb : bool — climb milling for a clockwise (M03) spindle; False = conventional
    order : "hub_to_tip" (s = 0 first) | "tip_to_hub"
    approach : float, mm — approach/retract distance along the tool axis (> 0)
    clearance : Clearance or None — None: a cylinder ``clearance_margin`` mm outside the
        largest radius of the passes and their approach points
    clearance_margin : float, mm (> 0)
    direct_link : float, mm, or None — largest gap bridged on the surface (default 2 × the
        tool radius); 0 = always through the clearance surface
    rapid_step : float, radians — angular step of rapids along the clearance surface
    link_step : float, mm — pose spacing of on-surface links
    chord, tool_radius : float, mm — chord tolerance and (ball-equivalent) radius the spiral
        blends are sampled for (as the forward step of :mod:`.sampling`)
    """

    mode: str = "oneway"
    climb: bool = True
    order: str = "hub_to_tip"
    approach: float = 2.0
    clearance: Clearance | None = None
    clearance_margin: float = 5.0
    direct_link: float | None = None
    rapid_step: float = math.radians(5.0)
    link_step: float = 0.25
    chord: float = 0.05
    tool_radius: float = 6.0

    def __post_init__(self):
        if self.mode not in LINK_MODES:
            raise LinkError(f"unknown link mode {self.mode!r}; use one of {', '.join(LINK_MODES)}")
        if self.order not in ORDERS:
            raise LinkError(
                f"unknown machining order {self.order!r}; use one of {', '.join(ORDERS)}"
            )
        for name in (
            "approach",
            "clearance_margin",
            "rapid_step",
            "link_step",
            "chord",
            "tool_radius",
        ):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise LinkError(
                    f"{name.replace('_', ' ')} must be a positive number, "
                    f"got {getattr(self, name)!r}"
                )
        if self.direct_link is not None:
            v = float(self.direct_link)
            if not (math.isfinite(v) and v >= 0):
                raise LinkError(f"direct link distance must be ≥ 0 mm, got {self.direct_link!r}")
        if self.rapid_step > math.pi / 4:
            raise LinkError("rapid step along the clearance surface must be ≤ 45°")


# ============================================================================ surface
class SurfaceProjector:
    """Exact closest points on the mesh with smooth normals, and points on an LMC level on
    the mesh between two given points (the spiral blend and on-surface links)."""

    def __init__(self, mesh: TriMesh, axis: Axis, morph: MorphingCones,
                 nearest: NearestFaces | None = None):
        # exact closest points without a whole-mesh tree: the generator projects only a few
        # clustered points (links, the spiral blend), so nothing is built until it does
        # (``nearest``: one made on ``mesh`` already, e.g. with its tree building alongside)
        self.mesh, self.axis, self.morph = mesh, axis, morph
        self._nf = NearestFaces(mesh) if nearest is None else nearest

    @property
    def nearest_faces(self) -> NearestFaces:
        """The exact closest-point search on the mesh (shared with the link check)."""
        return self._nf

    def project(self, points):
        """(q (k, 3), normal (k, 3), face (k,)) — closest points on the mesh, smooth normals."""
        q, face, bary = self._nf.query(points)
        return q, self.mesh.interpolate_normals(face, bary), face

    def ratio(self, points):
        return self.morph.ratio_of_points(points, self.axis)

    def on_level(self, A, s_target, *, iters: int = 20, tol: float = 1e-11):
        """Points on the mesh with morph ratio ``s_target`` reached from A by walking across
        the levels.

        Projected Newton steps along the surface gradient of the ratio:
        ``p ← project(p + (s_t − s(p)) g_t / |g_t|²)``, g_t the gradient of s (a function of
        (r, z)) projected on the tangent plane. The walk runs across the LMCs, never along
        them, so neighbouring start points give neighbouring results (no jumps across a thin
        edge the way nearest points on another curve can).

        Parameters
        ----------
        A : (k, 3) mm — start points (near the mesh)
        s_target : (k,) — ratios to reach

        Returns
        -------
        q (k, 3), normal (k, 3), face (k,), ratio (k,) — ``ratio`` is the true ratio of q
        (equal to ``s_target`` to ``tol`` where the walk converged)
        """
        st = np.asarray(s_target, dtype=np.float64)
        q, nrm, face = self.project(np.asarray(A, dtype=np.float64))
        r = self.ratio(q)
        active = np.abs(r - st) > tol
        for _ in range(iters):
            idx = np.nonzero(active)[0]
            if len(idx) == 0:
                break
            g = ratio_gradient(q[idx], self.morph, self.axis)
            n = nrm[idx]
            gt = g - np.einsum("ij,ij->i", g, n)[:, None] * n
            g2 = np.einsum("ij,ij->i", gt, gt)
            step = ((st[idx] - r[idx]) / np.where(g2 > 0, g2, np.inf))[:, None] * gt
            qq, nn, ff = self.project(q[idx] + step)
            rr = self.ratio(qq)
            # accept only improving steps (a projection may fall onto another sheet)
            better = np.abs(rr - st[idx]) < np.abs(r[idx] - st[idx])
            j = idx[better]
            q[j], nrm[j], face[j], r[j] = qq[better], nn[better], ff[better], rr[better]
            active[idx[~better]] = False
            active[j] = np.abs(r[j] - st[j]) > tol
        return q, nrm, face, r


def ratio_gradient(points, morph: MorphingCones, axis: Axis, h: float = 1e-3):
    """(k, 3) gradient (1/mm) of the morph ratio at points, by central differences."""
    P = np.asarray(points, dtype=np.float64)
    g = np.empty_like(P)
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        g[:, j] = (morph.ratio_of_points(P + e, axis) - morph.ratio_of_points(P - e, axis)) / (
            2 * h
        )
    return g


# ============================================================================ ordering
def _reverse(c: PassCurve) -> PassCurve:
    """The same pass run the other way (a closed loop keeps its start pose)."""
    k = len(c.cc)
    idx = (-np.arange(k)) % k if c.closed else np.arange(k)[::-1]
    return _take(c, idx)


def _take(c: PassCurve, idx) -> PassCurve:
    face = c.face[idx] if len(c.face) == len(c.cc) else c.face
    return PassCurve(
        s=c.s,
        closed=c.closed,
        cc=c.cc[idx],
        normal=c.normal[idx],
        tip=c.tip[idx],
        axis=c.axis[idx],
        face=face,
        move=c.move[idx],
        flags=c.flags[idx],
        ratio=None if c.ratio is None else c.ratio[idx],
    )


def _rotate(c: PassCurve, start: int) -> PassCurve:
    return _take(c, np.roll(np.arange(len(c.cc)), -int(start)))


def _climb_sense(c: PassCurve, morph, axis, toward_tip: bool) -> float:
    """Mean of m·k over the poses (> 0: climb for M03), m the unit direction toward the
    unmachined material (increasing s when machining hub → tip)."""
    f = feed_directions(c.cc, c.normal, c.closed)
    return float(np.mean(_climb_figures(c.cc, c.normal, f, morph, axis, toward_tip)))


def _climb_figures(cc, n, f, morph, axis, toward_tip: bool):
    """(k,) m·k of poses with contacts ``cc``, unit normals ``n`` and feed directions ``f``
    (k, 3): k = f × n, m the unit direction toward the unmachined material in the tangent
    plane (each row from its own pose alone)."""
    k = np.cross(f, n)
    g = ratio_gradient(cc, morph, axis)
    m = g - np.einsum("ij,ij->i", g, n)[:, None] * n
    m /= np.maximum(np.linalg.norm(m, axis=1), 1e-300)[:, None]
    if not toward_tip:
        m = -m
    return np.einsum("ij,ij->i", m, k)


def _climb_senses(curves, morph, axis, toward_tip: bool) -> dict:
    """{id(curve): :func:`_climb_sense`} of the passes, their poses' figures computed at
    once (one numpy call each instead of ~40 per pass) and each pass's mean of its own —
    the same floats as pass by pass, for a morph whose ratio is pointwise in closed form
    (:class:`~..part.cones.MorphingCones`); {} for any other (each pass then on its own)."""
    if not isinstance(morph, MorphingCones) or not curves:
        return {}
    try:
        f = np.vstack([feed_directions(c.cc, c.normal, c.closed) for c in curves])
    except BliskCamError:
        return {}  # raised again where that pass is placed, as pass by pass
    v = _climb_figures(np.vstack([c.cc for c in curves]), np.vstack([c.normal for c in curves]),
                       f, morph, axis, toward_tip)
    out, a = {}, 0
    for c in curves:
        b = a + len(c.cc)
        out[id(c)] = float(np.mean(v[a:b]))
        a = b
    return out


def _orient_sense(c, want_positive: bool, morph, axis, toward_tip, senses=None):
    """``c`` or its reverse, whichever mills climb (``want_positive``) or conventional;
    ``senses``: :func:`_climb_senses` of the passes (else ``c``'s own is computed)."""
    sense = senses.get(id(c)) if senses else None
    if sense is None:
        sense = _climb_sense(c, morph, axis, toward_tip)
    return c if (sense >= 0) == want_positive else _reverse(c)


def _nearest_pose(c: PassCurve, p) -> int:
    return int(np.argmin(np.linalg.norm(c.cc - p, axis=1)))


def _levels(curves):
    """Group passes into levels (consecutive equal s), keeping order."""
    out = []
    for c in curves:
        if out and out[-1][0].s == c.s:
            out[-1].append(c)
        else:
            out.append([c])
    return out


def order_passes(
    curves,
    opts: LinkOptions,
    morph: MorphingCones,
    axis: Axis,
    projector: SurfaceProjector | None = None,
) -> list[PassCurve]:
    """The cutting passes in machining order and direction (see the module docstring).

    Parameters
    ----------
    curves : list of PassCurve — CC passes in order of s (as :mod:`.passes` makes them)
    opts : LinkOptions
    morph, axis : the LMC family and the blisk axis
    projector : SurfaceProjector — needed for the spiral

    Returns
    -------
    list of PassCurve (new objects; tips and axes are copies until oriented)
    """
    levels = _levels([c for c in curves if len(c.cc) >= 2])
    if not levels:
        raise LinkError("no pass with two or more poses to link")
    toward_tip = opts.order == "hub_to_tip"
    if not toward_tip:
        levels = levels[::-1]
    out: list[PassCurve] = []
    prev_end = None
    closed_count = 0
    senses = _climb_senses([c for lv in levels for c in lv], morph, axis, toward_tip)

    def place(c: PassCurve, sense_positive: bool | None):
        nonlocal prev_end
        if c.closed:
            if sense_positive is not None:
                c = _orient_sense(c, sense_positive, morph, axis, toward_tip, senses)
            if prev_end is not None:
                c = _rotate(c, _nearest_pose(c, prev_end))
            prev_end = c.cc[0]
        else:
            if sense_positive is not None:
                c = _orient_sense(c, sense_positive, morph, axis, toward_tip, senses)
            else:  # zig-zag: start at the end nearer the previous end
                if prev_end is not None and np.linalg.norm(c.cc[-1] - prev_end) < np.linalg.norm(
                    c.cc[0] - prev_end
                ):
                    c = _reverse(c)
            prev_end = c.cc[-1]
        out.append(c)

    def by_distance(level):
        rest = list(level)
        while rest:
            if prev_end is None:
                yield rest.pop(0)
            else:
                d = [np.min(np.linalg.norm(c.cc - prev_end, axis=1)) for c in rest]
                yield rest.pop(int(np.argmin(d)))

    if opts.mode == "spiral":
        single = [len(lv) == 1 and lv[0].closed for lv in levels]
        i = 0
        while i < len(levels):
            j = i
            while j < len(levels) and single[j]:
                j += 1
            if j - i >= 2:
                loops = []
                for lv in levels[i:j]:
                    c = _orient_sense(lv[0], opts.climb, morph, axis, toward_tip, senses)
                    if loops:
                        c = _rotate(c, _nearest_pose(c, loops[-1].cc[0]))
                    elif prev_end is not None:
                        c = _rotate(c, _nearest_pose(c, prev_end))
                    loops.append(c)
                if projector is None:
                    raise LinkError(
                        "the spiral needs the mesh (a SurfaceProjector) to blend the turns"
                    )
                sp = _spiral(loops, projector, opts.chord, opts.tool_radius)
                out.append(sp)
                prev_end = sp.cc[-1]
                i = j
            else:
                for c in by_distance(levels[i]):
                    place(c, opts.climb)
                i += 1
        return out

    for lv in levels:
        for c in by_distance(lv):
            if opts.mode == "oneway":
                place(c, opts.climb)
            else:
                if c.closed:
                    place(c, opts.climb if closed_count % 2 == 0 else not opts.climb)
                    closed_count += 1
                else:
                    place(c, opts.climb if not out else None)
    return out


def _loop_at(loop: PassCurve, u):
    """Points and normals of the closed polyline ``loop`` at arc-length fractions u (q,)."""
    P = np.vstack([loop.cc, loop.cc[:1]])
    N = np.vstack([loop.normal, loop.normal[:1]])
    L = np.linalg.norm(np.diff(P, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(L)])
    x = np.asarray(u, dtype=np.float64) * cum[-1]
    seg = np.clip(np.searchsorted(cum, x, side="right") - 1, 0, len(L) - 1)
    w = ((x - cum[seg]) / np.where(L[seg] > 0, L[seg], 1.0))[:, None]
    n = N[seg] + w * (N[seg + 1] - N[seg])
    return P[seg] + w * (P[seg + 1] - P[seg]), n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[
        :, None
    ]


def _spiral(
    loops, projector: SurfaceProjector, chord: float, rho: float, rounds: int = 12
) -> PassCurve:
    """One continuous pass: loop 0, the blended turns 0→1, …, (n−2)→(n−1), loop n−1.

    Turn i has a pose at every pose fraction of loop i, and segments are bisected (in the
    fraction) until the blend point at the middle lies within ``chord``/2 of the CC segment and
    3 chord/4 of the ball-centre segment (ball of radius ``rho``) and the normal turns by at
    most the forward step's ``2 acos(1 − chord / 4ρ)`` (:mod:`.sampling`): the blend runs
    over different parts of the surface than loop i, so it needs its own chord control."""
    max_turn = 2.0 * math.acos(max(-1.0, 1.0 - chord / (4.0 * rho)))
    loops = list(loops)
    for i in range(len(loops) - 1):
        # turn i ends where the walk from loop i's start lands on level i+1: loop i+1 starts there
        w, wn, wf, _ = projector.on_level(loops[i].cc[:1], np.array([loops[i + 1].s]))
        loops[i + 1] = _start_at(loops[i + 1], w[0], wn[0], int(wf[0]))
    turns = list(zip(loops[:-1], loops[1:], strict=True))
    # first every pose fraction of loop i, then bisection of the segments that fail
    U, Q, N, F, R = _turn_poses(turns, projector)
    _refine_turns(turns, projector, U, Q, N, F, R, chord, rho, max_turn, rounds)
    return _joined_pass(loops, Q, N, F, R)


def _turn_poses(turns, projector: SurfaceProjector):
    """Per turn (loop a → loop b), the blend at every pose fraction of a: lists of fractions
    U (k,), CC points Q (k, 3), normals N (k, 3), faces F (k,) and ratios R (k,)."""
    U, Q, N, F, R = [], [], [], [], []
    As, Ts = [], []
    for a, b in turns:
        A = np.vstack([a.cc, a.cc[:1]])
        L = np.linalg.norm(np.diff(A, axis=0), axis=1)
        u = np.concatenate([[0.0], np.cumsum(L)]) / max(L.sum(), 1e-300)
        u[-1] = 1.0
        U.append(u)
        As.append(A)
        Ts.append(a.s + u * (b.s - a.s))
    q, n, f, r = projector.on_level(np.vstack(As), np.concatenate(Ts))
    off = 0
    for (a, b), u in zip(turns, U, strict=True):
        m = len(u)
        qq, nn, ff, rr = (
            q[off : off + m].copy(),
            n[off : off + m].copy(),
            f[off : off + m].copy(),
            r[off : off + m].copy(),
        )
        off += m
        # exact ends: the loops' own first poses
        qq[0], nn[0], rr[0], qq[-1], nn[-1], rr[-1] = (
            a.cc[0],
            a.normal[0],
            a.s,
            b.cc[0],
            b.normal[0],
            b.s,
        )
        Q.append(qq)
        N.append(nn)
        F.append(ff)
        R.append(rr)
    return U, Q, N, F, R


def _refine_turns(turns, projector: SurfaceProjector, U, Q, N, F, R, chord, rho, max_turn,
                  rounds):
    """Bisect (in place, up to ``rounds`` times) the turns' segments whose middle blend point
    strays from the segment (CC: chord/2, ball centre: 3 chord/4) or whose normal turns
    by more than ``max_turn``."""
    pending = [np.arange(len(u) - 1) for u in U]  # segment j = (u_j, u_j+1) to test
    for _ in range(rounds):
        if not any(len(p) for p in pending):
            break
        As, Ts, own = [], [], []
        for i, ((a, b), p) in enumerate(zip(turns, pending, strict=True)):
            um = 0.5 * (U[i][p] + U[i][p + 1])
            As.append(_loop_at(a, um)[0])
            Ts.append(a.s + um * (b.s - a.s))
            own.append(np.full(len(p), i))
        q, n, f, r = projector.on_level(np.vstack(As), np.concatenate(Ts))
        own = np.concatenate(own)
        for i in range(len(turns)):
            sel = own == i
            p = pending[i]
            if len(p) == 0:
                continue
            qm, nm = q[sel], n[sel]
            q0, q1, n0, n1 = Q[i][p], Q[i][p + 1], N[i][p], N[i][p + 1]
            dev = segment_distance(qm, q0, q1)
            devc = segment_distance(qm + rho * nm, q0 + rho * n0, q1 + rho * n1)
            turn = np.arccos(np.clip(np.einsum("ij,ij->i", n0, n1), -1.0, 1.0))
            gap = U[i][p + 1] - U[i][p]
            bad = ((dev > 0.5 * chord) | (devc > 0.75 * chord) | (turn > max_turn)) & (gap > 1e-9)
            um = 0.5 * (U[i][p] + U[i][p + 1])
            ins = p[bad] + 1
            U[i] = np.insert(U[i], ins, um[bad])
            Q[i] = np.insert(Q[i], ins, qm[bad], axis=0)
            N[i] = np.insert(N[i], ins, nm[bad], axis=0)
            F[i] = np.insert(F[i], ins, f[sel][bad])
            R[i] = np.insert(R[i], ins, r[sel][bad])
            # new indices of the halves of the failed segments
            shift = np.arange(int(bad.sum()))
            lo = p[bad] + shift
            pending[i] = np.sort(np.concatenate([lo, lo + 1]))


def _joined_pass(loops, Q, N, F, R) -> PassCurve:
    """The spiral as one open pass: loop 0, the turns, loop n−1 closed on its start,
    repeated points dropped."""
    cc, nn, ff, rr = (
        [loops[0].cc],
        [loops[0].normal],
        [_faces(loops[0])],
        [np.full(len(loops[0].cc), loops[0].s)],
    )
    for i in range(len(Q)):  # the turns
        cc.append(Q[i])
        nn.append(N[i])
        ff.append(F[i])
        rr.append(R[i])
    last = loops[-1]
    cc += [last.cc, last.cc[:1]]
    nn += [last.normal, last.normal[:1]]
    ff += [_faces(last), _faces(last)[:1]]
    rr += [np.full(len(last.cc), last.s), np.array([last.s])]
    CC, NN, FF, RR = np.vstack(cc), np.vstack(nn), np.concatenate(ff), np.concatenate(rr)
    keep = np.ones(len(CC), bool)
    keep[1:] = np.linalg.norm(np.diff(CC, axis=0), axis=1) > 1e-9
    CC, NN, FF, RR = CC[keep], NN[keep], FF[keep], RR[keep]
    return PassCurve(
        s=float(loops[0].s),
        closed=False,
        cc=CC,
        normal=NN,
        tip=CC.copy(),
        axis=NN.copy(),
        face=FF,
        ratio=RR,
    )


def _start_at(loop: PassCurve, w, wn, wf) -> PassCurve:
    """The closed ``loop`` with the point ``w`` (on the loop's curve) inserted on the nearest
    segment and made its first pose."""
    P = loop.cc
    Q = np.roll(P, -1, axis=0)
    d = Q - P
    t = np.clip(
        np.einsum("ij,ij->i", w - P, d) / np.maximum(np.einsum("ij,ij->i", d, d), 1e-300), 0, 1
    )
    dist = np.linalg.norm(P + t[:, None] * d - w, axis=1)
    j = int(np.argmin(dist))
    near = np.linalg.norm(P - w, axis=1)
    if near.min() <= 1e-9:
        return _rotate(loop, int(np.argmin(near)))
    c = _rotate(loop, j + 1)  # w goes before the old pose j+1
    face = _faces(c)
    return PassCurve(
        s=c.s,
        closed=True,
        cc=np.vstack([w[None], c.cc]),
        normal=np.vstack([wn[None], c.normal]),
        tip=np.vstack([w[None], c.tip]),
        axis=np.vstack([wn[None], c.axis]),
        face=np.concatenate([[wf], face]),
        move=np.concatenate([[c.move[0]], c.move]),
        flags=np.concatenate([[0], c.flags]),
        ratio=None if c.ratio is None else np.concatenate([[c.s], c.ratio]),
    )


def _faces(c: PassCurve):
    return c.face if len(c.face) == len(c.cc) else np.full(len(c.cc), -1, dtype=np.int64)


#: the approach point lies the approach distance off the surface: along a tool axis at angle
#: φ from the surface normal that is d / cos φ, up to this many times d (φ ≤ 76°)
APPROACH_STRETCH_MAX = 4.0


def approach_length(c: PassCurve, j: int, d_app: float) -> float:
    """Length (mm) along the tool axis from pose ``j`` of ``c`` to its approach/retract point:
    ``d_app`` off the surface (the normal), d_app / cos φ with φ the axis' angle from the
    normal, at most :data:`APPROACH_STRETCH_MAX` × d_app. With the axis 75° from the normal a
    point d_app along the axis is only 0.26 d_app off the surface: the rapid down to it swept
    the cutter through the stock a roughing pass leaves (1.7 mm deep in the job simulation)."""
    cos = float(np.dot(c.axis[j], c.normal[j]))
    return float(d_app) / max(cos, 1.0 / APPROACH_STRETCH_MAX)


def _clearance_of(curves, opts: LinkOptions, axis: Axis, d_app: float) -> Clearance:
    """The clearance surface of ``opts`` (default: the cylinder just outside every tip and
    approach point); raises LinkError when it is not outside the approach points."""
    ends = np.vstack(
        [np.vstack([c.tip[[0, -1]], c.tip[[0, -1]] + np.array(
            [[approach_length(c, 0, d_app)], [approach_length(c, len(c) - 1, d_app)]])
            * c.axis[[0, -1]]]) for c in curves]
    )
    all_tips = np.vstack([c.tip for c in curves])
    if opts.clearance is None:
        r_all, _ = meridional(np.vstack([all_tips, ends]), axis)
        clear = Clearance(float(r_all.max()) + float(opts.clearance_margin))
    else:
        clear = opts.clearance
    r_e, z_e = meridional(ends, axis)
    if np.any(clear.r_at(z_e) <= r_e):
        raise LinkError(
            f"the clearance surface (radius {clear.radius:g} mm, slope {clear.slope:g}) "
            "is not outside "
            f"the passes' approach points (up to r = {r_e.max():.3f} mm); raise its radius"
        )
    return clear


def build_program(
    curves,
    opts: LinkOptions,
    axis: Axis,
    *,
    tool_radius: float,
    projector: SurfaceProjector | None = None,
    cl_points=None,
    link_check=None,
) -> Program:
    """Link the oriented passes into a :class:`~.toolpath.Program`.

    Parameters
    ----------
    curves : list of PassCurve — in machining order, with final tips and axes
    opts : LinkOptions
    axis : Axis — the blisk axis
    tool_radius : float, mm — for the default direct-link distance
    projector : SurfaceProjector — needed for on-surface links (else always via clearance)
    cl_points : callable (cc, normal, axis) → tip — the cutter's CC → CL (on-surface links)
    link_check : :class:`.link_check.SweptLinkCheck` or None — an on-surface link whose swept
        cutter cuts the part deeper than its tolerance goes through the clearance surface
        instead (retract, rapids, approach) and is counted there (``None``: not checked)

    Raises
    ------
    LinkError when the clearance surface is not outside the passes' approach points.
    """
    if not curves:
        raise LinkError("nothing to link: no passes")
    direct = 2.0 * float(tool_radius) if opts.direct_link is None else float(opts.direct_link)
    if projector is None or cl_points is None:
        direct = 0.0
    d_app = float(opts.approach)
    clear = _clearance_of(curves, opts, axis, d_app)
    rows = ProgramRows()
    prev = None
    for ci, c in enumerate(curves):
        idx = np.arange(len(c.cc))
        if c.closed:
            idx = np.append(idx, 0)
        t0, a0 = c.tip[0], c.axis[0]
        first_move = MOVE_APPROACH
        if prev is None:
            e0 = t0 + approach_length(c, 0, d_app) * a0
            rows.extend(_checked_route(
                link_check, None, None, t0, a0,
                lambda r, along, e0=e0, a0=a0: via_clearance(
                    r, clear, axis, opts.rapid_step, e0, a0, e0, a0, first=True,
                    along_axis=along)))
        else:
            pc, pj = prev
            link = None
            if direct > 0 and np.linalg.norm(c.cc[0] - pc.cc[pj]) <= direct:
                link = _surface_link(
                    pc.cc[pj],
                    pc.normal[pj],
                    pc.axis[pj],
                    c.cc[0],
                    c.normal[0],
                    a0,
                    projector,
                    cl_points,
                    opts.link_step,
                )
            if link is not None and link_check is not None:
                depth = link_check.depth(
                    np.vstack([pc.tip[pj][None], link[0], t0[None]]),
                    np.vstack([pc.axis[pj][None], link[1], a0[None]]),
                )
                if depth > link_check.tolerance:
                    air, left = _air_route(link_check, clear, axis, opts.rapid_step,
                                           d_app, pc.tip[pj], pc.axis[pj], t0, a0)
                    link_check.reroute(depth, left)
                    rows.extend(air)
                    link = False
            if link is False:  # re-routed through the air: approach the pass
                pass
            elif link is not None:
                lt, la = link
                if len(lt):
                    rows.emit(lt, la, MOVE_LINK)
                first_move = MOVE_LINK
            else:
                pt, pa = pc.tip[pj], pc.axis[pj]
                up = pt + approach_length(pc, pj, d_app) * pa
                down = t0 + approach_length(c, 0, d_app) * a0

                def route(r, along, up=up, pa=pa, down=down, a0=a0):
                    r.emit(up, pa, MOVE_RETRACT)
                    via_clearance(r, clear, axis, opts.rapid_step, up, pa, down, a0,
                                  along_axis=along)

                rows.extend(_checked_route(link_check, pt, pa, t0, a0, route))
        mv = np.full(len(idx), MOVE_CUT, dtype=np.int8)
        mv[0] = first_move
        rows.emit(c.tip[idx], c.axis[idx], mv, ci, idx, c.flags[idx])
        prev = (c, int(idx[-1]))
    pc, pj = prev
    pt, pa = pc.tip[pj], pc.axis[pj]
    up = pt + approach_length(pc, pj, d_app) * pa

    def leave(r, along):
        r.emit(up, pa, MOVE_RETRACT)
        r.emit(clearance_point(up, pa, clear, axis, along), pa, MOVE_RAPID)

    rows.extend(_checked_route(link_check, pt, pa, None, None, leave))
    return rows.program()


def _checked_route(link_check, pt, pa, t0, a0, build) -> ProgramRows:
    """The rows of a planned route via the clearance surface from pose (pt, pa) (None: the
    program's first entry, from the route's own start) to pose (t0, a0) (None: the program's
    last exit),
    ``build(rows, along_axis)`` writing them: out and in along the tool axes
    (:func:`.rapids.clearance_point`); when that route's swept cutter cuts the blade deeper
    than the link tolerance (a leaning blade over the tool's line), the radial one if it
    cuts no deeper than the tolerance. When both cut, the first is kept (the check's depth of a
    deep cut on an open mesh is no measure to compare two routes by: a ball centre beyond a
    free edge reads as inside), counted and reported (:meth:`LinkCheck.rapids_cut`; collision
    avoidance re-routes it)."""
    first = None
    for along in (True, False):
        r = ProgramRows()
        build(r, along)
        if link_check is None:
            return r
        d = _route_depth(link_check, r, pt, pa, t0, a0)
        if d <= link_check.tolerance:
            return r
        first = first or (r, d)
    link_check.rapids_cut(first[1])
    return first[0]


#: lifts tried (× the approach distance) for a link re-routed through the air, before the
#: clearance surface
AIR_LIFTS = (1.0, 2.0, 4.0, 8.0)


def _route_depth(link_check, r: ProgramRows, pt, pa, t0, a0) -> float:
    """How deep (mm) the cutter cuts moving from (pt, pa) through the rows ``r`` onto
    (t0, a0); pt / t0 None: from the rows' first / to their last row."""
    head_t, head_a = ([], []) if pt is None else ([pt[None]], [pa[None]])
    tail_t, tail_a = ([], []) if t0 is None else ([t0[None]], [a0[None]])
    T = np.vstack([*head_t, *r.tips, *tail_t])
    A = np.vstack([*head_a, *[np.broadcast_to(a, t.shape) for a, t in zip(r.axs, r.tips,
                                                                          strict=True)],
                   *tail_a])
    return link_check.depth(T, A)


def _air_route(link_check, clear, axis, rapid_step, d_app, pt, pa, t0, a0):
    """(rows, depth) — the moves from pose (pt, pa) to above (t0, a0) for a link that may not
    stay on the surface: retract up ``pa`` by h, one rapid straight to ``t0 + h a0`` (the
    axis interpolated as the check samples it), the pass then approached down ``a0``;
    h = ``AIR_LIFTS`` × the approach distance in turn, then up the tool axes to the clearance
    surface (:func:`via_axis_exits`), then the route via the clearance surface. The first
    route whose swept cutter (``link_check``, approach included) cuts no deeper than the
    tolerance is taken, else the one cutting least (``depth`` its cut, mm)."""
    best = None
    for k in (*AIR_LIFTS, "exit", None):
        r = ProgramRows()
        if k == "exit":
            if not via_axis_exits(r, clear, axis, rapid_step, d_app, pt, pa, t0, a0):
                continue
        elif k is None:
            r.emit(pt + d_app * pa, pa, MOVE_RETRACT)
            via_clearance(r, clear, axis, rapid_step, pt + d_app * pa, pa, t0 + d_app * a0, a0)
        else:
            h = k * d_app
            r.emit(pt + h * pa, pa, MOVE_RETRACT)
            # one rapid row: consecutive rapid rows are read back as the clearance surface
            # (:func:`..collision.reroute.clearance_surface`)
            r.emit(t0 + h * a0, a0, MOVE_RAPID)
        d = _route_depth(link_check, r, pt, pa, t0, a0)
        if best is None or d < best[1]:
            best = (r, d)
        if d <= link_check.tolerance:
            break
    return best


def _surface_link(p0, n0, a0, p1, n1, a1, projector, cl_points, step):
    """Interior poses of an on-surface link p0 → p1 (tips (j, 3), axes (j, 3)), or None when
    the surface between turns by 90° or more (the link would cross an edge)."""
    L = float(np.linalg.norm(p1 - p0))
    n = max(1, int(math.ceil(L / step)))
    t = np.arange(1, n) / n
    if len(t) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3))
    q, nrm, _ = projector.project(p0 + t[:, None] * (p1 - p0))
    if np.any(nrm @ n0 <= 0) or np.any(nrm @ n1 <= 0):
        return None
    a = slerp(a0, a1, t)
    if np.any(np.einsum("ij,ij->i", a, nrm) <= 0.05):
        return None
    return cl_points(q, nrm, a), a
