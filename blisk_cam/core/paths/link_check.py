"""The swept cutter of an on-surface link against the part (issue 28).

A link kept on the surface (:func:`.linking.build_program`) places the cutter on projected
points of the straight step between two passes; around a sharp trailing edge or across a
concave corner the cutter posed there, or swept between two such poses, can cut into the
part although every pose of the passes clears it. :class:`SweptLinkCheck` measures how deep
the posed cutter goes below the mesh along a polyline of poses (the tip and the axis
interpolated linearly between them, the axis renormalised, as the machine moves and as
:mod:`..verify.links` measures it) so that linking can send a link that cuts deeper than the
chord tolerance through the air instead.

Sampling: between two samples spaced h apart on a ball of radius ρ the swept solid differs
from the union of the sampled balls by at most ``ρ − √(ρ² − h²/4) ≈ h²/(8ρ)``; samples are
spaced ``h = √(2 ρ tol)``, i.e. at most tol/4 is missed (ρ the corner radius of a bull nose;
tol/2 for a flat end, whose edge is sharp).

Lengths mm.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.distance import MeshDistance
from ..geometry.mesh import TriMesh

__all__ = ["SweptLinkCheck"]


class SweptLinkCheck:
    """How deep a cutter moving through poses cuts into a mesh; counts the links re-routed.

    Parameters
    ----------
    mesh : TriMesh — the part (outward normals)
    cutter : Cutter — the path's cutter
    tolerance : float, mm — the depth a link may cut (the chord tolerance)
    distance : MeshDistance or None — a prebuilt distance structure on ``mesh``

    Attributes
    ----------
    rerouted : int — links reported by :meth:`reroute`
    worst : float, mm — the deepest cut those links would have made
    rapids, rapids_worst : int, float mm — planned routes via the clearance surface between
        passes that cut the part deeper than the tolerance (kept), their deepest cut
    still, still_depth : int, float mm — of the re-routed links, those that every route
        through the air cuts too (the least deep is taken), and the deepest such cut
    """

    def __init__(self, mesh: TriMesh, cutter, tolerance: float, *, distance=None):
        self.cutter = cutter
        self.tolerance = float(tolerance)
        self._md = MeshDistance(mesh) if distance is None else distance
        self._ball = cutter.type == "ball"
        self._rho = float(cutter.radius) if self._ball else float(getattr(cutter, "r", 0.0))
        edge = self._rho if self._rho > 0 else 0.0
        self.spacing = (
            math.sqrt(2.0 * edge * self.tolerance) if edge > 0 else 0.5 * self.tolerance
        )
        self.rerouted = 0
        self.worst = 0.0
        self.still = 0
        self.still_depth = 0.0
        self.rapids = 0
        self.rapids_worst = 0.0
        self._memo = {}  # point bytes → (signed distance, closest point) (:meth:`_closest`)

    def depth(self, tips, axes) -> float:
        """The deepest cut (mm, ≥ 0) of the cutter moving through the poses ``tips`` (k, 3),
        ``axes`` (k, 3) unit (k ≥ 1)."""
        T = np.asarray(tips, dtype=np.float64).reshape(-1, 3)
        A = np.asarray(axes, dtype=np.float64).reshape(-1, 3)
        if len(T) > 1:
            L = np.linalg.norm(np.diff(T, axis=0), axis=1)
            n = np.maximum(1, np.ceil(L / self.spacing).astype(np.int64))
            seg = np.repeat(np.arange(len(L)), n)
            t = (np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n)
            t = t[:, None]
            T = np.vstack([T[seg] * (1 - t) + T[seg + 1] * t, T[-1:]])
            A = np.vstack([A[seg] * (1 - t) + A[seg + 1] * t, A[-1:]])
            A = A / np.maximum(np.linalg.norm(A, axis=1), 1e-300)[:, None]
        if self._ball:
            sd, _ = self._closest(T + self._rho * A)
            d = self._rho - sd
        else:
            r = float(self.cutter.radius)
            _, point = self._closest(T + r * A)
            d = -self.cutter.signed_distance(point, T, A)
        return max(0.0, float(np.max(d)))

    def _closest(self, Q):
        """(signed distance (k,), closest point (k, 3)) of the (k, 3) points ``Q`` (mm) on
        the mesh, each point measured once per check: the routes tried for one link share
        their ends and often more (the two routes via the clearance surface are the same
        where the tool axes lead radially), and a closed pass starts and ends on the same
        pose, the end of one link and the start of the next. Each point's answer is its
        own (:meth:`..geometry.distance.MeshDistance.query` answers every point alone), so
        the figures are those of querying every point."""
        keys = [row.tobytes() for row in Q]
        memo = self._memo
        new = {}
        for i, key in enumerate(keys):
            if key not in memo and key not in new:
                new[key] = i
        if new:
            rows = np.fromiter(new.values(), dtype=np.int64, count=len(new))
            q = self._md.query(Q[rows])
            sd, point = q.signed_distance, q.point
            for j, key in enumerate(new):
                memo[key] = (sd[j], point[j])
        got = [memo[key] for key in keys]
        return (np.array([g[0] for g in got], dtype=np.float64),
                np.array([g[1] for g in got], dtype=np.float64).reshape(-1, 3))

    def reroute(self, depth: float, left: float = 0.0) -> None:
        """Record a link sent through the air because it would have cut ``depth`` mm; its
        route through the air still cuts ``left`` mm (0: within the tolerance)."""
        self.rerouted += 1
        self.worst = max(self.worst, float(depth))
        if left > self.tolerance:
            self.still += 1
            self.still_depth = max(self.still_depth, float(left))

    def rapids_cut(self, depth: float) -> None:
        """Record a planned route via the clearance surface (between passes, into the first or
        out of the last) that cuts
        ``depth`` mm (kept: collision avoidance re-routes such routes; counted when deeper
        than the tolerance)."""
        if depth > self.tolerance:
            self.rapids += 1
            self.rapids_worst = max(self.rapids_worst, float(depth))

    def warnings(self) -> list[str]:
        """The messages for the user (empty when nothing was re-routed)."""
        out = []
        w = self.warning()
        if w:
            out.append(w)
        if self.rapids:
            k = self.rapids
            out.append(
                f"{k} route{'s' if k != 1 else ''} via the clearance surface "
                f"cut{'s' if k == 1 else ''} the blade by up to {self.rapids_worst:.3f} mm "
                "(the rapids run straight through it): run collision avoidance "
                "(--collisions avoid) to re-route them"
            )
        return out

    def warning(self) -> str | None:
        """The message for the user, or None when no link was re-routed."""
        if not self.rerouted:
            return None
        k = self.rerouted
        return (
            f"{k} link{'s' if k != 1 else ''} re-routed through the air: kept on the surface "
            f"{'they' if k != 1 else 'it'} would have cut the blade by up to {self.worst:.3f} mm "
            f"(chord tolerance {self.tolerance:g} mm)"
            + (
                f"; {self.still} of them still cut{'s' if self.still == 1 else ''} up to "
                f"{self.still_depth:.3f} mm through the air: run collision avoidance"
                if self.still
                else ""
            )
        )
