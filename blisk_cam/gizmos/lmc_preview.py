"""Live preview of a few LMC curves while a cone handle is dragged (pure numpy, no ``bpy``).

While the user drags P1, P2, Q1 or Q2, the viewport shows the mesh ∩ LMC curves of a few
ratios (paper 001 §3.1: s = 0, 0.5, 1 and some in between) for the cones being dragged. The
expensive part — reading the blade, welding and orienting it (:class:`TriMesh`) and its edge
topology — is done once per blade revision and cached here; each new cone pair only needs a new
:class:`MeshConeSlicer` (the morph field over the vertices) and one slice per level. The
Blender side (:mod:`.cone_gizmos`) supplies a loader for the blade arrays, invalidates the cache
on a depsgraph update of the blade, and throttles the requests with :class:`Throttle`.

Units: mm (core); the drawing code converts to Blender units.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field

import numpy as np

from ..core.cones import Axis, Cone, MorphingCones
from ..core.errors import BliskCamError
from ..core.mesh import TriMesh
from ..core.slicing import MeshConeSlicer

__all__ = ["DEFAULT_LEVELS", "LmcPreview", "PreviewCurve", "PreviewResult", "Throttle"]

#: Ratios s of the preview curves: both end cones, the middle cone and four more.
DEFAULT_LEVELS = tuple(float(s) for s in np.linspace(0.0, 1.0, 7))


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
    mesh_seconds : float — time to read and prepare the mesh (0 when it came from the cache)
    setup_seconds : float — slicer set-up (morph field) for this cone pair
    level_seconds : list of float — slicing time per level
    """

    key: Hashable
    curves: list = field(default_factory=list)
    error: str | None = None
    mesh_seconds: float = 0.0
    setup_seconds: float = 0.0
    level_seconds: list = field(default_factory=list)

    @property
    def seconds_per_curve(self) -> float:
        """Slicer set-up plus slicing, divided by the number of levels (the ≤ 50 ms budget)."""
        n = max(len(self.level_seconds), 1)
        return (self.setup_seconds + sum(self.level_seconds)) / n


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


class LmcPreview:
    """Cache of the prepared blade mesh and of the last preview result.

    Parameters
    ----------
    levels : sequence of float in [0, 1] — the ratios s to slice

    Usage::

        preview = LmcPreview()
        result = preview.compute(mesh_key, load, axis, cone1, cone2)

    ``mesh_key`` identifies the blade geometry (e.g. its name and the unit scale); ``load()``
    returns its ``(V (n, 3) mm, F (m, 3))`` and is only called when the key changed or after
    :meth:`invalidate`. A repeated request with the same key, axis and cones returns the cached
    result without slicing again.
    """

    def __init__(self, levels=DEFAULT_LEVELS):
        lv = np.asarray(levels, dtype=np.float64).reshape(-1)
        if len(lv) == 0 or not np.all(np.isfinite(lv)) or lv.min() < 0.0 or lv.max() > 1.0:
            raise BliskCamError(f"preview levels must be ratios in [0, 1], got {levels!r}")
        self.levels = tuple(float(s) for s in lv)
        self.mesh_key = None
        self.mesh: TriMesh | None = None
        self.result: PreviewResult | None = None
        self.mesh_loads = 0  # how many times the mesh was (re)built — tests watch this

    # --- cache -------------------------------------------------------------------------
    def invalidate(self) -> None:
        """Forget the mesh and the last result (the blade changed)."""
        self.mesh_key = None
        self.mesh = None
        self.result = None

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
        self.mesh_loads += 1
        return mesh, time.perf_counter() - t0

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
            t0 = time.perf_counter()
            slicer = MeshConeSlicer(mesh, axis, morph)
            result.setup_seconds = time.perf_counter() - t0
            for s in self.levels:
                t0 = time.perf_counter()
                curves = slicer.slice(s)
                result.level_seconds.append(time.perf_counter() - t0)
                result.curves.extend(
                    PreviewCurve(s=float(s), points=c.points, closed=c.closed) for c in curves
                )
        except BliskCamError as exc:
            result.curves = []
            result.error = str(exc)
        self.result = result
        return result
