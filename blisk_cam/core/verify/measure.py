"""Independent measurement of a tool path on its mesh: scallops, gouges, chord errors.

Nothing here shares code with the path generator (``slicing``, ``sampling``, ``expansion``);
only the mesh, cone and path data structures are common. The figures are computed from
first principles on the triangles themselves:

* **point → mesh** — exact closest points on the triangles (every candidate triangle is
  tested with an exact point–triangle routine; candidates come from a bounding-volume tree
  whose node bounds are both an axis-aligned box and an oriented cylinder, so pruning is
  exact). The side is decided with the angle-weighted pseudo-normal of the closest feature
  (face, edge or vertex; Bærentzen & Aanæs 2005), which is the correct inside/outside test
  on a closed mesh (on an open one, beyond a boundary it is the side of the nearest face).
* **surface samples** — a deterministic barycentric grid on every triangle of the machined
  region (morph ratio in [0, 1]), finer than ``spacing``, with the smooth normal, plus the
  points where the grid edges cross the region's boundary cones.
* **swept cutter** — the volume swept by the cutter along each pass (straight moves between
  the poses, closed passes include the closing move). For a ball of radius ρ it is a union
  of capsules around the centre polyline; the *material left* at a surface point p is the
  signed distance from p to that volume, ``min_seg dist(p, seg) − ρ`` (> 0: material left,
  < 0: gouge, in mm). Other cutters plug in through :func:`swept_cutter`.
* **scallops** — per pair of neighbouring levels, the material left using only those two
  passes, maximised over the samples *and* over the ridge where the two passes' envelopes
  meet (located on the sample grid edges by regula falsi on the exact distances), so the
  figure is the ridge's, not the nearest sample's. The scallop height along the surface
  normal (the textbook cusp height) is measured at the ridge points too.

The swept volume assumes the ball centre moves on straight lines between poses (linear
interpolation in the part frame); a ball is symmetric, so its axis does not matter.

Units are mm throughout. The module is numpy/scipy only (no bpy, no trimesh).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import ToleranceError
from ..geometry.axis import meridional
from ..geometry.closest import ClosestPoints, barycentric, closest_on_segments, closest_on_triangles
from ..geometry.distance import MeshDistance, closest_points
from ..geometry.mesh import TriMesh
from ..geometry.vectors import dot
from ..part.fitting import region_holes
from ..part.profiles import morph_between
from ..runtime import Cancelled, Progress, alongside, cancellable, check_cancel, map_tasks, parallel
from ..tool.cutter import as_cutter
from ..toolpath.types import PassCurve, ToolPath
from .allowance import as_measured_on_blade
from .contacts import cl_or_nan, interpolated_contacts
from .forest import SweptForest, regula_falsi
from .links import cut_runs, link_checks
from .samples import SurfaceSamples, default_spacing, surface_samples
from .sweep import SWEEP_METHODS, SweepError, SweptCutter, swept_cutter
from .sweep_ball import SweptBall, _curve_polyline

__all__ = [
    "Cancelled",
    "ClosestPoints",
    "MeshDistance",
    "SurfaceSamples",
    "SweptBall",
    "SWEEP_METHODS",
    "SweepError",
    "SweptCutter",
    "VerifyReport",
    "closest_points",
    "closest_on_segments",
    "closest_on_triangles",
    "default_spacing",
    "surface_samples",
    "swept_cutter",
    "verify_path",
]


# ================================================================== report
@dataclass
class VerifyReport:
    """All figures of :func:`verify_path` (mm unless stated).

    Scalars
    -------
    tool_radius, spacing (sample spacing used), n_samples, n_poses, n_curves, n_levels
    max_material_left : max over region samples and scallop ridges of the material left by
        all passes (signed distance from the surface to the swept cutter; NaN without samples)
        — ``max_material_left_at`` its location
    max_gouge : max depth of the swept cutter below the region's surface, ≥ 0 — measured at
        the samples and at the feet of the sub-sampled centre polylines (where the deepest
        cuts are); ``max_gouge_at`` its location
    max_cusp : max of ``pair_cusp``
    max_cusp_normal : max of ``pair_cusp_normal``
    cc_chord : max distance from the CC polylines (``subsamples`` − 1 points inside every
        segment, closing segments included) to the mesh; ``cc_chord_at`` where
    path_overcut : max of ρ − signed dist(centre polyline, mesh) over the sub-sampled centre
        polylines, ≥ 0 (the straight moves cut into the mesh by this much; the sign makes a
        centre inside the material count as ρ + depth); ``path_overcut_at`` where
    path_undercut : max of signed dist(centre polyline, mesh) − ρ, ≥ 0 (the centre polyline
        leaves the exact offset surface by this much)
    cc_on_mesh : max distance of the CC points to the mesh
    cc_on_cone : max |f_s(r, z)| of the CC points to their LMC (meridional distance)
    normal_error_deg : max angle between a pose's normal and the mesh's smooth normal at the
        CC point's closest point, degrees
    pose_mismatch : max |tip + ρ axis − (cc + ρ normal)| (the ball centre implied by the CL
        data against the one implied by the CC data)

    Arrays
    ------
    levels (p,) distinct s of the passes; pair_s (p−1, 2) consecutive levels;
    pair_cusp (p−1,) max material left at the surface between two consecutive levels
        (samples with s in the pair's interval) by those two levels' passes only, including
        the ridge where their envelopes meet (located to ~1e-9 mm);
    pair_cusp_normal (p−1,) the same scallop measured as a height along the smooth surface
        normal (the textbook cusp height; on a plane ρ − sqrt(ρ² − w²/4) where pair_cusp is
        sqrt(ρ² + w²/4) − ρ), taken at the ridge points within 25 % of the pair's top and at
        its highest sample; pair_gouge (p−1,) max depth below the surface by the two passes;
    pair_where (p−1, 3) location of each pair's max, pair_n_samples (p−1,);
    curve_* (n_curves,) per-curve figures; sample_points (k, 3), sample_values (k,) material
    left at the samples; vertex_values (n_vertices,) material left at the mesh vertices, NaN
    outside the region; timings (dict of seconds).

    Links (every program row that is not a cut: link, approach, retract, rapid)
    -----
    link_gouge : max depth (mm, ≥ 0) of the cutter below the mesh along the non-cut moves of
        the program (sampled at ``subsamples`` points per move, axis interpolated; a ball
        exactly, ρ − signed distance of its centre; another cutter by the mesh point nearest
        its axis one radius above the tip); ``link_gouge_at`` where, ``link_gouge_row`` the
        program row the move ends at; link_rows : the non-cut moves measured (0 without a
        program)

    Holes (issue 28)
    -----
    uncovered_holes, uncovered_area (mm²), uncovered_at (3,) : holes of the mesh inside the
        region (:func:`..part.fitting.region_holes`): surface the samples cannot reach, so no
        figure above covers it; ``uncovered_at`` is the largest hole's centre

    Allowance (semi-finishing: ``path.allowance`` a > 0)
    ---------
    allowance : a. Every figure above is then measured against the blade offset by a
        (:mod:`.allowance`: the cutter grown by a on the blade; ``tool`` and ``tool_radius``
        are the grown cutter's): the material left on the blade is a + ``max_material_left``,
        ``max_gouge`` and ``link_gouge`` are depths into the allowance.
    """

    tool_radius: float
    tool: dict
    spacing: float
    n_samples: int
    n_poses: int
    n_curves: int
    n_levels: int
    max_material_left: float
    max_material_left_at: np.ndarray
    max_gouge: float
    max_gouge_at: np.ndarray
    max_cusp: float
    max_cusp_normal: float
    cc_chord: float
    cc_chord_at: np.ndarray
    path_overcut: float
    path_overcut_at: np.ndarray
    path_undercut: float
    cc_on_mesh: float
    cc_contact: float
    cc_on_cone: float
    normal_error_deg: float
    pose_mismatch: float
    levels: np.ndarray
    pair_s: np.ndarray
    pair_cusp: np.ndarray
    pair_cusp_normal: np.ndarray
    pair_gouge: np.ndarray
    pair_where: np.ndarray
    pair_n_samples: np.ndarray
    curve_cc_chord: np.ndarray
    curve_overcut: np.ndarray
    curve_undercut: np.ndarray
    curve_on_mesh: np.ndarray
    curve_on_cone: np.ndarray
    pose_cc_contact: np.ndarray
    sample_points: np.ndarray
    sample_values: np.ndarray
    vertex_values: np.ndarray
    timings: dict = field(default_factory=dict)
    link_gouge: float = 0.0
    link_gouge_at: np.ndarray | None = None
    link_gouge_row: int | None = None
    link_rows: int = 0
    allowance: float = 0.0  # mm of stock the path leaves (see below)
    uncovered_holes: int = 0
    uncovered_area: float = 0.0
    uncovered_at: np.ndarray | None = None

    def summary(self) -> dict:
        """Plain-Python figures for JSON or printing (no large arrays)."""

        def f(x):
            x = float(x)
            return x if np.isfinite(x) else None

        return {
            "tool_radius": f(self.tool_radius),
            "tool": dict(self.tool),
            "spacing": f(self.spacing),
            "n_samples": int(self.n_samples),
            "n_poses": int(self.n_poses),
            "n_curves": int(self.n_curves),
            "n_levels": int(self.n_levels),
            "max_material_left": f(self.max_material_left),
            "max_gouge": f(self.max_gouge),
            "max_cusp": f(self.max_cusp),
            "max_cusp_normal": f(self.max_cusp_normal),
            "cc_chord": f(self.cc_chord),
            "path_overcut": f(self.path_overcut),
            "path_undercut": f(self.path_undercut),
            "cc_on_mesh": f(self.cc_on_mesh),
            "cc_contact": f(self.cc_contact),
            "cc_on_cone": f(self.cc_on_cone),
            "normal_error_deg": f(self.normal_error_deg),
            "pose_mismatch": f(self.pose_mismatch),
            "pair_s": [[f(a), f(b)] for a, b in self.pair_s],
            "pair_cusp": [f(x) for x in self.pair_cusp],
            "pair_cusp_normal": [f(x) for x in self.pair_cusp_normal],
            "timings": {k: round(float(v), 4) for k, v in self.timings.items()},
            "link_gouge": f(self.link_gouge),
            "link_rows": int(self.link_rows),
            **({"allowance": float(self.allowance)} if self.allowance else {}),
            **({"uncovered_holes": int(self.uncovered_holes),
                "uncovered_area": float(self.uncovered_area)} if self.uncovered_holes else {}),
        }


def _nanmax(x, default=np.nan):
    x = np.asarray(x, dtype=np.float64)
    x = x[np.isfinite(x)]
    return float(x.max()) if len(x) else default


def _subsample(c: PassCurve, pts, nsub: int, include_nodes: bool):
    """Points along a pass polyline: ``nsub − 1`` interior points per segment (and the
    nodes themselves when ``include_nodes``)."""
    a, b = _curve_polyline(c, pts)
    t = np.arange(0 if include_nodes else 1, nsub) / nsub
    out = (a[:, None, :] + t[None, :, None] * (b - a)[:, None, :]).reshape(-1, 3)
    if include_nodes and not (c.closed and len(pts) > 2):
        out = np.vstack([out, np.asarray(pts, float)[-1:]])
    return out


def _ridges(samples, strip, g, npairs):
    """Grid edges inside one strip across which g (a sign per sample: −1, 0, 1 or NaN)
    changes sign: (edge ids, pair ids)."""
    # one int32 code per sample, 4 strip + (1 where g < 0, 2 where g > 0, else 0), −1
    # outside the strips: an edge's ends are in one strip with opposite signs exactly when
    # their codes differ in those two bits alone (XOR 3); one gather of both ends' codes
    code = np.where((strip >= 0) & (strip < npairs),
                    4 * strip + np.where(g < 0, 1, np.where(g > 0, 2, 0)), -1).astype(np.int32)
    ce = code[samples.edges]
    idx = np.flatnonzero((ce[:, 0] ^ ce[:, 1]) == 3)
    return idx, strip[samples.edges[idx, 0]]


def verify_path(mesh: TriMesh, path: ToolPath, *, spacing: float | None = None,
                subsamples: int = 8, refine: int = 3, method: str = "fast",
                workers: int | None = None, cancel=None, progress=None,
                on_material_left=None) -> VerifyReport:
    """Measure a tool path on its mesh, independently of the generator.

    Parameters
    ----------
    mesh : TriMesh — the machined surface (normals out of the material)
    path : ToolPath — passes with cc, normal, tip, axis per pose; a path leaving stock
        (``allowance`` > 0) is measured against the blade offset by it (:mod:`.allowance`)
    spacing : float, mm — surface sample spacing; default :func:`default_spacing` of the
        tool radius and the path's cusp tolerance (a third of the nominal pass spacing)
    subsamples : int — points per segment for the chord checks (CC and centre polylines)
    refine : int — regula-falsi iterations locating each scallop ridge
    method : "fast" | "exact" — how the swept volume of a non-ball cutter is minimised over
        each move (:class:`SweptCutter`); a ball is always swept exactly (:class:`SweptBall`)
    workers : int or None — threads for the point queries (None: every core of this
        process); every point is measured independently, so the figures do not depend on it
    cancel : None, threading.Event or callable returning True to stop — checked between the
        steps and before every chunk of points (:func:`..runtime.map_chunks`) and every
        per-level task, from the worker threads too; once set, :class:`Cancelled` is raised
        (within one chunk's time) and nothing is returned
    progress : None or callable(:class:`~..runtime.Progress`) — told the fraction done and
        the step starting (mesh tree, poses, samples, material, scallops, totals), for a
        front end's progress line; it does not change the figures
    on_material_left : None or callable(vertex_values (n_vertices,) mm) — called once, on the
        calling thread, as soon as the material left is measured (before the scallops): the
        report's ``vertex_values`` to come (a front end shows its colour map early)

    Returns
    -------
    VerifyReport
    """
    with parallel(workers), cancellable(cancel, "verify"):
        report = _verify_path(mesh, as_measured_on_blade(path), spacing, subsamples, refine,
                              method, progress, on_material_left)
    report.allowance = float(path.allowance or 0.0)
    return report


#: the steps of verify and the fraction of a typical run done when each starts
_STEPS = {"mesh tree": 0.0, "poses": 0.05, "samples": 0.35, "material": 0.45,
          "scallops": 0.7, "links": 0.93, "totals": 0.95}


def _verify_path(mesh, path, spacing, subsamples, refine, method, progress=None,
                 on_material_left=None):
    """:func:`verify_path` on the threads set by the caller: the named steps in order."""
    def step(name):
        check_cancel()
        if progress is not None:
            progress(Progress(_STEPS[name], name))

    step("mesh tree")
    t0 = time.perf_counter()
    tim = {}
    cutter, rho, spacing = _tool_and_spacing(path, spacing, method)
    cones = morph_between(path.cone1, path.cone2)  # LMC, or LMRS for profile generatrices
    axis = path.axis
    curves = cut_runs(path.curves)
    # the surface samples do not depend on the poses: with several threads they are built
    # on a thread of their own (one core) while the mesh tree and the pose checks run
    # ("samples" then times the wait and the gouge feet)
    mesh.face_normals, mesh.vertex_normals, mesh.edge_faces  # noqa: B018  (filled once:
    # both threads read these caches)
    samples = alongside(lambda: surface_samples(mesh, cones, axis, spacing))
    md = MeshDistance(mesh, compiled=True)  # ties: the lowest face id (same distances)
    tim["mesh_tree"] = time.perf_counter() - t0

    step("poses")
    t1 = time.perf_counter()
    # the whole path's swept volume depends on the passes alone: built beside the poses
    whole = alongside(lambda: _whole_sweep(path.tool, curves, method))
    pc, cc_checks = _pose_checks(mesh, md, curves, cutter, rho, cones, axis, subsamples)
    tim["poses"] = time.perf_counter() - t1

    step("samples")
    t1 = time.perf_counter()
    smp, P, normals, s_all = _samples_and_feet(mesh, cones, axis, samples(), pc)
    spacing = smp.spacing
    tim["samples"] = time.perf_counter() - t1

    step("material")
    t1 = time.perf_counter()
    sweep = whole()
    # the levels' swept volumes (the scallops') are built beside the material's query
    cut = alongside(lambda: _level_forest(path.tool, curves, *sweep[:2], method))
    levels, lev_of, whole, values, lab = _material_left(sweep, curves, P, P + rho * normals)
    tim["material"] = time.perf_counter() - t1
    if on_material_left is not None:
        on_material_left(smp.at_vertices(values, mesh.n_vertices))

    step("scallops")
    t1 = time.perf_counter()
    # the CC points' checks, the links and the region's holes need no later step: with
    # several threads they run alongside the scallops, filling the cores that its serial
    # parts leave idle (started here, they do not slow the samples' thread or the material)
    cc_checks = alongside(cc_checks)
    links = alongside(lambda: (link_checks(md, path.program, cutter, rho, subsamples),
                               region_holes(mesh, axis, path.cone1, path.cone2)))
    sc = _scallops(mesh, cut(), levels, smp, P, normals, s_all, values, lab, rho, refine)
    tim["scallops"] = time.perf_counter() - t1

    step("links")
    t1 = time.perf_counter()
    links, holes = links()
    tim["links"] = time.perf_counter() - t1

    step("totals")
    t1 = time.perf_counter()
    tot = _totals(mesh, smp, P, values, whole, sc, len(curves))
    tim["totals"] = time.perf_counter() - t1
    cc_checks()  # the CC points' checks, started alongside in "scallops"
    tim["total"] = time.perf_counter() - t0
    if progress is not None:
        progress(Progress(1.0, "done"))
    rep = _report(cutter, rho, spacing, curves, levels, P, values, pc, sc, tot, tim)
    rep.link_gouge, rep.link_gouge_at, rep.link_gouge_row, rep.link_rows = links
    if holes:
        rep.uncovered_holes = len(holes)
        rep.uncovered_area = float(sum(h.area for h in holes))
        rep.uncovered_at = np.asarray(holes[0].centre)
    return rep


def _tool_and_spacing(path, spacing, method):
    """(cutter, ρ, sample spacing) of the path's tool; ToleranceError on a bad method or
    radius."""
    if str(method).strip().lower() not in SWEEP_METHODS:
        raise ToleranceError(f"verify method must be one of {', '.join(SWEEP_METHODS)}; "
                             f"got {method!r}")
    tool = path.tool
    if isinstance(tool, dict) or getattr(tool, "type", "ball") != "ball":
        cutter = as_cutter(tool)
        rho = cutter.radius
    else:  # a ball (Cutter or legacy BallTool): only its radius matters
        rho = float(tool.radius)
        if not (rho > 0):
            raise ToleranceError(f"tool radius must be positive, got {rho} mm")
        cutter = as_cutter(tool)
    if spacing is None:
        spacing = default_spacing(rho, path.cusp)
    return cutter, rho, spacing


@dataclass
class _PoseChecks:
    """Per-curve figures of the poses themselves (NaN for a curve without poses)."""

    on_mesh: np.ndarray
    on_cone: np.ndarray
    cc_chord: np.ndarray
    over: np.ndarray
    under: np.ndarray
    nerr: float = 0.0
    mismatch: float = 0.0
    pose_contact: np.ndarray = field(default_factory=lambda: np.zeros(0))
    chord_at: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    over_at: np.ndarray = field(default_factory=lambda: np.full(3, np.nan))
    #: mesh points (point, face, bary) under the centres that cut in: the deepest gouges
    feet: tuple | None = None


def _pose_checks(mesh, md, curves, cutter, rho, cones, axis, subsamples):
    """The tool's path against the exact offset (:func:`_path_checks`: over/undercut, the
    gouge feet). Returns (:class:`_PoseChecks`, the CC points' checks (:func:`_cc_checks`)
    as a function to run before reading its CC figures: nothing downstream needs them)."""
    ncur = len(curves)
    pc = _PoseChecks(*(np.full(ncur, np.nan) for _ in range(5)))
    if not ncur:
        return pc, lambda: pc
    _path_checks(pc, md, curves, cutter, rho, subsamples)
    return pc, lambda: _cc_checks(pc, mesh, md, curves, cutter, rho, cones, axis, subsamples)


def _cc_checks(pc, mesh, md, curves, cutter, rho, cones, axis, subsamples) -> _PoseChecks:
    """CC points on the mesh and on their LMC, normals, tips against the CC data, chord of the
    CC polylines (into ``pc``)."""
    ncur = len(curves)
    is_ball = cutter.type == "ball"
    cc_all = np.vstack([np.asarray(c.cc, float) for c in curves])
    nrm_all = np.vstack([np.asarray(c.normal, float) for c in curves])
    cid = np.repeat(np.arange(ncur), [len(c.cc) for c in curves])
    cp = md.query(cc_all)
    check_cancel()  # between the sub-steps too: a cancel acts within a second
    pc.on_mesh = _group_max(ncur, cid, cp.distance)
    sn = mesh.interpolate_normals(cp.face, cp.bary)
    un = nrm_all / np.maximum(np.linalg.norm(nrm_all, axis=1), 1e-300)[:, None]
    pc.nerr = float(np.degrees(np.arccos(np.clip(dot(sn, un), -1.0, 1.0))).max())
    tips = np.vstack([np.asarray(c.tip, float) for c in curves])
    axs = np.vstack([np.asarray(c.axis, float) for c in curves])
    axs = axs / np.linalg.norm(axs, axis=1)[:, None]
    if is_ball:
        pc.mismatch = float(np.linalg.norm(tips + rho * axs - (cc_all + rho * nrm_all),
                                           axis=1).max())
    else:  # the tip implied by the CC data (the cutter touching cc) against the path's
        mm = np.linalg.norm(tips - cl_or_nan(cutter, cc_all, un, axs), axis=1)
        pc.mismatch = float(np.inf if np.any(np.isnan(mm)) else mm.max())
    # the CC point against the posed cutter's surface (0 when the cutter touches it there)
    pc.pose_contact = np.abs(cutter.signed_distance(cc_all, tips, axs))
    check_cancel()
    pc.on_cone = _group_max(ncur, cid, np.abs(_lmc_values(curves, cones, axis, cc_all, cid)))
    # chord of the CC polylines
    sub = [_subsample(c, c.cc, subsamples, False) for c in curves]
    sid = np.repeat(np.arange(ncur), [len(x) for x in sub])
    if len(sid):
        subp = np.vstack(sub)
        dch = md.query(subp).distance
        pc.cc_chord = _group_max(ncur, sid, dch)
        pc.chord_at = subp[int(np.argmax(dch))]
    return pc


def _path_checks(pc, md, curves, cutter, rho, subsamples):
    """The tool's path against the exact offset: over/undercut and the gouge feet (into
    ``pc``)."""
    ncur = len(curves)
    if cutter.type == "ball":
        # centre polylines against the exact offset
        cen = [np.asarray(c.tip, float) + rho * np.asarray(c.axis, float) for c in curves]
        sub = [_subsample(c, x, subsamples, True) for c, x in zip(curves, cen, strict=True)]
        sid = np.repeat(np.arange(ncur), [len(x) for x in sub])
        # the CC polylines' points: where the centres' closest points are (a k-d search
        # from 6 mm off the surface is slow; the result does not depend on the guess)
        cq = md.query(np.vstack(sub), near=lambda: np.vstack(
            [_subsample(c, c.cc, subsamples, True) for c in curves]))
        check_cancel()
        dev = cq.signed_distance - rho
        pc.over_at = np.vstack(sub)[int(np.argmin(dev))]
    else:
        # the interpolated poses' lowest points (toward −n); the mesh point under each
        # against the posed cutter (< 0: the surface is cut into there)
        xs, sid, xtip, xax = interpolated_contacts(cutter, curves, subsamples)
        check_cancel()
        cq = md.query(xs)
        check_cancel()
        dev = cutter.signed_distance(cq.point, xtip, xax)
        pc.over_at = cq.point[int(np.argmin(dev))] if len(xs) else np.full(3, np.nan)
    pc.over = np.maximum(_group_max(ncur, sid, -dev), 0.0)
    pc.under = np.maximum(_group_max(ncur, sid, dev), 0.0)
    # the feet of the centres that come closer than ρ: where the deepest gouges are
    cut_in = dev < 0
    pc.feet = (cq.point[cut_in], cq.face[cut_in], cq.bary[cut_in])
    return pc


def _lmc_values(curves, cones, axis, cc_all, cid):
    """f_s(r, z) of every CC point on its curve's LMC (each pose its own for a spiral)."""
    r, z = meridional(cc_all, axis)
    fvals = np.empty(len(cc_all))
    for i, c in enumerate(curves):
        m = cid == i
        if np.all(c.ratio == c.ratio[0]):
            fvals[m] = cones.f(float(c.ratio[0]), r[m], z[m])
        else:  # a spiral: every pose on its own LMC
            fvals[m] = [cones.f(float(si), ri, zi) for si, ri, zi in zip(
                c.ratio, r[m], z[m], strict=True)]
    return fvals


def _samples_and_feet(mesh, cones, axis, smp: SurfaceSamples, pc: _PoseChecks):
    """The surface samples of the region (``smp``) plus the gouge feet inside it: (samples,
    points, normals, ratios); the grid samples come first."""
    P, normals, s_all = smp.points, smp.normals, smp.s
    if pc.feet is not None:
        fp, ff, fb = pc.feet
        fs = cones.ratio_of_points(fp, axis)
        ok = (fs >= -1e-9) & (fs <= 1.0 + 1e-9)
        fp = fp[ok]
        fn = mesh.interpolate_normals(ff[ok], fb[ok])
        P = np.vstack([P, fp])
        normals = np.vstack([normals, fn])
        s_all = np.concatenate([smp.s, fs[ok]])
    return smp, P, normals, s_all


def _whole_sweep(tool, curves, method):
    """(levels, level of each curve, the whole path's swept volume, owned by levels)."""
    levels = np.unique([float(c.s) for c in curves]) if len(curves) else np.zeros(0)
    lev_of = np.searchsorted(levels, [float(c.s) for c in curves])
    return levels, lev_of, swept_cutter(tool, curves, owners=lev_of, method=method)


def _material_left(sweep, curves, P, guess=None):
    """Material left by all passes at the points: (levels, level of each curve, the swept
    volume, signed distances (k,), level of the nearest pass (k,) or −1). ``sweep``: what
    :func:`_whole_sweep` returns; ``guess`` (k, 3): where the nearest ball centres are likely
    (point + ρ · normal; a ball only, for speed)."""
    ncur = len(curves)
    levels, lev_of, whole = sweep
    if ncur:
        values, seg = (whole.nearest(P, guess) if isinstance(whole, SweptBall)
                       else whole.nearest(P))
        lab = np.where(seg >= 0, whole.owner[np.maximum(seg, 0)], -1)  # level of the nearest pass
    else:
        values, lab = np.full(len(P), np.nan), np.full(len(P), -1)
    return levels, lev_of, whole, values, lab


@dataclass
class _Scallops:
    """Figures per pair of neighbouring levels, and the located ridge points."""

    pair_cusp: np.ndarray
    pair_cn: np.ndarray
    pair_gouge: np.ndarray
    pair_where: np.ndarray
    pair_n: np.ndarray
    ridge_pts: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    ridge_face: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    ridge_val: np.ndarray = field(default_factory=lambda: np.zeros(0))
    ridge_pair: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))


