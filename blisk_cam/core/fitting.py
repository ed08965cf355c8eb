"""Fit the hub cone (cone 1) and the tip cone (cone 2) to a blade mesh's boundary loops.

Paper 001 §2.1: the hub and tip boundaries of a blade on a blisk lie on two cones. An open
blade mesh (hub and tip not capped) has a boundary loop at each end; we fit a cone to each by
least squares in the meridional (r, z) plane (:func:`.cones.fit_cone`), report the residual,
and tell hub from tip by the mean radius (the hub is nearer the axis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .cones import Axis, Cone, fit_cone, meridional
from .errors import ConeError
from .mesh import TriMesh

__all__ = ["ConeFit", "fit_cones_to_mesh"]


@dataclass
class ConeFit:
    """Result of :func:`fit_cones_to_mesh`.

    cone1, cone2 : Cone — hub and tip cones
    residual1, residual2 : float, mm — largest meridional distance of a loop vertex from its cone
    hub_loop, tip_loop : (k,) int — vertex ids of the loops used
    other_loops : int — further boundary loops (holes) that were not used
    """

    cone1: Cone
    cone2: Cone
    residual1: float
    residual2: float
    hub_loop: np.ndarray
    tip_loop: np.ndarray
    other_loops: int = 0


def fit_cones_to_mesh(mesh: TriMesh, axis: Axis, *, extend: float = 2.0) -> ConeFit:
    """Fit cone 1 to the hub boundary loop and cone 2 to the tip boundary loop.

    Parameters
    ----------
    mesh : TriMesh — an open blade (hub and tip ends open)
    axis : Axis
    extend : float, mm — the generatrix segments extend this far past the loops' extent

    Raises
    ------
    ConeError when the mesh has fewer than two boundary loops (e.g. a capped, watertight
    blade) — then the cones must be given explicitly.
    """
    loops = [lp for lp in mesh.boundary_loops() if len(lp) >= 3]
    if len(loops) < 2:
        raise ConeError(
            f"the blade mesh has {len(loops)} open boundary loop(s), need two (hub and tip) to "
            "fit the cones: delete the hub and tip caps of a closed blade, or give the cones "
            "explicitly (--cone1/--cone2, or the Region panel)"
        )
    # the two longest loops are hub and tip; others are holes
    lengths = [np.linalg.norm(np.diff(mesh.V[np.r_[lp, lp[:1]]], axis=0), axis=1).sum() for lp in loops]
    order = np.argsort(lengths)[::-1]
    a, b = loops[order[0]], loops[order[1]]
    ra = meridional(mesh.V[a], axis)[0].mean()
    rb = meridional(mesh.V[b], axis)[0].mean()
    hub, tip = (a, b) if ra <= rb else (b, a)
    c1, res1, _ = fit_cone(mesh.V[hub], axis, extend=extend)
    c2, res2, _ = fit_cone(mesh.V[tip], axis, extend=extend)
    return ConeFit(c1, c2, res1, res2, hub, tip, other_loops=len(loops) - 2)
