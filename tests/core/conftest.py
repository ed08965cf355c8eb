"""Shared fixtures for the core tests: real NASA blades and small analytic meshes."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from blisk_cam.core.cones import Axis, Cone, MorphingCones

SHARED = Path(__file__).resolve().parents[2].parent / "shared"
# the blades: $BLISK_CAM_BLADES, else tests/data/blades in the repository, else shared/ beside
# the repository (a git worktree elsewhere sets the variable)
_REPO_BLADES = Path(__file__).resolve().parents[1] / "data" / "blades"
BLADES = Path(
    os.environ.get("BLISK_CAM_BLADES")
    or (_REPO_BLADES if _REPO_BLADES.is_dir() else SHARED / "data" / "blades")
)


def read_binary_stl(path):
    """(V (3m, 3), F (m, 3)) of a binary STL, unwelded (tests only; the product reads
    meshes through Blender's importers)."""
    raw = Path(path).read_bytes()
    n = int(np.frombuffer(raw, dtype="<u4", count=1, offset=80)[0])
    rec = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    data = np.frombuffer(raw, dtype=rec, count=n, offset=84)
    V = data["v"].reshape(-1, 3).astype(np.float64)
    return V, np.arange(len(V)).reshape(-1, 3)


def nasa_blade(name):
    stl = BLADES / f"{name}_blade_extended_open.stl"
    meta = BLADES / f"{name}_blade.json"
    if not stl.exists():
        pytest.skip(f"NASA blade data not found at {BLADES} (shared/ must sit beside the repo)")
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