def _level_forest(tool, curves, levels, lev_of, method):
    """One swept volume per level, asked together (a forest: one joint pass per query);
    None with fewer than two levels (no pair)."""
    if len(levels) < 2:
        return None
    return SweptForest(map_tasks(lambda i: swept_cutter(
        tool, [c for c, lv in zip(curves, lev_of, strict=True) if lv == i], method=method),
        range(len(levels))))


def _scallops(mesh, cut, levels, smp, P, normals, s_all, values, lab, rho,
              refine) -> _Scallops:
    """Per pair of neighbouring levels: the material left by those two passes alone at the
    samples and at the ridge where their envelopes meet, and the scallop height along the
    normal there."""
    npairs = max(len(levels) - 1, 0)
    sc = _Scallops(np.full(npairs, np.nan), np.full(npairs, np.nan), np.full(npairs, np.nan),
                   np.full((npairs, 3), np.nan), np.zeros(npairs, dtype=np.int64))
    if not npairs:
        return sc
    # ``cut``: the levels' forest (:func:`_level_forest`)
    strip = np.searchsorted(levels, s_all, side="right") - 1
    strip = np.where(s_all == levels[-1], npairs - 1, strip)
    strip = np.where((s_all < levels[0]) | (s_all > levels[-1]), -1, strip)
    valid = strip >= 0
    # where the nearest pass of all is one of the strip's two, it is the pair's distance
    # and tells which of the two is nearer; elsewhere measure both
    near_lo = valid & (lab == strip)
    near_hi = valid & (lab == strip + 1)
    other = valid & ~near_lo & ~near_hi
    mat = np.where(near_lo | near_hi, values, np.nan)
    gsign = np.where(near_lo, -1.0, np.where(near_hi, 1.0, np.nan))
    known = guess = None
    if isinstance(cut[0], SweptBall):
        if not cut.balls:  # (compiled balls find their own start: no guess needed)
            guess = P + rho * normals  # where the nearest ball centres are likely
        # a ball's distance to one level is the minimum over that level's segments of the
        # same point–segment distances as the whole path's: where the nearest pass of all is
        # one of the strip's two, it is that level's distance, bit for bit (a swept cutter's
        # search depends on its candidates: it is measured again)
        known = (np.where(near_lo, values, np.nan), np.where(near_hi, values, np.nan),
                 near_lo.copy(), near_hi.copy())
    if np.any(other):
        dlo, dhi = _two_level_distances(cut, P[other], strip[other], npairs,
                                        guess=None if guess is None else guess[other])
        mat[other] = np.minimum(dlo, dhi)
        gsign[other] = np.sign(dlo - dhi)
        if known is not None:
            for arr, d, has in ((known[0], dlo, known[2]), (known[1], dhi, known[3])):
                arr[other], has[other] = d, True
    sv, mv = strip[valid], mat[valid]
    sc.pair_n = np.bincount(sv, minlength=npairs)
    sc.pair_cusp, arg = _group_max_arg(npairs, sv, mv)
    sc.pair_gouge = np.maximum(_group_max(npairs, sv, -mv), 0.0)
    has = arg >= 0
    top = np.flatnonzero(valid)[arg[has]]  # each pair's highest sample (not P[valid]'s copy)
    sc.pair_where[has] = P[top]
    _ridge_points(mesh, smp, cut, strip, gsign, npairs, refine, sc, known, rho)
    # scallop height along the smooth normal, at the ridge points and at each pair's
    # highest sample
    hp = np.concatenate([sc.ridge_pts, P[top]])
    top_n, nr = normals[top], len(sc.ridge_pts)

    def normals_of(rows):  # the smooth normals of the rows traced (ascending: ridge first)
        # (rows of (k, 3) arrays gathered by take: ~3x faster than fancy indexing)
        m = int(np.searchsorted(rows, nr))
        rf = sc.ridge_face[rows[:m]]
        corners = mesh.F.take(rf, axis=0)
        ridge_n = mesh.interpolate_normals(rf, barycentric(
            sc.ridge_pts.take(rows[:m], axis=0), *(mesh.V.take(corners[:, j], axis=0)
                                                  for j in range(3))))
        return np.concatenate([ridge_n, top_n[rows[m:] - nr]])

    hv = np.concatenate([sc.ridge_val, mat[top]])
    hq = np.concatenate([sc.ridge_pair, np.nonzero(has)[0]])
    sc.pair_cn = _scallop_heights(cut, hp, normals_of, hv, hq, npairs, rho)
    return sc


