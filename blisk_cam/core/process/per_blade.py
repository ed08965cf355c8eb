"""Per-blade finishing of a whole-blisk scan: every blade gets its own path from its own faces.

A new blisk is one blade's program turned N times (paper 003 §V.A). A repaired or worn blisk is
not: after tip rebuilding or blending each blade differs, so each is planned from its own scan.
The run, blade by blade, each independent of the others:

1. the scan is split into hub and blades by the part model
   (:func:`..part.model.split_blisk_mesh`: faces of revolution = hub, N from the rotational
   symmetry, blade faces grouped by pitch sector); blade k = the faces of sector k
   (:func:`blades_of_scan`), its neighbours = the faces of sectors k ± 1 … k ± j *as scanned*
   (not blade k turned: a rebuilt neighbour may stand closer than the nominal pitch);
2. :func:`plan_blade`: the hub and tip cones fitted to the blade's own boundary loops
   (:mod:`..part.fitting`, the "fit" stage of :mod:`.blade_finish`, paper 001 §2), the LMC
   passes planned (:func:`.blade_finish.plan_paths`), the collision check of paper 004 against
   the actual neighbours (:mod:`..collision.avoid`, neighbour meshes given as obstacles, none
   turned copies), the independent verify and its verdict (:mod:`..verify`), and with a
   machine the inverse kinematics (:func:`..post.blocks.build_blocks`) — a blade that is
   unreachable, keeps unresolved collisions, fails the verdict or raises a
   :class:`..errors.BliskCamError` is a *failed* :class:`BladeOutcome` naming why; it never
   stops the others;
3. :func:`sections_program`: one NC program, one section per blade that passed, each its own
   moves.

Placement: every blade's path is planned where the blade stands in the scan (the blisk's
frame), so no section is a rotated copy and none needs turning into place: the machine's
inverse kinematics turn the table rotary to reach blade k like any other pose. Between
sections the block stream's safe retract (:data:`..post.blocks.SAFE`) indexes the rotaries at
the safe height, as between the blades of a repeated program.

Units: mm, radians (angles in degrees only in messages).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ..collision.options import CollisionOptions
from ..errors import BliskCamError, PostError
from ..geometry.mesh import TriMesh
from ..machine.description import Machine, load_machine
from ..part.model import BliskSplit
from ..post.blocks import Blocks, NcOptions, build_blocks
from ..post.common import PostContext
from ..post.export import get_post
from ..toolpath.types import ToolPath
from ..verify.measure import verify_path
from ..verify.verdict import judge, verdict_dict
from .blade_finish import PathRequest, plan_paths
from .collision_stage import collision_stage

__all__ = ["BladeGeometry", "BladeOutcome", "blades_of_scan", "plan_blade",
           "sections_program"]


@dataclass
class BladeGeometry:
    """One blade of a scan and what stands beside it.

    Attributes
    ----------
    index : int — the blade's number k (its pitch sector, 0..N−1)
    blade_count : int — N
    V : (n, 3) float, mm; F : (m, 3) int64 — the blade's own faces (compact)
    neighbours : list of (name, V, F) — the scanned blades k ± 1 … k ± j ("blade 3")
    """

    index: int
    blade_count: int
    V: np.ndarray
    F: np.ndarray
    neighbours: list = field(default_factory=list)


def _faces_of(V, F, select) -> tuple[np.ndarray, np.ndarray]:
    used, inv = np.unique(F[select], return_inverse=True)
    return np.ascontiguousarray(V[used]), inv.reshape(-1, 3).astype(np.int64)


def blades_of_scan(V, F, split: BliskSplit, neighbours: int = 1) -> list[BladeGeometry]:
    """The N blades of a split whole-blisk mesh, each with its ``neighbours`` scanned
    neighbours per side.

    Parameters
    ----------
    V : (n, 3) float, mm; F : (m, 3) int — the mesh given to
        :func:`..part.model.split_blisk_mesh`
    split : BliskSplit — its result (``split.sector``: the blade of every face, −1 = hub)
    neighbours : int ≥ 0 — blades per side (2·neighbours + 1 ≤ N)

    Returns
    -------
    list of BladeGeometry, blade k at index k
    """
    V = np.asarray(V, np.float64)
    F = np.asarray(F, np.int64)
    n = int(split.blade_count)
    j = int(neighbours)
    if j < 0 or 2 * j + 1 > n:
        raise BliskCamError(f"{j} neighbours per side need {2 * j + 1} blades but the blisk has "
                            f"{n}; use at most {(n - 1) // 2}")
    if len(split.sector) != len(F):
        raise BliskCamError(f"the split is of a mesh with {len(split.sector)} faces, not this "
                            f"one ({len(F)}); split the same mesh")
    own = [_faces_of(V, F, split.sector == k) for k in range(n)]
    out = []
    for k in range(n):
        nb = [(f"blade {(k + s * i) % n}", *own[(k + s * i) % n])
              for i in range(1, j + 1) for s in (-1, 1)]
        out.append(BladeGeometry(k, n, own[k][0], own[k][1], nb))
    return out


@dataclass
class BladeOutcome:
    """What became of one blade.

    Attributes
    ----------
    index : int — blade number k
    ok : bool — planned, collision-free (or every collision corrected), verdict PASS,
        reachable (when a machine was given)
    reason : str or None — why not, in one line for the user
    path : ToolPath or None — the blade's path (kept for a failed blade when it was planned)
    figures : dict — JSON-ready: poses, program rows, length mm, verify maxima mm, collision
        counts, verdict
    blocks : Blocks or None — the blade's solved block stream (with a machine)
    """

    index: int
    ok: bool
    reason: str | None = None
    path: ToolPath | None = None
    figures: dict = field(default_factory=dict)
    blocks: Blocks | None = None


def plan_blade(blade: BladeGeometry, request: PathRequest, collision: CollisionOptions | None =
               None, *, verify: bool = True, machine: Machine | str | None = None,
               post: str | None = None, nc: NcOptions | None = None) -> BladeOutcome:
    """Fit, plan, check collisions against the actual neighbours, verify and (with
    ``machine``) solve one blade. Never raises for the blade's own trouble: a
    :class:`..errors.BliskCamError` becomes a failed outcome naming it.

    Parameters
    ----------
    blade : BladeGeometry
    request : PathRequest — cones None to fit them to this blade (paper 001 §2); the options
    collision : CollisionOptions or None — mode "check" or "avoid"; ``blade_count`` and
        ``neighbours`` are set here (the neighbours come as scanned meshes, none turned)
    verify : bool — measure the path on the blade (:func:`..verify.measure.verify_path`)
    machine, post, nc : the machine (preset, TOML or Machine), post name and NC options to
        solve the blade's blocks (reachability) for :func:`sections_program`

    Returns
    -------
    BladeOutcome
    """
    k = blade.index
    fig: dict = {"blade": k}
    try:
        mesh = TriMesh.from_arrays(blade.V, blade.F)
        extra = ()
        if collision is not None and collision.mode != "off":
            opts = dataclasses.replace(collision, blade_count=max(2, blade.blade_count),
                                       neighbours=0)
            extra = (collision_stage(opts, blade.neighbours),)
        plan = plan_paths(mesh, request, extra=extra)
    except BliskCamError as exc:
        return BladeOutcome(k, False, f"blade {k}: not planned: {_one_line(exc)}", None, fig)
    path = plan.path
    prog = path.program
    fig.update(poses=int(path.n_poses), program_rows=int(len(prog) if prog is not None else 0),
               length_mm=round(float(path.length()), 6))
    reasons = []
    if plan.collision is not None:
        s = path.collision or {}
        fig.update(colliding_before=int(s.get("colliding_before") or 0),
                   collisions_unresolved=int(plan.collision.n_unresolved))
        if plan.collision.n_unresolved:
            reasons.append(f"{plan.collision.n_unresolved} unresolved collision(s) with "
                           f"{', '.join(n for n, *_ in blade.neighbours) or 'the blade'}")
    if verify:
        try:
            report = verify_path(mesh, path)
            verdict = judge(report, request.cusp, request.chord, path.tool, path)
        except BliskCamError as exc:
            reasons.append(f"not verified: {_one_line(exc)}")
        else:
            path.verify = verdict_dict(verdict)
            fig.update(max_material_left_mm=_finite(report.max_material_left),
                       max_gouge_mm=_finite(report.max_gouge), verdict=verdict.status)
            if not verdict.passed:
                bad = [c for c in verdict.checks if not c.passed]
                reasons.append("verify FAIL: " + "; ".join(
                    f"{c.name} {c.value:.4f} mm > {c.bound:.4f} mm" for c in bad))
    blocks = None
    if machine is not None and not reasons:
        try:
            blocks = blade_blocks(path, machine, post or "apt", nc, k)
        except BliskCamError as exc:
            reasons.append(f"unreachable: {_one_line(exc)}")
    if reasons:
        return BladeOutcome(k, False, f"blade {k}: " + "; ".join(reasons), path, fig)
    return BladeOutcome(k, True, None, path, fig, blocks)


def _one_line(exc) -> str:
    return " ".join(str(exc).split())


def _finite(x):
    x = float(x)
    return round(x, 9) if math.isfinite(x) else None


def blade_blocks(path: ToolPath, machine: Machine | str, post: str, nc: NcOptions | None,
                 index: int) -> Blocks:
    """The block stream of one blade's own path (one blade, no repetition, no subprogram),
    every row labelled blade ``index``. ReachError for an unreachable pose."""
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    mod = get_post(post)
    mod.check(machine)
    options = dataclasses.replace(nc or NcOptions(), blades=1, use_subprogram=False)
    b = build_blocks(path, machine, options, indexable=False, solve=getattr(mod, "SOLVE", True))
    b.blade = np.full(len(b), int(index))
    return b


def sections_program(outcomes, machine: Machine | str, post: str,
                     nc: NcOptions | None = None, *, name: str = "blisk") -> str:
    """One NC program with a section per blade that passed (its own solved blocks, in blade
    order); the header lists the blades left out and why.

    Parameters
    ----------
    outcomes : list of BladeOutcome — those with ``ok`` and ``blocks`` are written
    machine, post, nc : as for :func:`..post.export.export_nc` (``nc.blades`` is ignored)
    name : str — the header's blade name (the scan's)

    Returns
    -------
    str — the program text. PostError when no blade passed.
    """
    if not isinstance(machine, Machine):
        machine = load_machine(machine)
    mod = get_post(post)
    mod.check(machine)
    good = sorted((o for o in outcomes if o.ok and o.blocks is not None), key=lambda o: o.index)
    if not good:
        raise PostError("no blade passed, so there is no program to write; see the blades' "
                        "reasons in the summary")
    failed = sorted((o for o in outcomes if not o.ok), key=lambda o: o.index)
    parts = [o.blocks for o in good]
    keys = ("kind", "tip", "axis", "xyz", "angles", "feed", "blade", "source", "singular")
    cat = {key: np.concatenate([getattr(b, key) for b in parts]) for key in keys}
    first = parts[0]
    blocks = Blocks(**cat, blades=len(good), indexed=False, offsets=np.zeros(len(good)),
                    blisk_axis=first.blisk_axis, safe_z=first.safe_z,
                    inserted=sum(b.inserted for b in parts),
                    max_deviation=max(b.max_deviation for b in parts),
                    unresolved=sum(b.unresolved for b in parts))
    notes = [f"one section per blade, each from its own scan: blades "
             f"{', '.join(str(o.index) for o in good)}"]
    notes += [f"NOT WRITTEN: {o.reason}" for o in failed]
    options = dataclasses.replace(nc or NcOptions(), blades=1, blade_name=name,
                                  notes=(*(nc.notes if nc else ()), *notes))
    ctx = PostContext(path=good[0].path, machine=machine, options=options, blocks=blocks,
                      post=mod.NAME)
    return mod.write(ctx)
