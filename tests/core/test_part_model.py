"""The blisk part model (core/part/model.py): the whole-blisk split finds N and separates hub
and blade faces exactly (the demo blisk with a full hub ring; NASA Rotor 37 patterned to its
36 blades on a revolved hub), and says clearly when it cannot."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.errors import PartError
from blisk_cam.core.geometry.axis import Axis, revolve
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.vectors import rotate_about
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import (
    blade_count_from_symmetry,
    part_from_blade,
    part_from_demo,
    read_rz_csv,
    split_blisk_mesh,
    theta_about,
)
from tests.support.blades import nasa_blade
from tests.support.scan_blisk import worn_blisk


def _stack(parts):
    offs = np.cumsum([0] + [len(V) for V, _ in parts[:-1]])
    V = np.concatenate([V for V, _ in parts])
    F = np.concatenate([F + o for (_, F), o in zip(parts, offs, strict=True)])
    return V, F


@pytest.fixture(scope="module")
def demo_whole():
    d = make_demo_blisk(hub_pitches=24, resolution=0.3)
    V, F = d.combined(list(range(24)))
    return d, V, F


@pytest.fixture(scope="module")
def rotor37_whole():
    V, F, hub, _ = nasa_blade("rotor37")
    m = TriMesh.from_arrays(V, F)
    p1 = np.array([hub.r1, hub.z1])
    p2 = np.array([hub.r2, hub.z2])
    rz = np.linspace(p1 - 0.3 * (p2 - p1), p2 + 0.3 * (p2 - p1), 12)
    HV, HQ = revolve(rz, Axis(), segments=360)
    HF = np.concatenate([HQ[:, [0, 1, 2]], HQ[:, [0, 2, 3]]])
    blades = [(rotate_about(m.V, np.array([0.0, 0.0, 1.0]), k * 2 * math.pi / 36,
                            form="coordinate"), m.F) for k in range(36)]
    return (len(HF), len(m.F)), *_stack([(HV, HF)] + blades)


def _check_split(split, n_hub, n_blade_faces, N):
    assert split.blade_count == N
    np.testing.assert_array_equal(split.hub_faces, np.arange(n_hub))
    np.testing.assert_array_equal(split.blade_faces, np.arange(n_hub, n_hub + N * n_blade_faces))
    # each blade (input order) lies wholly in one sector, and the N sectors are distinct
    sec = split.sector[n_hub:].reshape(N, n_blade_faces)
    assert np.all(sec == sec[:, :1])
    assert sorted(sec[:, 0].tolist()) == list(range(N))
    # neighbouring blades are neighbouring sectors
    assert np.all(np.mod(np.diff(sec[:, 0]), N) == 1)


def test_demo_whole_blisk_split(demo_whole):
    d, V, F = demo_whole
    split = split_blisk_mesh(V, F, 24)
    _check_split(split, len(d.hub_faces), len(d.blade_faces), 24)
    part = split.part
    assert len(part.blade_faces) == len(d.blade_faces)
    # the fitted hub profile lies on the demo's hub cone
    c = d.hub_cone
    P = part.hub_profile
    t = (P[:, 1] - c.z1) / (c.z2 - c.z1)
    np.testing.assert_allclose(P[:, 0], c.r1 + t * (c.r2 - c.r1), atol=1e-6)


def test_rotor37_patterned_to_36_blades(rotor37_whole):
    (n_hub, n_blade), V, F = rotor37_whole
    split = split_blisk_mesh(V, F, None)  # N found without help
    _check_split(split, n_hub, n_blade, 36)


def test_split_errors(demo_whole):
    d, V, F = demo_whole
    with pytest.raises(PartError, match="24-fold symmetry but the blade count given is 20"):
        split_blisk_mesh(V, F, 20)
    # one blade missing: not periodic
    nb = len(d.blade_faces)
    with pytest.raises(PartError, match="not rotationally periodic"):
        split_blisk_mesh(V, F[:-nb], 24)
    # blades only: no faces of revolution
    with pytest.raises(PartError, match="no hub found"):
        split_blisk_mesh(V, F[len(d.hub_faces):], 24)


def test_symmetry_order_from_harmonics():
    rng = np.random.default_rng(1)
    base = rng.uniform(0.0, 0.2, 50)
    th = (base[None] + 2 * math.pi * np.arange(7)[:, None] / 7).ravel()
    n, off = blade_count_from_symmetry(th, np.ones(len(th)))
    assert n == 7 and off < 0.05  # (the histogram's bins alias ~1 %)
    n, off = blade_count_from_symmetry(th[:-50], np.ones(len(th) - 50))
    assert n != 7 or off > 0.1  # one copy missing: not 7-fold


def test_part_from_blade_and_csv(tmp_path):
    d = make_demo_blisk(resolution=0.3)
    f = tmp_path / "hub.csv"
    c = d.hub_cone
    f.write_text(f"# r, z\n{c.r1}, {c.z1}\n{c.r2}; {c.z2}\n")
    P = read_rz_csv(f)
    part = part_from_blade(d.blade_vertices, d.blade_faces, P, 24)
    ref = part_from_demo(d)
    assert part.blade_count == 24 and math.isclose(part.sector_start, ref.sector_start)
    np.testing.assert_allclose(part.hub_r([0.0]), [c.r1 + (0 - c.z1) / (c.z2 - c.z1)
                                                   * (c.r2 - c.r1)])
    V, F, hub = part.part_mesh()
    r, th, z = theta_about(V[np.unique(F[hub])], part.axis)
    rel = np.mod(th - part.sector_start + math.pi, 2 * math.pi) - math.pi
    # the hub faces of blade 0's sector only
    assert rel.min() >= -1e-9 and rel.max() <= part.pitch + 1e-9
    bad = tmp_path / "bad.csv"
    bad.write_text("150, 0\nnot a number\n")
    with pytest.raises(PartError, match="line 2"):
        read_rz_csv(bad)


def test_a_scan_whose_blades_differ_keeps_its_blade_count_and_numbering():
    """A repaired blisk's blades are turned a few tenths of a degree each way and one is much
    thinner: N is still found (harmonics far above N do not read the differences as a lower
    symmetry), and blade 0 is the blade nearest θ = 0 however the others differ."""
    turns = [0.2, -0.2, 0.2, -0.2]
    V, F, d, blades = worn_blisk(4, 0.2, offsets=[0.04, -0.6, 0.08, 0.02], turns_deg=turns)
    split = split_blisk_mesh(V, F)
    assert split.blade_count == 4
    # every built blade's faces land in one sector; sector of blade k is k (blade 0 at θ≈0)
    offs = np.cumsum([0] + [len(Fk) for _, Fk in blades[:-1]]) + (len(F) - sum(
        len(Fk) for _, Fk in blades))
    for k, (_, Fk) in enumerate(blades):
        assert set(split.sector[offs[k]:offs[k] + len(Fk)].tolist()) == {k}
    with pytest.raises(PartError, match="3-fold|blade count"):
        split_blisk_mesh(V, F, blade_count=3)


@pytest.mark.parametrize("blade", ["demo", "rotor37"])
def test_envelope_contains_the_whole_blade(blade):
    """The envelope (the default blank's shape) holds every point of the blade, not only its
    vertices: points on a barycentric grid of every triangle lie under its top, linear between
    stations. Rotor 37's long tip triangles left stations without a vertex, and the old
    nearest-vertex top dipped there: blade points stood up to 14.5 mm above it (demo 0.68)."""
    if blade == "demo":
        part = part_from_demo(make_demo_blisk(resolution=0.3))
    else:
        V, F, hub, _ = nasa_blade("rotor37")
        profile = np.array([[hub.r1, hub.z1], [hub.r2, hub.z2]])
        part = part_from_blade(V, F, profile, 36)
    V, F = part.blade_vertices, part.blade_faces
    u, v = np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 6))
    keep = u + v <= 1 + 1e-12
    w = np.stack([1 - u[keep] - v[keep], u[keep], v[keep]], 1)  # (k, 3) barycentric
    P = np.einsum("kc,fcd->fkd", w, V[F]).reshape(-1, 3)
    r, _, z = theta_about(P, part.axis)
    top = np.asarray(part.envelope)[2:]  # the stations (r, z), z ascending
    assert np.all(np.diff(top[:, 1]) > 0)
    over = r - np.interp(z, top[:, 1], top[:, 0])
    assert over.max() <= 1e-9, f"{(over > 1e-9).sum()} blade points above the envelope, " \
                               f"up to {over.max():.3f} mm"