def _ridge_points(mesh, smp, cut, strip, gsign, npairs, refine, sc: _Scallops, known=None,
                  rho=0.0):
    """Ridges on the sample grid (grid samples are the first len(smp) of the points): grid
    edges in one strip whose ends are nearer to different passes, located by regula falsi
    (Illinois) on the exact distances; raises the pairs' cusps in ``sc`` where a ridge point
    is higher and stores the ridge points.

    ``known`` (a ball only): (d_lo, d_hi, has_lo, has_hi) (k,) — the points' distances to
    their strip's two levels already measured (:func:`_scallops`); only the others are
    measured at the edges' ends. A ball's iterates are measured against the segments listed
    near the first iterate (:meth:`.sweep_ball.SweptBall.near`: the same floats, no tree walk
    per iteration); its centres are looked for ``rho`` (mm) along the samples' normals."""
    ng = len(smp)
    eidx, epair = _ridges(smp, strip[:ng], gsign[:ng], npairs)
    if len(eidx):
        # the edges' distinct ends and each end's rank among them (np.unique's with its
        # inverse), by marking the samples: no sort of the ~2e5 ends
        ev = smp.edges.take(eidx, axis=0)  # (row gathers by take: ~3x fancy indexing's)
        mark = np.zeros(ng, dtype=bool)
        mark[ev] = True
        ends, inv = np.flatnonzero(mark), (np.cumsum(mark) - 1)[ev]
        if known is None:
            dlo, dhi = _two_level_distances(cut, smp.points[ends], strip[ends], npairs)
        else:
            dlo, dhi = known[0][ends], known[1][ends]
            mlo, mhi = _two_level_distances(
                cut, smp.points.take(ends, axis=0), strip[ends], npairs,
                need=(~known[2][ends], ~known[3][ends]),
                guess=None if cut.balls else smp.points[ends] + rho * smp.normals[ends])
            dlo = np.where(known[2][ends], dlo, mlo)
            dhi = np.where(known[3][ends], dhi, mhi)
        g = dlo - dhi
        ga, gb = g[inv[:, 0]], g[inv[:, 1]]
        ok = ((ga < 0) & (gb > 0)) | ((ga > 0) & (gb < 0))
        eidx, epair, ga, gb = eidx[ok], epair[ok], ga[ok], gb[ok]
    if not len(eidx):
        return
    ea, eb = smp.edges.take(eidx, axis=0).T
    xa, xb = smp.points.take(ea, axis=0), smp.points.take(eb, axis=0)
    steps = cut.ridge_steps(xa, xb, ga, gb, epair, refine)  # compiled balls: every step
    if steps is None:
        near = []

        def distances(x, i):
            if known is not None and i == 0:
                # the iterates after the first move by far less than a tenth of the edge
                near.append(_two_level_near(cut, x, epair, npairs,
                                            0.1 * np.linalg.norm(xb - xa, axis=1),
                                            x + rho * smp.normals[ea]))
            return _two_level_distances(cut, x, epair, npairs, near=near[0] if near else None)

        steps = regula_falsi(xa, xb, ga, gb, refine, distances)
    x, la, lb = steps
    rv = np.minimum(la, lb)
    rmax, ra = _group_max_arg(npairs, epair, rv)
    better = np.isfinite(rmax) & ~(rmax <= sc.pair_cusp)
    sc.pair_cusp = np.where(better, rmax, sc.pair_cusp)
    sc.pair_where[better] = x[ra[better]]
    sc.ridge_pts = x
    sc.ridge_face = smp.edge_face[eidx]  # their normals: asked in :func:`_scallops`
    sc.ridge_val, sc.ridge_pair = rv, epair


