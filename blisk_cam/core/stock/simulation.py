"""One simulation: a part, a blank, programs run in order, the deviation map and its verdict.

:func:`iter_simulate` is a generator (progress between yields, cancellable between batches,
the Blender operator and the CLI drive the same one) returning a :class:`Simulation`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import StockError
from ..part.model import BliskPart
from ..runtime import Progress
from ..toolpath.types import ToolPath
from .blank import stock_from_allowance
from .deviation import (
    deviation_map,
    resolved_points,
    simulation_summary,
    surface_distance,
    vertex_areas,
    vertex_normals,
)
from .dexels import RadialDexels
from .removal import RemovalResult, simulate_moves

__all__ = ["PartOnGrid", "Simulation", "cut_into", "iter_simulate", "part_on_grid", "part_surface"]


@dataclass
class Simulation:
    """The outcome: the stock after the programs, the removal figures, the part mesh with its
    deviation per vertex (mm; NaN where the vertex is buried in the part: hub faces under a
    blade), the JSON-ready summary, and ``judged`` (n,) bool: the vertices whose deviation the
    verdict judges (on the outer surface and resolved by the stock's grid,
    :func:`.deviation.resolved_points`; the others' readings may be the grid's)."""

    stock: RadialDexels
    removal: RemovalResult
    V: np.ndarray
    F: np.ndarray
    deviation: np.ndarray
    summary: dict
    judged: np.ndarray | None = None


def part_surface(part: BliskPart, resolution: float, *, solid: RadialDexels | None = None):
    """The part mesh of the deviation map: V, F, unit vertex normals (out of the metal) and
    the (n,) mask of vertices on the part's outer surface (hub vertices under the blade, in
    the part's own material, are not). ``solid``: the part as radial dexels of ``resolution``
    when the caller has it (else it is cast here)."""
    V, F, hub = part.part_mesh()
    N = vertex_normals(V, F, (hub, part.axis))
    if solid is None:
        solid = stock_from_allowance(part, 0.0, resolution)
    on_hub = np.zeros(len(V), bool)
    on_hub[np.unique(F[hub])] = True
    on_blade = np.zeros(len(V), bool)
    on_blade[np.unique(F[~hub])] = True
    buried = on_hub & ~on_blade & solid.occupied(V + 2.0 * resolution * N)
    return V, F, N, ~buried


@dataclass(frozen=True)
class PartOnGrid:
    """What every simulation of one part on one stock grid judges against, built once per
    grid (:func:`part_on_grid`; a job's operations share one): ``solid`` the part cast on the
    stock's own rays; the part mesh ``V`` (n, 3) mm, ``F`` (m, 3), unit vertex normals ``N``
    (n, 3) and ``surface`` (n,) bool, the vertices on the outer surface
    (:func:`part_surface`); ``distance`` (m', 3) points → (m',) exact distance (mm) to the
    surface's faces (:func:`.deviation.surface_distance`); ``area`` (n,) mm², each vertex's
    share of the faces' area."""

    solid: RadialDexels
    V: np.ndarray
    F: np.ndarray
    N: np.ndarray
    surface: np.ndarray
    distance: object
    area: np.ndarray

    def fits(self, stock: RadialDexels) -> bool:
        """Whether this was cast on ``stock``'s grid (the same rays)."""
        a, b = self.solid, stock
        return (a.blade_count == b.blade_count and a.n_theta == b.n_theta and a.n_z == b.n_z
                and a.theta0 == b.theta0 and a.z0 == b.z0 and a.resolution == b.resolution
                and a.axis.as_list() == b.axis.as_list())


def part_on_grid(part: BliskPart, stock: RadialDexels) -> PartOnGrid:
    """The :class:`PartOnGrid` of ``part`` on ``stock``'s grid (its rays; the material does
    not matter)."""
    solid = stock_from_allowance(part, 0.0, stock.resolution, grid=stock)
    V, F, N, surface = part_surface(part, stock.resolution, solid=solid)
    return PartOnGrid(solid, V, F, N, surface, surface_distance(V, F[surface[F].any(axis=1)]),
                      vertex_areas(V, F))


def cut_into(paths) -> float | None:
    """How deep the programs ``paths`` (ToolPath) cut into the part at most, mm: each its chord
    less the allowance it leaves (< 0: they stay that far outside the part); None without
    paths."""
    return max((p.chord - float(getattr(p, "allowance", 0.0) or 0.0) for p in paths),
               default=None)


def _check_frame(part: BliskPart, path: ToolPath, k: int):
    a, b = np.asarray(part.axis.as_list()), np.asarray(path.axis.as_list())
    if not (np.allclose(a[:3], b[:3], atol=1e-6) and np.allclose(a[3:], b[3:], atol=1e-9)):
        raise StockError(f"program {k + 1} was planned about the axis {path.axis.as_list()} but "
                         f"the part's axis is {part.axis.as_list()}; simulate in the frame the "
                         "paths were planned in")
    if path.program is None:
        raise StockError(f"program {k + 1} has no linked program (only passes); plan it with "
                         "linking so that every move is known")


def iter_simulate(part: BliskPart, stock: RadialDexels, paths, *, gouge_tolerance=None,
                  reach_out: float = 2.0, reach_in: float = 0.5, assembly=None,
                  check_body: bool = True, cut_into_part: float | None = None,
                  near: list | None = None, frame: PartOnGrid | None = None):
    """Run ``paths`` (ToolPath with programs, in order) on ``stock`` (changed in place);
    yields Progress, returns a :class:`Simulation`. ``gouge_tolerance`` (mm) defaults to the
    largest chord tolerance of the paths plus the stock's resolution. When every program
    leaves stock (``ToolPath.allowance``, semi-finishing) the smallest allowance is the
    surface the verdict judges gouges against.

    Gouges are judged where the grid resolves them (:func:`.deviation.resolved_points`, with
    the part plus that allowance cast on the stock's own rays); the map reads inward to
    twice the tolerance plus a cell at least (``reach_in``), so a gouge past the tolerance
    reads as one (deeper ones read as that depth: "at least"). How deep a clean program cuts
    below the judged surface (``resolved_points``' ``cut_depth``) is taken from the paths: each
    cuts its chord into the surface it leaves (its allowance), so ``chord − allowance`` into the
    part (< 0: it stays that far outside); ``cut_into_part`` (mm, the same figure) adds what
    earlier operations on this stock cut. ``near``: a list collecting the rows whose rapid or
    body met material the crash test let pass (:func:`.removal.simulate_moves`; rows counted
    over ``paths`` in order), for :mod:`.fine_check`. ``frame``: :func:`part_on_grid` of this
    part on this stock's grid when the caller has it (a job: one for all its operations)."""
    paths = list(paths)
    for k, p in enumerate(paths):
        _check_frame(part, p, k)
    if stock.blade_count != part.blade_count:
        raise StockError(f"the stock is for {stock.blade_count} blades, the part has "
                         f"{part.blade_count}; use a stock made for this part")
    if frame is not None and not frame.fits(stock):
        raise StockError("the part's frame was cast on another stock grid; build it with "
                         "part_on_grid(part, stock) for this stock")
    if gouge_tolerance is None:
        gouge_tolerance = max([p.chord for p in paths] + [0.0]) + stock.resolution
    initial = stock.volume()
    total = RemovalResult(removed={}, rows=0)
    n_rows = sum(len(p.program) for p in paths) or 1
    offset = 0
    for p in paths:
        gen = simulate_moves(stock, p.program, p.tool, assembly, check_body=check_body,
                             row_offset=offset, near=near)
        while True:
            try:
                pr = next(gen)
            except StopIteration as stop:
                res = stop.value
                break
            yield Progress(0.9 * (offset + pr.fraction * len(p.program)) / n_rows, pr.message)
        for k, v in res.removed.items():
            total.removed[k] = total.removed.get(k, 0.0) + v
        total.crashes += res.crashes
        total.rows += res.rows
        total.sub_poses += res.sub_poses
        total.pairs += res.pairs
        offset += len(p.program)
    yield Progress(0.9, "measuring the deviation on the part")
    tol = float(gouge_tolerance)
    # a gouge deeper than reach_in reads as −reach_in: the map must see past the tolerance
    reach_in = max(float(reach_in), 2.0 * tol + stock.resolution)
    allowance = min((float(getattr(p, "allowance", 0.0) or 0.0) for p in paths), default=0.0)
    # the part on the stock's own rays: where the grid resolves a gouge past the tolerance
    if frame is None:
        frame = part_on_grid(part, stock)
    solid, V, F, N, surface = frame.solid, frame.V, frame.F, frame.N, frame.surface
    dev = np.full(len(V), np.nan)
    dev[surface] = deviation_map(stock, V[surface], N[surface], reach_out=reach_out,
                                 reach_in=reach_in)
    # how deep into the part the programs (and the earlier ones) cut, mm (< 0: outside it)
    into = [x for x in (cut_into(paths), cut_into_part) if x is not None]
    resolved = resolved_points(solid, V[surface], N[surface], tol, frame.distance,
                               cut_depth=max(0.0, allowance + max(map(float, into), default=0.0)),
                               allowance=allowance)
    summary = simulation_summary(part, stock, total, V[surface], dev[surface],
                                 gouge_tolerance=tol, initial_volume=initial,
                                 allowance=allowance, resolved=resolved,
                                 area=frame.area[surface])
    judged = np.zeros(len(V), bool)
    judged[np.flatnonzero(surface)] = np.asarray(resolved, bool) & np.isfinite(dev[surface])
    yield Progress(1.0, "done")
    return Simulation(stock, total, V, F, dev, summary, judged)
