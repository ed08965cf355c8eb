"""Live preview of a few LMC curves while a cone handle is dragged (pure numpy, no ``bpy``).

While the user drags P1, P2, Q1 or Q2, the viewport shows the mesh ∩ LMC curves of a few
ratios (paper 001 §3.1: s = 0, 0.5, 1 and some in between) for the cones being dragged. What
does not depend on the cones is done once per blade revision (and axis) and cached here:
reading the blade, welding and orienting it (:class:`TriMesh`), its edge topology, and a
:class:`MeridionalIndex` — the vertices' meridional coordinates (r, z) and the faces binned on
a grid of the (r, z) half-plane. A level's LMC is a straight line in that half-plane, so a drag
step finds the faces that can cross one of the preview levels from the grid cells the lines
pass (a few per cent of the faces), builds a :class:`MeshConeSlicer` on just those faces and
slices it: the same curves as a slicer on the whole mesh (every crossed face is kept, vertex
order and edge direction preserved), for a cost that grows with the curves, not the mesh. The
Blender side (:mod:`.cone_gizmos`) supplies a loader for the blade arrays, invalidates the
cache on a depsgraph update of the blade, and throttles the requests with :class:`Throttle`.

Units: mm (core); the drawing code converts to Blender units.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field

import numpy as np

from ..core.errors import BliskCamError
from ..core.geometry.axis import Axis, meridional
from ..core.geometry.mesh import TriMesh
from ..core.part.cones import Cone, MorphingCones
from ..core.paths.slicing import MeshConeSlicer

__all__ = ["DEFAULT_LEVELS", "LmcPreview", "MeridionalIndex", "PreviewCurve", "PreviewResult",
           "Throttle"]

#: Ratios s of the preview curves: both end cones, the middle cone and four more.
DEFAULT_LEVELS = tuple(float(s) for s in np.linspace(0.0, 1.0, 7))
#: the slicer's on-cone tolerance (mm), as ``MeshConeSlicer``'s default
_ON_TOL = 1e-4


@dataclass(frozen=True)
class PreviewCurve:
    """One preview polyline: ``points`` (k, 3) float64 in mm (world), on the LMC at ``s``."""

    s: float
    points: np.ndarray
    closed: bool


@dataclass
class PreviewResult:
    """The preview of one cone pair.

    Attributes
    ----------
    key : the request key it answers (mesh key, axis, cones, levels)
    curves : list of PreviewCurve (all components of every level)
    error : str or None — why there is nothing to show (bad cones, unusable mesh)
    mesh_seconds : float — time to read and prepare the mesh and its meridional index (0 when
        both came from the cache)
    setup_seconds : float — slicer set-up for this cone pair (the faces near the levels, their
        submesh and its morph field)
    faces_sliced : int — faces of the mesh the slicer was built on (all, or those near the
        levels)
    level_seconds : list of float — slicing time per level sliced
    levels_reused : int — levels whose LMC did not move since the last result: their curves
        are reused, not sliced again
    """

    key: Hashable
    curves: list = field(default_factory=list)
    error: str | None = None
    mesh_seconds: float = 0.0
    setup_seconds: float = 0.0
    level_seconds: list = field(default_factory=list)
    faces_sliced: int = 0
    levels_reused: int = 0

    @property
    def seconds_per_curve(self) -> float:
        """Slicer set-up plus slicing, divided by the number of levels (the ≤ 50 ms budget)."""
        n = max(len(self.level_seconds), 1)
        return (self.setup_seconds + sum(self.level_seconds)) / n

    @property
    def seconds_per_step(self) -> float:
        """Slicer set-up plus every level: one preview update while dragging."""
        return self.setup_seconds + sum(self.level_seconds)


class Throttle:
    """At most one action every ``interval`` seconds.

    ``ready()`` is True (and restarts the interval) when at least ``interval`` seconds have
    passed since the last time it was True; ``remaining()`` is the wait until then.

    Parameters
    ----------
    interval : float, seconds ≥ 0
    clock : callable returning seconds (default ``time.monotonic``; tests pass a fake clock)
    """

    def __init__(self, interval: float = 0.1, clock: Callable[[], float] = time.monotonic):
        interval = float(interval)
        if not interval >= 0.0:
            raise BliskCamError(f"throttle interval must be ≥ 0 seconds, got {interval!r}")
        self.interval = interval
        self.clock = clock
        self._last = None

    def ready(self) -> bool:
        now = self.clock()
        if self._last is None or now - self._last >= self.interval:
            self._last = now
            return True
        return False

    def remaining(self) -> float:
        if self._last is None:
            return 0.0
        return max(0.0, self.interval - (self.clock() - self._last))

    def mark(self) -> None:
        """Start the interval now (e.g. at the end of the action it throttles)."""
        self._last = self.clock()

    def reset(self) -> None:
        self._last = None


class MeridionalIndex:
    """The faces of a mesh binned on a grid of the meridional half-plane (r, z) of an axis.

    An LMC at ratio s is the line f_s(r, z) = α r + β z + γ = 0 of that half-plane
    (``MorphingCones.line_coefficients``; paper 001 Eq. 4–5); a face can only cross it where
    its vertices' (r, z) are on both sides. Each face goes to the cell of the centre of its
    vertices' (r, z) box, and each cell keeps the union of its faces' boxes: since f_s is
    affine, its extremes over a box are at corners, so a whole cell is ruled out with four
    products; so is each face of a cell left. :meth:`faces_near` returns the faces whose box
    comes within ``tol`` of a level's line — a superset of the faces the slicer's crossing
    test can select (vertices on both sides, or on the LMC within its ``on_tol`` ≤ ``tol``).

    Parameters
    ----------
    mesh : TriMesh (V (n, 3) mm, F (m, 3))
    axis : Axis
    faces_per_cell : int — the grid size: about m / faces_per_cell cells
    """

    def __init__(self, mesh: TriMesh, axis: Axis, faces_per_cell: int = 16):
        self.axis = axis
        r, z = meridional(mesh.V, axis)  # (n,) mm
        F = mesh.F
        fr, fz = r[F], z[F]  # (m, 3)
        rlo, rhi = fr.min(axis=1), fr.max(axis=1)
        zlo, zhi = fz.min(axis=1), fz.max(axis=1)
        m = len(F)
        r0, r1 = float(rlo.min()), float(rhi.max())
        z0, z1 = float(zlo.min()), float(zhi.max())
        wr, wz = max(r1 - r0, 1e-9), max(z1 - z0, 1e-9)
        cells = max(1.0, m / max(int(faces_per_cell), 1))
        nr = int(np.clip(np.sqrt(cells * wr / wz), 1, 4096))
        nz = int(np.clip(cells / nr, 1, 4096))
        ir = np.clip(((0.5 * (rlo + rhi) - r0) / wr * nr).astype(np.int64), 0, nr - 1)
        iz = np.clip(((0.5 * (zlo + zhi) - z0) / wz * nz).astype(np.int64), 0, nz - 1)
        cell = ir * nz + iz
        order = np.argsort(cell, kind="stable")
        cs = cell[order]
        starts = np.flatnonzero(np.r_[True, cs[1:] != cs[:-1]])
        self.faces = order  # (m,) face ids grouped by cell, ascending within a cell
        self.start = starts  # (k,) first position of each non-empty cell in ``faces``
        self.count = np.diff(np.r_[starts, m])  # (k,)
        # each face's (r, z) box, in the order of ``faces``: (m,) each
        self.box = tuple(np.ascontiguousarray(x[order]) for x in (rlo, rhi, zlo, zhi))
        # the union of its faces' boxes per cell: (k,) each
        self.cell_box = (np.minimum.reduceat(self.box[0], starts),
                         np.maximum.reduceat(self.box[1], starts),
                         np.minimum.reduceat(self.box[2], starts),
                         np.maximum.reduceat(self.box[3], starts))
        self.n_faces = m
        self.shape = (nr, nz)

    @staticmethod
    def _range(a: float, b: float, c: float, box, idx=None):
        """(min, max) of f = a r + b z + c over each (r, z) box (at its corners: f is
        affine); ``box`` = (rlo, rhi, zlo, zhi), optionally taken at ``idx``."""
        rlo, rhi, zlo, zhi = box if idx is None else (x[idx] for x in box)
        ar_lo, ar_hi = (a * rlo, a * rhi) if a >= 0.0 else (a * rhi, a * rlo)
        bz_lo, bz_hi = (b * zlo, b * zhi) if b >= 0.0 else (b * zhi, b * zlo)
        return ar_lo + bz_lo + c, ar_hi + bz_hi + c

    def faces_near(self, morph: MorphingCones, levels, tol: float) -> np.ndarray:
        """Ascending ids of the faces whose vertices' (r, z) box reaches within ``tol`` of
        the line of some level: f_s ≤ tol somewhere on the box and f_s ≥ −tol somewhere
        (f_s: signed meridional distance, mm, to the LMC at s). A superset of the faces
        with vertices on both sides of a level (or on it within ``tol``).

        Parameters
        ----------
        morph : MorphingCones
        levels : sequence of float — ratios s
        tol : float, mm ≥ 0
        """
        picked = []
        for s in levels:
            a, b, c = morph.line_coefficients(float(s))
            lo, hi = self._range(a, b, c, self.cell_box)
            near = np.flatnonzero((lo <= tol) & (hi >= -tol))
            if len(near) == 0:
                continue
            # the positions in ``faces`` of those cells' faces (concatenated ranges)
            cnt = self.count[near]
            pos = np.repeat(self.start[near] - np.cumsum(cnt) + cnt, cnt) + np.arange(cnt.sum())
            lo, hi = self._range(a, b, c, self.box, pos)
            picked.append(pos[(lo <= tol) & (hi >= -tol)])
        if not picked:
            return np.zeros(0, dtype=np.int64)
        return np.sort(self.faces[np.unique(np.concatenate(picked))])


class LmcPreview:
    """Cache of the prepared blade mesh, its meridional index and the last preview result.

    Parameters
    ----------
    levels : sequence of float in [0, 1] — the ratios s to slice
    indexed : bool — slice only the faces near the levels (:class:`MeridionalIndex`, the
        default); False builds the slicer on the whole mesh for every cone pair (the
        reference the index is checked and benchmarked against)

    Usage::

        preview = LmcPreview()
        result = preview.compute(mesh_key, load, axis, cone1, cone2)

    ``mesh_key`` identifies the blade geometry (e.g. its name and the unit scale); ``load()``
    returns its ``(V (n, 3) mm, F (m, 3))`` and is only called when the key changed or after
    :meth:`invalidate`. A repeated request with the same key, axis and cones returns the cached
    result without slicing again.
    """

    #: above this share of the faces near the levels, the whole mesh is sliced instead
    SUBMESH_SHARE = 0.5

    def __init__(self, levels=DEFAULT_LEVELS, *, indexed: bool = True):
        lv = np.asarray(levels, dtype=np.float64).reshape(-1)
        if len(lv) == 0 or not np.all(np.isfinite(lv)) or lv.min() < 0.0 or lv.max() > 1.0:
            raise BliskCamError(f"preview levels must be ratios in [0, 1], got {levels!r}")
        self.levels = tuple(float(s) for s in lv)
        self.mesh_key = None
        self.mesh: TriMesh | None = None
        self.result: PreviewResult | None = None
        self.mesh_loads = 0  # how many times the mesh was (re)built — tests watch this
        self.indexed = bool(indexed)
        self.index: MeridionalIndex | None = None
        self.index_builds = 0
        self._levels: dict = {}  # level key → its PreviewCurves, of the last result (indexed)

    # --- cache -------------------------------------------------------------------------
    def invalidate(self) -> None:
        """Forget the mesh and the last result (the blade changed)."""
        self.mesh_key = None
        self.mesh = None
        self.result = None
        self.index = None
        self._levels = {}

    def has_mesh(self, mesh_key=None) -> bool:
        """True when a prepared mesh is cached (for ``mesh_key`` if given)."""
        return self.mesh is not None and (mesh_key is None or mesh_key == self.mesh_key)

    def mesh_for(self, mesh_key, load) -> tuple[TriMesh, float]:
        """The prepared mesh for ``mesh_key`` (built with ``load()`` if not cached) and the
        seconds it took to build (0.0 from the cache)."""
        if self.mesh is not None and self.mesh_key == mesh_key:
            return self.mesh, 0.0
        t0 = time.perf_counter()
        V, F = load()
        mesh = TriMesh.from_arrays(V, F)
        _ = mesh.edges, mesh.vertex_normals  # topology and normals once, not per cone pair
        self.mesh, self.mesh_key = mesh, mesh_key
        self.result = None
        self.index = None
        self._levels = {}
        self.mesh_loads += 1
        return mesh, time.perf_counter() - t0

    def index_for(self, mesh: TriMesh, axis: Axis) -> tuple[MeridionalIndex, float]:
        """The meridional index of the cached mesh about ``axis`` (built if not cached) and
        the seconds it took to build (0.0 from the cache)."""
        if self.index is not None and self.index.axis.as_list() == axis.as_list():
            return self.index, 0.0
        t0 = time.perf_counter()
        self.index = MeridionalIndex(mesh, axis)
        self.index_builds += 1
        return self.index, time.perf_counter() - t0

    def slicer_for(self, mesh: TriMesh, axis: Axis, morph: MorphingCones, levels=None):
        """The slicer of a cone pair for ``levels`` (default: all): on the faces near them
        (indexed) or on the whole mesh; None when no face comes near one (nothing to show)."""
        if not self.indexed:
            return MeshConeSlicer(mesh, axis, morph)
        index, _ = self.index_for(mesh, axis)
        # 10 × the slicer's on-cone tolerance: a superset of the faces its test can select
        levels = self.levels if levels is None else levels
        faces = index.faces_near(morph, levels, 10.0 * _ON_TOL)
        if len(faces) == 0:
            return None
        if len(faces) > self.SUBMESH_SHARE * mesh.n_faces:
            return MeshConeSlicer(mesh, axis, morph, on_tol=_ON_TOL)
        return MeshConeSlicer(mesh.submesh(faces), axis, morph, on_tol=_ON_TOL)

    @staticmethod
    def request_key(mesh_key, axis: Axis, cone1, cone2, levels) -> tuple:
        return (
            mesh_key,
            tuple(axis.as_list()),
            tuple(float(x) for x in cone1),
            tuple(float(x) for x in cone2),
            tuple(levels),
        )

    def is_current(self, mesh_key, axis: Axis, cone1, cone2) -> bool:
        """True when the cached result answers exactly this request."""
        return self.result is not None and self.result.key == self.request_key(
            mesh_key, axis, cone1, cone2, self.levels
        )

    # --- work --------------------------------------------------------------------------
    def compute(self, mesh_key, load, axis: Axis, cone1, cone2) -> PreviewResult:
        """The preview curves for a cone pair (cached for a repeated request).

        Bad cones (crossing, coincident, r < 0) or an unusable mesh do not raise: the result
        carries the reason in ``error`` and no curves, so a drag through an invalid position
        shows the problem instead of stopping the interaction.

        Parameters
        ----------
        mesh_key : hashable — identifies the blade geometry
        load : callable → (V (n, 3) float mm, F (m, 3) int)
        axis : Axis (mm)
        cone1, cone2 : four numbers r1, z1, r2, z2 (mm)
        """
        key = self.request_key(mesh_key, axis, cone1, cone2, self.levels)
        if self.result is not None and self.result.key == key and self.mesh_key == mesh_key:
            return self.result
        result = PreviewResult(key=key)
        try:
            morph = MorphingCones(Cone(*cone1), Cone(*cone2))
            mesh, result.mesh_seconds = self.mesh_for(mesh_key, load)
            if self.indexed:
                _, t_index = self.index_for(mesh, axis)
                result.mesh_seconds += t_index
            # a level whose LMC did not move (s = 1 while cone 1 is dragged, s = 0 for cone 2)
            # keeps its curves: they depend on the level's line (and s) only
            keys = {s: self._level_key(axis, morph, s) for s in self.levels}
            done = {s: self._levels[keys[s]] for s in self.levels if keys[s] in self._levels}
            todo = [s for s in self.levels if s not in done]
            t0 = time.perf_counter()
            slicer = self.slicer_for(mesh, axis, morph, todo) if todo else None
            result.setup_seconds = time.perf_counter() - t0
            result.faces_sliced = 0 if slicer is None else slicer.mesh.n_faces
            result.levels_reused = len(done)
            for s in todo if slicer is not None else ():
                t0 = time.perf_counter()
                curves = slicer.slice(s)
                result.level_seconds.append(time.perf_counter() - t0)
                done[s] = [PreviewCurve(s=float(s), points=c.points, closed=c.closed)
                           for c in curves]
            for s in self.levels:
                result.curves.extend(done.get(s, []))
            if self.indexed:
                self._levels = {keys[s]: done.get(s, []) for s in self.levels}
        except BliskCamError as exc:
            result.curves = []
            result.error = str(exc)
            self._levels = {}
        self.result = result
        return result

    @staticmethod
    def _level_key(axis: Axis, morph: MorphingCones, s: float) -> tuple:
        """What a level's curves depend on: the mesh (the cache is per mesh), the axis, s
        (the end levels snap differently) and the level's line (α, β, γ) in (r, z)."""
        return (tuple(axis.as_list()), float(s), *morph.line_coefficients(float(s)))
