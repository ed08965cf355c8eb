"""Depth per cut from a scallop height: levels spaced so that the step a level leaves on the
blade walls stays within a height h.

**The step cusp.** Two consecutive levels leave a staircase on a wall. Locally the wall is a
plane (its offset by the allowance, which the tool touches), the two tools are the same solid
of revolution about the axis a, both touching that plane, the lower one moved along the wall
by D. The nearest points of a solid of revolution to a plane lie in the plane through its
axis along the plane's normal n, so the question is two-dimensional: in that section the
tool's outline is the bottom (a line ⊥ a, half-length e = R − r), the corner arc of radius r
and the side (a line ∥ a); it touches the wall's line at the point of the arc whose normal is
−n, at the angle ψ from the side end (sin ψ = |n · a|: ψ = 0 a wall parallel to the axis,
90° a floor). The upper tool's outline runs from the contact toward its bottom (an arc of
90° − ψ, then the bottom's line), the lower tool's toward its side (an arc of ψ, then the
side's line). Each is, over the wall, a convex increasing height G(x) at the distance x from
its contact along the wall:

    G(x; U) = r − √(r² − x²)                         x ≤ r sin U   (on the arc)
            = r (1 − cos U) + (x − r sin U) tan U    beyond        (on the line at angle U)

with U = 90° − ψ for the upper tool (for a ball, whose arc goes on through the tip, U = 90°
with the arc's end vertical), U = ψ for the lower. The cusp is where the two meet:
G(x; 90° − ψ) = G(d − x; ψ), d = |D|. Inverted, the largest d that keeps the cusp at most h is

    d_max(h) = G⁻¹(h; 90° − ψ) + G⁻¹(h; ψ),
    G⁻¹(y; U) = √(r² − (r − y)²)                        y ≤ r (1 − cos U)
              = r sin U + (y − r (1 − cos U)) / tan U   beyond,

closed form. Where both meet on the arcs this is the two-circle (ball scallop) formula
h = r − √(r² − d²/4) (the scallop between two balls on a plane, paper 001's Eq. 13 with an
infinite surface radius); a sharp corner (r = 0) gives d = h / (sin ψ cos ψ), i.e. the
staircase's corner s |n · a| = h (s = d cos ψ the step along the axis) — the level step cusp
the roughing's docstring bounds with. The lines are taken as unbounded (the bottom's far
corner and the flute's top only rise faster), so d_max is on the safe side.

**From the radial step to D.** Levels are radial offsets Δr of the tip surface. D lies in the
wall's plane and in the section (∥ a − (n·a) n), so D · u = Δr (u the radial direction) gives
d = Δr √(1 − c²) / ((a − c n) · u), c = n · a; for a radial axis d = Δr / cos ψ.

**Levels.** The wall samples are the blade mesh's vertices with their normals (both sides of
the blade face a channel; blade 1 is blade 0 turned by the pitch), on the walls: the normal
within 60° of the tangential plane (steeper than 30° from the hub; the floor band's surface
driven passes take the rest of the fillet). Each sample's tool axes are the radial direction
tilted by the lead and by side tilts spanning the range the levels may use at its place
(``tilt_range``); its largest radial step Δr_max is the least over them. From the level the
stepping starts at (the floor for ``from-hub``, the shroud otherwise) each next level is the
largest step ≤ the cap (the flute length or a maximum depth per cut) such that every sample
between the two levels has Δr(z) ≤ Δr_max: the worst point of the band decides, so the step
varies with the walls' slope along the channel and with the height. ``morph`` steps the
morph parameter σ (r = f + σ (t − f)), the radial step at a station then (t − f) Δσ.
Units mm, radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BliskCamError, ToolError
from ..geometry.axis import Axis
from ..geometry.mesh import TriMesh
from ..part.model import theta_about
from ..tool.cutter import Cutter
from .axis import mean_camber_lean, tilted_axes
from .levels import LEVEL_MODES, Level, level_radii

__all__ = ["WALL_SLOPE", "channel_levels", "check_depth_options", "cusp_of_step", "fillet_band",
           "radial_step_limit", "sample_limits", "scallop_levels", "step_for_scallop",
           "wall_samples"]

#: the walls: blade points whose normal lies within this angle of the tangential plane
WALL_SLOPE = math.radians(60.0)
#: the least step between levels (mm) however steep the worst sample asks
MIN_STEP = 0.05


def _ginv(y, r, U):
    """G⁻¹(y; U) of the module docstring (arrays broadcast): the distance along the wall from
    the contact at which the outline (corner radius ``r``, end angle ``U`` rad) is ``y`` mm
    above the wall; +inf where it never is (U = 0: the side's line lies on the wall)."""
    y, r, U = np.broadcast_arrays(*(np.asarray(v, float) for v in (y, r, U)))
    Uc = np.minimum(U, 0.5 * math.pi)
    on_arc = y <= r * (1.0 - np.cos(Uc))
    arc = np.sqrt(np.maximum(r * r - (r - np.minimum(y, r)) ** 2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        line = r * np.sin(Uc) + (y - r * (1.0 - np.cos(Uc))) / np.tan(Uc)
    line = np.where(Uc >= 0.5 * math.pi - 1e-12, r, line)  # a vertical end: x stays r
    line = np.where(Uc <= 1e-12, np.inf, line)
    return np.where(on_arc, arc, line)


def step_for_scallop(h, psi, r: float, ball: bool):
    """(…) the largest distance d (mm) along a wall between the contacts of two tools of
    corner radius ``r`` whose outlines then meet at most ``h`` mm above it (module
    docstring), at the contact angle ``psi`` (rad, 0 a wall parallel to the axis); ``ball``
    the arc going on through the tip (no bottom line)."""
    psi = np.clip(np.asarray(psi, float), 0.0, 0.5 * math.pi)
    upper = 0.5 * math.pi - psi + (0.5 * math.pi if ball else 0.0)
    return _ginv(h, r, upper) + _ginv(h, r, psi)


def _g(x, r, U):
    """G(x; U) of the module docstring (the forward height)."""
    x, r, U = np.broadcast_arrays(*(np.asarray(v, float) for v in (x, r, U)))
    Uc = np.minimum(U, 0.5 * math.pi)
    xa = r * np.sin(Uc)
    arc = r - np.sqrt(np.maximum(r * r - np.minimum(x, r) ** 2, 0.0))
    line = r * (1.0 - np.cos(Uc)) + (x - xa) * np.tan(np.minimum(Uc, 0.5 * math.pi - 1e-9))
    line = np.where(Uc >= 0.5 * math.pi - 1e-12, np.inf, line)
    return np.where(x <= xa, arc, line)


def cusp_of_step(d, psi, r: float, ball: bool, iterations: int = 60):
    """(…) the cusp height (mm) two tools of corner radius ``r`` leave on a wall when their
    contacts are ``d`` mm apart along it at the contact angle ``psi`` (rad): the height where
    the upper tool's outline G(x; 90° − ψ) meets the lower's G(d − x; ψ), by bisection in x
    (the inverse of :func:`step_for_scallop`)."""
    d, psi = np.broadcast_arrays(np.asarray(d, float), np.clip(np.asarray(psi, float), 0.0,
                                                                0.5 * math.pi))
    upper = 0.5 * math.pi - psi + (0.5 * math.pi if ball else 0.0)
    lo, hi = np.zeros(d.shape), d.copy()
    for _ in range(iterations):
        x = 0.5 * (lo + hi)
        above = _g(x, r, upper) > _g(d - x, r, psi)
        hi = np.where(above, x, hi)
        lo = np.where(above, lo, x)
    x = 0.5 * (lo + hi)
    return np.minimum(_g(x, r, upper), _g(d - x, r, psi))


def radial_step_limit(h: float, cutter: Cutter, normals, axes, radial) -> np.ndarray:
    """(k,) the largest radial step Δr (mm) between two levels that leaves at most ``h`` mm
    at wall points of unit ``normals`` (k, 3) cut with the tool ``axes`` (k, 3), ``radial``
    (k, 3) the radial directions there (module docstring: d_max and D · u = Δr)."""
    n, a, u = (np.asarray(v, float) for v in (normals, axes, radial))
    c = np.einsum("ij,ij->i", n, a)
    psi = np.arcsin(np.clip(np.abs(c), 0.0, 1.0))
    d = step_for_scallop(h, psi, float(cutter.r), cutter.type == "ball")
    den = np.einsum("ij,ij->i", a - c[:, None] * n, u)
    sq = np.sqrt(np.maximum(1.0 - c * c, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        dr = d * np.maximum(den, 1e-9) / sq
    return np.where(np.isfinite(dr), dr, np.inf)


def _blade_vertices(V, F, axis: Axis):
    """(r, θ, z, unit normals (k, 3), radial directions (k, 3)) of the blade mesh's vertices:
    what :func:`fillet_band` and :func:`wall_samples` read the walls' slope from."""
    mesh = TriMesh.from_arrays(np.asarray(V, float), np.asarray(F, np.int64))
    r, th, z = theta_about(mesh.V, axis)
    e1, e2, _ = axis.angular_frame()
    u = np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2
    return r, th, z, mesh.vertex_normals, u


def fillet_band(part, cutter: Cutter, lean: float = math.radians(20.0)) -> float:
    """The height (mm above the hub) up to which the levels' passes cannot be trusted to
    reach the walls, which the floor band's surface-driven passes then finish: the hub
    fillet's radius r_f (estimated on the blade mesh: a point of a circular fillet whose
    normal is β from the radial direction lies r_f (1 − cos β) above the hub; the median of
    height / (1 − cos β) over the points with β in 30°…60°) plus the cutter's corner radius
    (its corner rides on the fillet) plus R sin(``lean``) (the region's disc model smears a
    tool tilted by up to ``lean`` over that much height, keeping a bull nose's corner off the
    fillet, :func:`.region.offset_table`)."""
    r, _, z, N, u = _blade_vertices(part.blade_vertices, part.blade_faces, part.axis)
    cb = np.abs(np.einsum("ij,ij->i", N, u))
    H = np.asarray(part.hub_profile, float)
    y = r - np.interp(z, H[:, 1], H[:, 0])
    use = (cb >= math.cos(math.radians(60.0))) & (cb <= math.cos(math.radians(30.0))) & \
        (y > 0)
    rf = float(np.median(y[use] / (1.0 - cb[use]))) if use.any() else 0.0
    return rf + float(cutter.r) + float(cutter.max_radius) * math.sin(lean)


def wall_samples(V, F, axis: Axis):
    """The blade walls' samples (module docstring): (r, θ, z, normal (k, 3)) of the mesh's
    vertices whose normal lies within :data:`WALL_SLOPE` of the tangential plane."""
    r, th, z, N, u = _blade_vertices(V, F, axis)
    wall = np.abs(np.einsum("ij,ij->i", N, u)) <= math.sin(WALL_SLOPE)
    return r[wall], th[wall], z[wall], N[wall]


def check_depth_options(request, cutter: Cutter):
    """The step options of a roughing request (``depth_per_cut``, ``level_scallop``,
    ``max_depth_per_cut`` attributes, mm or None): exactly one of a constant depth per cut and
    a level scallop; the maximum depth per cut (with the scallop only; None: the flute length)
    caps the scallop's steps. Returns (depth or None, scallop or None, cap) or raises naming
    what to change."""
    depth_per_cut, level_scallop = request.depth_per_cut, request.level_scallop
    max_depth_per_cut = request.max_depth_per_cut
    def num(name, v):
        try:
            x = float(v)
        except (TypeError, ValueError):
            raise BliskCamError(f"{name} must be a number, got {v!r}") from None
        if not (math.isfinite(x) and x > 0):
            raise BliskCamError(f"{name} must be > 0 mm, got {x:g}")
        return x

    tool = f"{cutter.type} cutter Ø{cutter.d:g}"
    if level_scallop is None:
        if depth_per_cut is None:
            raise BliskCamError("give the depth per cut (a constant step between levels) or "
                                "a level scallop height (steps from the walls' slope)")
        if max_depth_per_cut is not None:
            raise BliskCamError("a maximum depth per cut caps the steps of a level scallop; "
                                "with a constant depth per cut leave it out")
        depth = num("depth per cut", depth_per_cut)
        if depth > cutter.h:
            raise ToolError(f"depth per cut {depth:g} mm is more than the flute length "
                            f"{cutter.h:g} mm of the {tool}")
        return depth, None, depth
    if depth_per_cut is not None:
        raise BliskCamError("give either a depth per cut (constant steps) or a level scallop "
                            "height (steps from the walls' slope), not both")
    h = num("level scallop height", level_scallop)
    cap = cutter.h if max_depth_per_cut is None else num("maximum depth per cut",
                                                         max_depth_per_cut)
    if cap > cutter.h:
        raise ToolError(f"maximum depth per cut {cap:g} mm is more than the flute length "
                        f"{cutter.h:g} mm of the {tool}")
    if h >= cap:
        raise BliskCamError(f"level scallop height {h:g} mm is not below the largest step "
                            f"{cap:g} mm (the flute length or the maximum depth per cut): a "
                            "scallop that large bounds nothing; give a smaller height")
    return None, h, cap


def scallop_levels(z, floor, top, mode: str, h: float, cap: float, cutter: Cutter, samples,
                   limit) -> tuple[list[Level], list[float]]:
    """The levels (from the shroud down, as :func:`.levels.level_radii`) over stations ``z``
    between ``floor`` and ``top`` (n,) mm, spaced for the scallop ``h`` mm (module
    docstring): ``samples`` (r, z) (k,) the wall samples, ``limit`` (k,) their largest radial
    steps (:func:`radial_step_limit`, least over their axes), ``cap`` the largest step.
    Returns (levels, steps): steps[k] the largest radial step (mm) from level k down to k + 1."""
    if mode not in LEVEL_MODES:
        raise BliskCamError(f"level mode must be one of {', '.join(LEVEL_MODES)}, got {mode!r}")
    z = np.asarray(z, float)
    f = np.asarray(floor, float)
    t = np.maximum(np.asarray(top, float), f)
    span = float((t - f).max()) if len(f) else 0.0
    rs, zs = (np.asarray(v, float) for v in samples)
    lim = np.maximum(np.asarray(limit, float), MIN_STEP)
    fs, ts = np.interp(zs, z, f), np.interp(zs, z, t)
    inside = (zs >= z[0]) & (zs <= z[-1])
    # every level in one parameter w: from-hub r = f + w (w up from 0), from-shroud
    # r = max(t − w, f) (w down from 0 at the top), morph r = f + w (t − f), w from 1 down
    if mode == "from-hub":
        def radius(w, ff, tt):
            return ff + w
        w, sign, w_end, scale = 0.0, 1.0, span, np.ones(len(zs))
    elif mode == "from-shroud":
        def radius(w, ff, tt):
            return np.maximum(tt - w, ff)
        w, sign, w_end, scale = 0.0, 1.0, span, np.ones(len(zs))
    else:
        def radius(w, ff, tt):
            return ff + w * (tt - ff)
        w, sign, w_end = 1.0, -1.0, 0.0
        scale = np.maximum(ts - fs, 1e-9)
    cap_w = cap if mode != "morph" else cap / max(span, 1e-9)
    ws = [w]
    while (w_end - w) * sign > 1e-9:
        step = min(cap_w, abs(w_end - w))
        for _ in range(200):
            a = radius(w, fs, ts)
            b = radius(w + sign * step, fs, ts)
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            band = inside & (rs >= lo - 1e-9) & (rs <= hi + 1e-9)
            if not band.any():
                break
            need = float((lim[band] / scale[band]).min())
            if need >= step * (1 - 1e-9):
                break
            step = need
        step = max(step, MIN_STEP / (1.0 if mode != "morph" else max(span, 1e-9)))
        w = w + sign * step
        if (w_end - w) * sign < 1e-6 * max(1.0, abs(w_end)):
            w = w_end
        ws.append(w)
    # ws from the start (floor for from-hub, shroud otherwise) to the end: the levels from
    # the shroud down, the last the floor
    if mode == "from-hub":
        ws = ws[::-1][1:]  # the top offset w = span lies at or above the shroud: not a level
        radii = [f + w_ for w_ in ws]
        labels = [f"from the hub +{w_:.3g} mm" for w_ in ws]
    elif mode == "from-shroud":
        ws = ws[1:]
        radii = [np.maximum(t - w_, f) for w_ in ws]
        labels = [f"from the shroud −{w_:.3g} mm" for w_ in ws]
    else:
        ws = ws[1:]
        radii = [f + w_ * (t - f) for w_ in ws]
        labels = [f"morph s = {w_:.3f}" for w_ in ws]
    radii[-1] = f.copy()
    K = len(radii)
    levels = [Level(k, r, f"level {k + 1} of {K} ({lab}, scallop {h:g} mm)")
              for k, (r, lab) in enumerate(zip(radii, labels, strict=True))]
    steps = [float(np.max(radii[k] - radii[k + 1])) for k in range(K - 1)]
    return levels, steps


def sample_limits(h: float, cutter: Cutter, axis: Axis, samples, lead: float, tilt_lo,
                  tilt_hi, n_tilts: int = 7) -> np.ndarray:
    """(k,) the largest radial step (mm) at each wall sample (r, θ, z, normal) of
    :func:`wall_samples`, the least over ``n_tilts`` side tilts spanning [``tilt_lo``,
    ``tilt_hi``] (k,) rad (both blade sides: a normal is taken as it is and turned to the
    other wall by the symmetry |n · a|, which the formula uses)."""
    _, th, _, N = samples
    lo = np.broadcast_to(np.asarray(tilt_lo, float), th.shape)
    hi = np.broadcast_to(np.asarray(tilt_hi, float), th.shape)
    out = np.full(len(th), np.inf)
    for f in np.linspace(0.0, 1.0, max(2, n_tilts)):
        u, a = tilted_axes(axis, th, lead, lo + f * (hi - lo))
        out = np.minimum(out, radial_step_limit(h, cutter, N, a, u))
    return out


def _lean_ranges(sections, z, floor, top, samples, reach: float, band: float,
                 max_turn: float):
    """(lo, hi) (k,) the side tilts (rad) a level passing a wall sample may take: the blades'
    mean camber lean (:func:`.axis.mean_camber_lean`) over the band of ``band`` mm above
    every tip radius within ``reach`` mm below the sample (a 1 mm grid), at the stations
    within 3 mm of it, widened by the turn the limiter may carry over 3 mm of stations."""
    rs, _, zs, _ = samples
    grid = np.arange(float(np.min(floor)) - 1.0, float(np.max(top)) + 1.0, 1.0)
    L = np.stack([mean_camber_lean(sections, z, np.full(len(z), g), np.full(len(z), g + band))
                  for g in grid])  # (grid, stations)
    lo = np.full(len(rs), np.inf)
    hi = np.full(len(rs), -np.inf)
    dz = float(np.median(np.diff(z))) if len(z) > 1 else 1.0
    w = max(1, int(math.ceil(3.0 / dz)))
    # the least and largest over the stations within 3 mm (a running window)
    from_ = np.lib.stride_tricks.sliding_window_view(np.pad(L, ((0, 0), (w, w)), "edge"),
                                                     2 * w + 1, axis=1)
    Lmin, Lmax = from_.min(axis=2), from_.max(axis=2)
    col = np.clip(np.searchsorted(z, zs), 0, len(z) - 1)
    for i, g in enumerate(grid):
        use = (g <= rs + 1.0) & (g >= rs - reach - 1.0)
        lo[use] = np.minimum(lo[use], Lmin[i, col[use]])
        hi[use] = np.maximum(hi[use], Lmax[i, col[use]])
    none = ~np.isfinite(lo)
    lo[none], hi[none] = 0.0, 0.0
    widen = max_turn * w
    return lo - widen, hi + widen


def channel_levels(part, cutter: Cutter, sections, z, floor, top, request, *, lean: bool):
    """The roughing's levels (from the shroud down) in the ``request``'s mode (``levels``):
    constant steps of its ``depth_per_cut`` (:func:`.levels.level_radii`) or, with its
    ``level_scallop`` (mm), steps from the walls' slope (module docstring) capped
    (:func:`check_depth_options`), the tool axes the radial direction tilted by its ``lead``
    and ``side_tilt`` and, with ``lean``, the blades' mean camber lean (``sections`` the
    blade's cylinder sections of :func:`.region.cylinder_sections`, turned at most its
    ``max_turn`` per station). Returns (levels, steps, depth, band): steps the largest radial
    step between consecutive levels (mm), depth the largest step there is (the constant depth
    per cut, or the largest of the scallop's), band the height above the hub allowance the
    floor band's passes take (the depth; with the scallop at least :func:`fillet_band`: the
    levels' staircase holds the scallop above it only)."""
    depth, scallop, cap = check_depth_options(request, cutter)
    mode, lead, side_tilt = request.levels, request.lead, request.side_tilt
    if scallop is None:
        levels = level_radii(z, floor, top, mode, depth)
        steps = [float(np.max(a.r - b.r)) for a, b in zip(levels[:-1], levels[1:],
                                                             strict=True)]
        return levels, steps, float(depth), float(depth)
    samples = wall_samples(part.blade_vertices, part.blade_faces, part.axis)
    if lean:
        lo, hi = _lean_ranges(sections, z, floor, top, samples, cap, max(cap, 2.0),
                              request.max_turn)
        lo, hi = np.minimum(lo, 0.0) + side_tilt, np.maximum(hi, 0.0) + side_tilt
    else:
        lo = hi = np.full(len(samples[0]), float(side_tilt))
    limit = sample_limits(scallop, cutter, part.axis, samples, lead, lo, hi)
    levels, steps = scallop_levels(z, floor, top, mode, scallop, cap, cutter,
                                   (samples[0], samples[2]), limit)
    first = float(np.max(np.maximum(top, floor) - levels[0].r))
    depth = float(min(cap, max(steps + [first])))
    return levels, steps, depth, max(depth, fillet_band(part, cutter))