def _scallop_heights(cut, hp, normals_of, hv, hq, npairs, rho):
    """Largest scallop height along the normal per pair (NaN where none): from the points
    ``hp`` (normals ``normals_of(rows)`` (len(rows), 3) of the rows traced, ascending;
    material left ``hv``, pair ``hq``) up to the nearer of the pair's two swept volumes
    (``cut``: the levels' forest)."""
    heights = np.where(hv > 0, np.nan, hv)
    hmax = np.maximum(4.0 * hv, 1e-6 * rho)
    # the height is the material left divided by the cosine of a slowly varying angle:
    # only points within 25 % of their pair's highest can hold the pair's highest
    top = _group_max(npairs, hq, hv)
    near_top = hv >= 0.75 * top[hq]

    live = (hv > 0) & near_top
    # every live point traced up to its pair's lower level's passes and to its upper's
    rows = np.nonzero(live)[0]
    j, lv, up = _two_level_queries(np.arange(len(rows)), hq[live], npairs)
    pi = rows[j]  # the queries' points (j: their rank among the live points)
    # (rows of (k, 3) arrays gathered by take: ~3x faster than fancy indexing)
    h = cut.height_along(hp.take(pi, axis=0), normals_of(rows).take(j, axis=0), hmax[pi], lv)
    h_lo = np.full(len(hp), np.inf)  # up to the pair's lower level's passes
    h_hi = np.full(len(hp), np.inf)
    h_lo[pi[~up]] = h[~up]
    h_hi[pi[up]] = h[up]
    heights = np.where(live, np.minimum(h_lo, h_hi), heights)
    heights[~np.isfinite(heights)] = np.nan
    return _group_max(npairs, hq, heights)


