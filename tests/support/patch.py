"""The stock measured under a patch of finishing passes (the semi-finishing tests): the
cutter with its flute cut short, and the deviation at the blade vertices the passes cover and
at the blade points under their middle contacts."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from blisk_cam.core.stock.deviation import deviation_map
from blisk_cam.core.tool.cutter import Cutter


def short_flute(tool) -> Cutter:
    """The cutter of ``tool`` with its flute cut short 1 mm above the corner and no body: its
    side higher up never reaches the blade near the contact, and the sweep's candidate rays
    shrink with it."""
    spec = tool.as_dict()
    spec["h"] = tool.f + 1.0
    return Cutter.from_dict({k: v for k, v in spec.items()
                             if k not in ("shank_diameter", "holder_diameter")})


def deviation_under_passes(stock, surface, ratio, s_lo, s_hi, core, core_n):
    """(dev (m,), P (m, 3)): the deviation (mm) of ``stock`` at the part's blade vertices
    the passes cover and at the blade points under the middle passes' contacts.

    ``surface``: (V, N, outer, on_blade) of the part's surface (``part_surface`` and the
    blade's vertex mask); ``ratio`` (n,): each vertex's morph ratio; ``s_lo``, ``s_hi``: the
    ratios of the second and the last-but-one pass (the covered band); ``core``, ``core_n``:
    per pass, the blade points under its contacts and their normals."""
    V, N, outer, on_blade = surface
    dist, j = cKDTree(np.vstack(core)).query(V)
    facing = np.einsum("ij,ij->i", N, np.vstack(core_n)[j]) > 0.9
    covered = on_blade & outer & facing & (dist < 1.0) & (ratio > s_lo) & (ratio < s_hi)
    assert covered.sum() >= 20
    # the mesh vertices there (between the passes: the scallops) and the blade points under
    # the middle passes' contacts
    inner = slice(len(core[0]), -len(core[-1]))
    P = np.vstack([V[covered], np.vstack(core)[inner]])
    Nn = np.vstack([N[covered], np.vstack(core_n)[inner]])
    return deviation_map(stock, P, Nn, reach_out=1.0, reach_in=0.5), P
