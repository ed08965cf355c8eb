"""The orient stage of blade finishing (:mod:`.blade_finish`): tool axes from lead/tilt or
a fixed point or line (:mod:`..paths.orientation`, paper 003), the local gouge check and fix
(:mod:`..paths.gouge`), axis smoothing and the tool tips of every pass, in place.

With lead/tilt ("local") and no near-field check, the passes' pointwise work runs once over
all their poses (:func:`orient_all_local`: the same floats as pass by pass, which at ~50
passes of a few hundred poses was mostly numpy call overhead); otherwise, and to raise an
error as pass by pass does, each pass on its own (:func:`orient_pass`). Lengths mm, angles
radians.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import BliskCamError
from ..paths.gouge import (
    LocalGougeReport,
    fix_local_gouges,
    fix_near_gouges,
    requested_margin,
    search_fixes,
    surface_normal_curvature,
)
from ..paths.orientation import axes_for_curve, lead_tilt_axes, local_frames, smooth_axes
from ..toolpath.types import (
    FLAG_AXIS_SMOOTHED,
    FLAG_GOUGE_FIXED,
    FLAG_LOCAL_GOUGE,
    FLAG_ZERO_SPEED,
)

__all__ = ["gouge_report", "known_faces", "orient_all_local", "orient_pass", "orient_passes"]


def orient_passes(curves, mesh, nearest, cutter, strategy, limits, req, report,
                  near_field=None) -> None:
    """Axes, tips and flags of every pass of ``curves`` (list of PassCurve) in place, the
    local gouge check's figures added to ``report`` (LocalGougeReport); ``nearest`` the
    mesh's :class:`~..geometry.distance.NearestFaces` (the faces of the CC points the
    passes do not carry); ``near_field`` (samples, k-d tree) or None (see
    :func:`~..paths.gouge.fix_near_gouges`)."""
    # the faces of the CC points the passes do not carry: one search for them all (only the
    # face is read, not the closest point or its normal; each point's face is its own)
    faces = [None] * len(curves)
    if strategy.mode == "local":
        faces = [known_faces(c) for c in curves]
        todo = [i for i, f in enumerate(faces) if f is None]
        if todo:
            found = nearest.faces(np.vstack([curves[i].cc for i in todo]))
            ends = np.cumsum([len(curves[i].cc) for i in todo])[:-1]
            for i, f in zip(todo, np.split(found, ends), strict=True):
                faces[i] = f
    if strategy.mode == "local" and near_field is None and curves:
        try:  # every pass at once (the figures of each pass alone, the errors aside)
            done = orient_all_local(curves, mesh, faces, cutter, strategy, limits, req)
        except BliskCamError:
            done = None  # raised again, as pass by pass, below
        if done is not None:
            for c, (axes, tip, flags, rep) in zip(curves, done, strict=True):
                c.axis, c.tip, c.flags = axes, tip, c.flags | flags
                report.add(rep)
            return
    for c, f in zip(curves, faces, strict=True):
        orient_pass(c, mesh, f, cutter, strategy, limits, req, req.axis, report, near_field)


def known_faces(curve):
    """The pass's faces when it carries one for every CC point, else None."""
    face = curve.face
    return face if len(face) == len(curve.cc) and np.all(face >= 0) else None


def orient_pass(
    curve, mesh, faces, cutter, strategy, limits, req, blisk_axis, report, near_field=None
):
    """Axes, flags and tips of one pass in place; ``faces`` (k,): the mesh face of each CC
    point (read by the local gouge check)."""
    cc, nrm, closed = curve.cc, curve.normal, curve.closed
    s = curve.ratios
    flags = np.zeros(len(cc), dtype=np.uint8)
    if strategy.mode == "local":
        f, n, k = local_frames(cc, nrm, closed)
        lead, tilt = strategy.at("lead", s), strategy.at("tilt", s)
        kf = surface_normal_curvature(mesh, faces, f)
        kk = surface_normal_curvature(mesh, faces, k)
        lead2, tilt2, flagged, left, margin = fix_local_gouges(
            cutter, f, n, k, lead, tilt, kf, kk, limits, fix=req.fix_local_gouge
        )
        if near_field is not None:  # the cutter's reach beyond the contact (a fillet corner)
            S, tree = near_field
            lead2, tilt2, nflag, nleft, _ = fix_near_gouges(
                cutter, S, cc, f, n, k, lead2, tilt2, limits, tol=0.25 * req.chord,
                fix=req.fix_local_gouge, tree=tree,
            )
            flagged, left = flagged | nflag, (left & ~nflag) | nleft
        want = lead_tilt_axes(f, n, k, lead2, tilt2)
        flags[flagged & ~left] |= FLAG_GOUGE_FIXED
        flags[left] |= FLAG_LOCAL_GOUGE
        report.add(gouge_report(cc, flagged, left, margin))
    else:
        want = axes_for_curve(cc, nrm, closed, s, strategy, blisk_axis)
        report.add(LocalGougeReport(n_poses=len(cc)))
    axes = want
    if strategy.max_turn is not None:
        axes = smooth_axes(want, nrm, strategy.max_turn, closed)
        moved = np.einsum("ij,ij->i", axes, want) < math.cos(1e-6)
        flags[moved] |= FLAG_AXIS_SMOOTHED
    tip, zero = cutter.cl_points_and_zero_speed(cc, nrm, axes, req.zero_speed_tol)
    flags[zero] |= FLAG_ZERO_SPEED
    curve.axis = axes
    curve.tip = tip
    curve.flags = curve.flags | flags


