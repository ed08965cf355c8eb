"""The test blades: NASA Rotor 37 and 67 as stored in tests/data/blades (see its README.md: mesh
in mm, the json's least-squares hub and tip cones) and a small analytic blade."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.mesh_io import read_mesh
from blisk_cam.core.part.cones import Cone, MorphingCones

#: NASA Rotor 37 and 67 (public test-case data, see tests/data/blades/README.md)
BLADES = Path(__file__).resolve().parents[1] / "data" / "blades"


def blade_stl(name: str) -> Path:
    """The blade surface of ``name`` ("rotor37" or "rotor67"): binary STL, mm, extended past
    hub and tip, open."""
    return BLADES / f"{name}_blade_extended_open.stl"


def blade_meta(name: str) -> dict:
    """The json of ``name``: axis, blade count, cones, mesh figures, provenance."""
    return json.loads((BLADES / f"{name}_blade.json").read_text())


def blade_cones(name: str) -> tuple[Cone, Cone]:
    """The json's hub and tip cones of ``name``."""
    cones = blade_meta(name)["cones"]
    return (Cone(*cones["hub"]["P1_rz_mm"], *cones["hub"]["P2_rz_mm"]),
            Cone(*cones["tip"]["P1_rz_mm"], *cones["tip"]["P2_rz_mm"]))


def nasa_blade(name: str):
    """V (3 corners per triangle, as read), F, hub cone, tip cone of ``name``."""
    V, F = read_mesh(blade_stl(name))
    return (V, F, *blade_cones(name))


def subdivide(V, F):
    """Midpoint subdivision (×4 triangles), vectorised."""
    E = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    uniq, inv = np.unique(E, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    mid = len(V) + inv.reshape(3, -1).T  # (m, 3): mids of v0v1, v1v2, v2v0
    V2 = np.vstack([V, 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])])
    a, b, c = F.T
    ab, bc, ca = mid.T
    quads = ([a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca])
    return V2, np.concatenate([np.stack(x, 1) for x in quads])


def subdivided_blade(name: str, target: int):
    """:func:`nasa_blade` welded, then subdivided until it has at least ``target / 2``
    triangles (the benchmarks' large blades): V, F, hub cone, tip cone."""
    V, F, c1, c2 = nasa_blade(name)
    m = TriMesh.from_arrays(V, F)
    V, F = m.V, m.F
    while len(F) * 2 < target:
        V, F = subdivide(V, F)
    return V, F, c1, c2


def tube_blade(n_u=96, n_v=40, cone1=(100.0, -10.0, 104.0, 30.0), cone2=(140.0, -10.0, 138.0, 30.0),
               half_thickness=3.0, chord=30.0):
    """A small analytic blade: an elliptic tube whose section at span v lies exactly on the
    LMC at s = v (so the hub loop is on cone 1 and the tip loop on cone 2 to rounding).

    Returns V (n, 3), F (m, 3) outward-oriented, and the MorphingCones.
    """
    mc = MorphingCones(Cone(*cone1), Cone(*cone2))
    u = np.linspace(0, 2 * np.pi, n_u, endpoint=False)
    v = np.linspace(0, 1, n_v)
    uu, vv = np.meshgrid(u, v)
    a, b = mc.generatrix(vv.ravel())
    t = 0.5 + 0.5 * np.cos(uu.ravel()) * (chord / np.linalg.norm(b - a, axis=1)) * 0.9
    rz = a + t[:, None] * (b - a)
    r = rz[:, 0]
    theta = half_thickness * np.sin(uu.ravel()) / r + 0.1 * vv.ravel()
    V = np.stack([r * np.cos(theta), r * np.sin(theta), rz[:, 1]], axis=1)
    idx = np.arange(n_u * n_v).reshape(n_v, n_u)
    i0 = idx[:-1, :]
    i1 = np.roll(idx[:-1, :], -1, axis=1)
    i2 = idx[1:, :]
    i3 = np.roll(idx[1:, :], -1, axis=1)
    F = np.vstack(
        [np.stack([i0, i1, i3], -1).reshape(-1, 3), np.stack([i0, i3, i2], -1).reshape(-1, 3)]
    )
    return V, F, mc
