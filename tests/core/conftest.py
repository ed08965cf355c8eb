"""Shared fixtures for the core tests: real NASA blades and small analytic meshes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh_io import read_mesh as read_binary_stl  # binary STL → (V, F)
from blisk_cam.core.part.cones import Cone, MorphingCones

#: NASA Rotor 37 and 67 (public test-case data, see tests/data/blades/README.md)
BLADES = Path(__file__).resolve().parents[1] / "data" / "blades"


def write_binary_stl(path, V, F):
    """Write (V (n, 3) mm, F (m, 3)) as a binary STL (float32, zero normals); returns str."""
    tri = np.asarray(V)[np.asarray(F)].astype("<f4")
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["v"] = tri
    Path(path).write_bytes(b"\0" * 80 + np.uint32(len(tri)).tobytes() + rec.tobytes())
    return str(path)


def nasa_blade(name):
    stl = BLADES / f"{name}_blade_extended_open.stl"
    meta = BLADES / f"{name}_blade.json"
    V, F = read_binary_stl(stl)
    cones = json.loads(meta.read_text())["cones"]
    c1 = Cone(*cones["hub"]["P1_rz_mm"], *cones["hub"]["P2_rz_mm"])
    c2 = Cone(*cones["tip"]["P1_rz_mm"], *cones["tip"]["P2_rz_mm"])
    return V, F, c1, c2


@pytest.fixture(scope="session")
def rotor37():
    return nasa_blade("rotor37")


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


@pytest.fixture
def tube():
    return tube_blade()


AXIS = Axis()


@pytest.fixture
def make_tube():
    """The :func:`tube_blade` factory, for tests that need other parameters."""
    return tube_blade