def orient_all_local(curves, mesh, faces, cutter, strategy, limits, req):
    """:func:`orient_pass` of every pass (mode "local", no near-field check) with its pointwise
    work — the surface curvatures, the requested axes' gouge margins, the tool axes and tips
    — done once over all the passes' poses (one numpy call each instead of one per pass: at
    Rotor 37's 52 passes the calls' overhead was most of the stage): every pose's figures
    are its own, so the same floats as pass by pass. The frames, the gouge-fix search (its
    chunks and candidates are a pass's) and the axis smoothing stay per pass. Nothing is
    written to the curves: a list of (axes, tips, flags, LocalGougeReport) per pass; an
    error raises out before any pass changes (the caller then orients pass by pass, which
    raises it as that does)."""
    sizes = [len(c.cc) for c in curves]
    ends = np.cumsum(sizes)[:-1]
    frames = [local_frames(c.cc, c.normal, c.closed) for c in curves]
    f, n, k = (np.vstack([fr[j] for fr in frames]) for j in range(3))
    cc = np.vstack([c.cc for c in curves])
    nrm = np.vstack([c.normal for c in curves])
    s = np.concatenate([c.ratios for c in curves])
    face = np.concatenate(faces)
    lead = np.asarray(strategy.at("lead", s), dtype=np.float64).copy()
    tilt = np.asarray(strategy.at("tilt", s), dtype=np.float64).copy()
    kf = surface_normal_curvature(mesh, face, f)
    kk = surface_normal_curvature(mesh, face, k)
    tol = 1e-6  # fix_local_gouges' default
    margin = requested_margin(cutter, f, n, k, lead, tilt, kf, kk)
    flagged = margin < -tol
    left = flagged.copy()
    cuts = [0, *(int(e) for e in ends), len(cc)]
    bounds = list(zip(cuts[:-1], cuts[1:], strict=True))
    if req.fix_local_gouge:
        for a, b in bounds:
            if flagged[a:b].any():  # the pass's own search, its slices written in place
                search_fixes(cutter, f[a:b], n[a:b], k[a:b], lead[a:b], tilt[a:b], kf[a:b],
                             kk[a:b], limits, margin[a:b], flagged[a:b], left[a:b], tol=tol)
    want = lead_tilt_axes(f, n, k, lead, tilt)
    flags = np.zeros(len(cc), dtype=np.uint8)
    flags[flagged & ~left] |= FLAG_GOUGE_FIXED
    flags[left] |= FLAG_LOCAL_GOUGE
    axes = want
    if strategy.max_turn is not None:
        axes = np.vstack([smooth_axes(want[a:b], nrm[a:b], strategy.max_turn, c.closed)
                          for (a, b), c in zip(bounds, curves, strict=True)])
        moved = np.einsum("ij,ij->i", axes, want) < math.cos(1e-6)
        flags[moved] |= FLAG_AXIS_SMOOTHED
    tip, zero = cutter.cl_points_and_zero_speed(cc, nrm, axes, req.zero_speed_tol)
    flags[zero] |= FLAG_ZERO_SPEED
    return [(axes[a:b].copy(), tip[a:b].copy(), flags[a:b].copy(),
             gouge_report(cc[a:b], flagged[a:b], left[a:b], margin[a:b])) for a, b in bounds]


def gouge_report(cc, flagged, left, margin) -> LocalGougeReport:
    """The local gouge check's figures of one pass: its CC points (k, 3) mm, the poses
    ``flagged`` and those ``left`` gouging after the fix ((k,) bool) and their gouge margins
    (k,) 1/mm (the worst of those left, ≤ 0)."""
    return LocalGougeReport(
        n_poses=len(cc),
        n_flagged=int(flagged.sum()),
        n_fixed=int((flagged & ~left).sum()),
        n_left=int(left.sum()),
        worst=float(min(0.0, margin[left].min())) if left.any() else 0.0,
        left_at=cc[left],
    )