def _totals(mesh, smp, P, values, whole, sc: _Scallops, ncur):
    """(max material left, max gouge, where each, per-vertex material left) over the samples
    and the ridge points that can raise the maximum."""
    all_pts, all_vals = P, values
    if len(sc.ridge_pts) and ncur:
        # all passes leave at most what two of them leave: only ridge points above the
        # samples' maximum can raise it
        cand = sc.ridge_val > _nanmax(values, -np.inf)
        if np.any(cand):
            all_pts = np.vstack([P, sc.ridge_pts[cand]])
            all_vals = np.concatenate([values, whole.distance(sc.ridge_pts[cand])])
    fin = np.isfinite(all_vals)
    if np.any(fin):
        i_max = int(np.argmax(np.where(fin, all_vals, -np.inf)))
        i_min = int(np.argmin(np.where(fin, all_vals, np.inf)))
        max_left = float(all_vals[i_max])
        max_gouge = max(0.0, -float(all_vals[i_min]))
        left_at, gouge_at = all_pts[i_max], all_pts[i_min]
    else:
        max_left, max_gouge = np.nan, 0.0
        left_at = gouge_at = np.full(3, np.nan)
    return max_left, max_gouge, left_at, gouge_at, smp.at_vertices(values, mesh.n_vertices)


def _report(cutter, rho, spacing, curves, levels, P, values, pc, sc, tot, tim) -> VerifyReport:
    """The :class:`VerifyReport` of the steps' results."""
    max_left, max_gouge, left_at, gouge_at, vertex_values = tot
    npairs = max(len(levels) - 1, 0)
    pair_s = np.stack([levels[:-1], levels[1:]], axis=1) if npairs else np.zeros((0, 2))
    return VerifyReport(
        tool_radius=rho,
        tool=cutter.as_dict(),
        spacing=float(spacing),
        n_samples=int(len(P)),
        n_poses=int(sum(len(c.cc) for c in curves)),
        n_curves=len(curves),
        n_levels=int(len(levels)),
        max_material_left=max_left,
        max_material_left_at=np.asarray(left_at),
        max_gouge=max_gouge,
        max_gouge_at=np.asarray(gouge_at),
        max_cusp=_nanmax(sc.pair_cusp),
        max_cusp_normal=_nanmax(sc.pair_cn),
        cc_chord=_nanmax(pc.cc_chord),
        cc_chord_at=np.asarray(pc.chord_at),
        path_overcut=_nanmax(pc.over, 0.0),
        path_overcut_at=np.asarray(pc.over_at),
        path_undercut=_nanmax(pc.under, 0.0),
        cc_on_mesh=_nanmax(pc.on_mesh),
        cc_contact=_nanmax(pc.pose_contact, 0.0),
        cc_on_cone=_nanmax(pc.on_cone),
        normal_error_deg=float(pc.nerr),
        pose_mismatch=float(pc.mismatch),
        levels=levels,
        pair_s=pair_s,
        pair_cusp=sc.pair_cusp,
        pair_cusp_normal=sc.pair_cn,
        pair_gouge=sc.pair_gouge,
        pair_where=sc.pair_where,
        pair_n_samples=sc.pair_n,
        curve_cc_chord=pc.cc_chord,
        curve_overcut=pc.over,
        curve_undercut=pc.under,
        curve_on_mesh=pc.on_mesh,
        curve_on_cone=pc.on_cone,
        pose_cc_contact=pc.pose_contact,
        sample_points=P,
        sample_values=values,
        vertex_values=vertex_values,
        timings=tim,
    )


def _group_max(n, idx, vals):
    out = np.full(n, -np.inf)
    if len(idx):
        np.maximum.at(out, idx, np.where(np.isnan(vals), -np.inf, vals))
    return np.where(np.isfinite(out) | (out == np.inf), out, np.nan)


def _group_max_arg(n, idx, vals):
    """(:func:`_group_max`, the index of each group's maximum (the last of equal ones; −1
    without a finite value)) of values ``vals`` in groups ``idx`` (k,) of ``n``, from one
    maximum per group."""
    best = np.full(n, -np.inf)
    v = np.where(np.isnan(vals), -np.inf, vals)
    np.maximum.at(best, idx, v)
    win = (v >= best[idx]) & np.isfinite(v)
    arg = np.full(n, -1, dtype=np.int64)
    arg[idx[win]] = np.nonzero(win)[0]
    return np.where(np.isfinite(best) | (best == np.inf), best, np.nan), arg


def _two_level_queries(rows, strip, npairs, need=None):
    """(row, level, upper?) of every point's queries to the two levels bounding its strip
    (levels in [0, npairs]), interleaved point by point: each level's queries come in the
    points' order. ``need`` (optional): (need_lo, need_hi) (k,) bool — only those queries.
    (The queries kept are picked from a (k, 2) mask: no (2k,) arrays to filter.)"""
    ok = np.stack([(strip >= 0) & (strip <= npairs), (strip >= -1) & (strip < npairs)], axis=1)
    if need is not None:
        ok &= np.stack(need, axis=1)
    q = np.flatnonzero(ok)
    j, up = q >> 1, (q & 1).astype(bool)
    return rows[j], strip[j] + up, up


def _two_level_near(cut, P, strip, npairs, margin, guess):
    """A ball's per-level :meth:`.sweep_ball.SweptBall.near` for :func:`_two_level_distances`'s
    ``near``: the queries of :func:`_two_level_queries` of the points (k, 3) (``margin``
    (k,) mm, ``guess`` (k, 3) where the nearest centres are likely) and, per level holding
    any, its listed segments — [(rows of those queries, near)]."""
    pi, lv, _ = _two_level_queries(np.arange(len(P)), strip, npairs)
    return cut.per_member(lv, lambda m, rows: m.near(P[pi[rows]], margin[pi[rows]],
                                                     guess[pi[rows]]))


def _two_level_distances(cut, P, strip, npairs, *, need=None, near=None, guess=None):
    """Distances of points to the passes of the two levels bounding their strip (``cut``:
    the levels' :class:`SweptForest`).

    ``need`` (optional): (need_lo, need_hi) (k,) bool — measure only these (NaN elsewhere).
    ``near`` (optional, with ``need`` None): :func:`_two_level_near` of the same strips at
    points near these.
    ``guess`` (optional, a ball's levels): (k, 3) where the nearest centres are likely.
    Returns (d_lo, d_hi) (k,), NaN where ``strip`` is outside [0, npairs)."""
    dlo = np.full(len(P), np.nan)
    dhi = np.full(len(P), np.nan)
    pi, lv, up = _two_level_queries(np.arange(len(P)), strip, npairs,
                                    None if near is not None else need)
    if near is not None:  # a ball's levels: the segments listed per level, one task each
        d = np.empty(len(pi))  # every query's level holds some: each row is filled

        def one(item):
            rows, listed = item
            return rows, listed.distance(P[pi[rows]])

        for rows, d_rows in map_tasks(one, [it for it in near if it[1] is not None]):
            d[rows] = d_rows
    else:
        d = cut.distance(P.take(pi, axis=0), lv,
                         near=None if guess is None else guess.take(pi, axis=0))
    dlo[pi[~up]] = d[~up]
    dhi[pi[up]] = d[up]
    return dlo, dhi
