"""Machine TOML, forward/inverse kinematics, linearization (issue 11 §1–2)."""

from __future__ import annotations

import fnmatch
import math
import tomllib

import numpy as np
import pytest

from blisk_cam.core.errors import BliskCamError, MachineError, ReachError
from blisk_cam.core.geometry.vectors import slerp
from blisk_cam.core.machine.description import (
    MACHINES_DIR,
    forward,
    known_presets,
    load_machine,
    machine_from_dict,
    tip_to_machine,
)
from blisk_cam.core.machine.kinematics import (
    _candidates,
    joint_deviation,
    linearize,
    solve_poses,
)
from blisk_cam.core.toolpath.types import MOVE_CUT, MOVE_RAPID
from tests.support.nc import demo_path

PRESETS = ("ac-trunnion", "bc-trunnion", "bc-head-table")

AC = """
name = "AC trunnion"
kinematics = "table-table"
spindle = [0, 0, 1]
[[rotary]]
name = "A"
axis = [1, 0, 0]
point = [0, 0, 0]
limits = [-10.0, 110.0]
[[rotary]]
name = "C"
axis = [0, 0, 1]
point = [0, 0, 0]
[linear]
X = [-400, 400]
Y = [-300, 300]
Z = [-300, 300]
[part]
origin = [0, 0, 0]
x = [1, 0, 0]
z = [0, 0, 1]
"""


@pytest.fixture(scope="module")
def demo():
    return demo_path()


def _write(tmp_path, text, name="m.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_presets_ship_and_ac_is_the_spec_example(tmp_path):
    assert set(PRESETS) <= set(known_presets())
    m = load_machine("ac-trunnion")
    ref = load_machine(_write(tmp_path, AC))
    assert m.kinematics == ref.kinematics == "table-table"
    assert m.axis_names == ("A", "C")
    for a, b in zip(m.rotaries, ref.rotaries, strict=True):
        assert np.allclose(a.axis, b.axis) and np.allclose(a.point, b.point)
        assert a.limits == b.limits
    assert m.rotaries[1].continuous
    assert m.linear == ref.linear and m.part_is_identity
    assert load_machine("bc-head-table").pivot_length > 0
    # shipped inside the package (the build copies blisk_cam/ as is; the manifest excludes no .toml)
    assert MACHINES_DIR.parent.name == "blisk_cam"
    manifest = tomllib.loads((MACHINES_DIR.parent / "blender_manifest.toml").read_text())
    for pat in manifest["build"]["paths_exclude_pattern"]:
        pat = pat.strip("/")
        for f in MACHINES_DIR.glob("*.toml"):
            for cand in (f.name, f"machines/{f.name}", "machines"):
                assert not fnmatch.fnmatch(cand, pat), (pat, cand)


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda t: t.replace('axis = [1, 0, 0]\n', "", 1), ["rotary 1", "axis", "missing"]),
        (lambda t: t.replace("axis = [1, 0, 0]", "axis = [0, 0, 0]"), ["zero vector"]),
        (lambda t: t.replace("[-10.0, 110.0]", "[110.0, -10.0]"), ["limits reversed"]),
        (lambda t: t.replace('"table-table"', '"tripod"'), ["unknown kinematics", "head-table"]),
        (lambda t: t.replace("z = [0, 0, 1]", "z = [0.1, 0, 1]"), ["not orthogonal"]),
        (lambda t: t.replace("X = [-400, 400]", "X = [400, -400]"), ["linear X", "reversed"]),
        (lambda t: t + "\n[[rotary]]\nname='B'\naxis=[0,1,0]\n", ["exactly two"]),
        (lambda t: t.replace("spindle = [0, 0, 1]", "spindle = [0, 1]"), ["spindle"]),
        (lambda t: t + "\nthis is not toml", ["not valid TOML"]),
        (lambda t: t.replace("axis = [1, 0, 0]", "axis = [0, 0, -2]"), ["parallel"]),
    ],
)
def test_malformed_machine_toml(tmp_path, edit, words):
    with pytest.raises(MachineError) as err:
        load_machine(_write(tmp_path, edit(AC)))
    assert isinstance(err.value, BliskCamError)
    for w in words:
        assert w in str(err.value)


def test_unknown_preset_lists_known(tmp_path):
    with pytest.raises(MachineError, match="known: ac-trunnion, bc-head-table, bc-trunnion"):
        load_machine("dmu-fantasy")
    with pytest.raises(MachineError, match="not found"):
        load_machine(tmp_path / "missing.toml")


def _random_axes(n, rng, max_polar=1.745):
    pol = rng.uniform(math.radians(5), max_polar, n)
    az = rng.uniform(-math.pi, math.pi, n)
    return np.stack([np.sin(pol) * np.cos(az), np.sin(pol) * np.sin(az), np.cos(pol)], 1)


@pytest.mark.parametrize("name", PRESETS)
def test_fk_ik_round_trip_both_branches(name):
    """Every pose solved, both branches satisfy the forward model (paper 002 Eq. 4)."""
    m = load_machine(name)
    rng = np.random.default_rng(3)
    axes = _random_axes(500, rng)
    tips = rng.uniform(-150, 150, (500, 3))
    th, reach, sing = _candidates(m, axes)
    assert reach.all() and not sing.any()
    for b in range(2):
        q = th[:, b, :]
        xyz = tip_to_machine(m, tips, q)
        t2, a2 = forward(m, xyz, q)
        assert np.abs(t2 - tips).max() < 1e-9
        assert np.abs(a2 - axes).max() < 1e-12
    ik = solve_poses(m, tips, axes, prev=np.zeros((500, 2)), sequential=False)
    t2, a2 = forward(m, ik.xyz, ik.angles)
    assert np.abs(t2 - tips).max() < 1e-9 and np.abs(a2 - axes).max() < 1e-12
    for j, r in enumerate(m.rotaries):
        if r.limits:
            assert (ik.angles[:, j] >= r.limits[0] - 1e-12).all()
            assert (ik.angles[:, j] <= r.limits[1] + 1e-12).all()


def test_table_table_convention_is_right_handed():
    """A part point on +Y turned by A = +90° about +X goes to +Z (the table turns the part)."""
    m = load_machine("ac-trunnion")
    xyz = tip_to_machine(m, [[0.0, 10.0, 0.0]], [[math.pi / 2, 0.0]])
    assert np.allclose(xyz, [[0, 0, 10]])
    # the tool axis (0, 1, 0) in the part is brought to the spindle +Z by A = +90°, C = 0
    ik = solve_poses(m, [[0.0, 0, 0]], [[0.0, 1.0, 0.0]])
    assert np.allclose(np.degrees(ik.angles), [[90.0, 0.0]], atol=1e-9)


def test_singular_pose_keeps_previous_rotary_and_is_reported():
    m = load_machine("ac-trunnion")
    axes = np.array([[0.0, -math.sin(0.3), math.cos(0.3)], [0, 0, 1.0], [0.0, 0.0, 1.0]])
    ik = solve_poses(m, np.zeros((3, 3)) + [10.0, 20.0, 5.0], axes)
    assert ik.singular.tolist() == [False, True, True]
    assert ik.angles[1, 1] == ik.angles[0, 1] == ik.angles[2, 1]
    assert abs(ik.angles[1, 0]) < 1e-9
    t2, a2 = forward(m, ik.xyz, ik.angles)
    assert np.allclose(t2, [10, 20, 5]) and np.allclose(a2, axes)


def test_continuous_axis_unwinds():
    """Three turns of the axis about the blisk axis: C runs on past 360° without a jump."""
    m = load_machine("ac-trunnion")
    phi = np.linspace(0, 6 * math.pi, 400)
    s1, c1 = np.sin(1.0), np.cos(1.0)
    axes = np.stack([s1 * np.cos(phi), s1 * np.sin(phi), np.full_like(phi, c1)], 1)
    ik = solve_poses(m, np.zeros((400, 3)), axes)
    c = ik.angles[:, 1]
    assert np.abs(np.diff(c)).max() < math.radians(3)
    assert abs(c[-1] - c[0]) > math.radians(1000)
    assert np.ptp(ik.angles[:, 0]) < 1e-9  # one branch throughout


def test_out_of_limits_names_pose_axis_value():
    m = load_machine("ac-trunnion")
    axes = np.array([[0.0, -1.0, 0.0], [0.0, -math.sin(2.4), math.cos(2.4)]])  # A = 137.5°
    with pytest.raises(ReachError) as err:
        solve_poses(m, np.zeros((2, 3)), axes, labels=np.array([7, 8]))
    msg = str(err.value)
    assert "pose 8" in msg and "axis A" in msg and "137.5" in msg and "radial" in msg


def test_linear_travel_limit():
    m = load_machine("ac-trunnion")
    with pytest.raises(ReachError, match=r"axis X = 500\.0000 mm"):
        solve_poses(m, [[500.0, 0, 0]], [[0.0, 0, 1]])


def test_slerp_is_unit_and_on_the_arc():
    a0 = np.array([[1.0, 0, 0]])
    a1 = np.array([[0.0, 1, 0]])
    v = slerp(a0, a1, np.array([0.5]))
    assert np.allclose(v, [[math.sqrt(0.5), math.sqrt(0.5), 0]])


def test_machine_from_dict_defaults_part_frame():
    d = {"kinematics": "head-head", "spindle": [0, 0, 1],
         "rotary": [{"name": "C", "axis": [0, 0, 1]}, {"name": "A", "axis": [1, 0, 0]}]}
    m = machine_from_dict(d)
    assert m.part_is_identity and m.rotaries[0].continuous
    ik = solve_poses(m, [[1.0, 2, 3]], [[0.0, 0.6, 0.8]])
    t, a = forward(m, ik.xyz, ik.angles)
    assert np.allclose(t, [[1, 2, 3]]) and np.allclose(a, [[0, 0.6, 0.8]])


@pytest.mark.parametrize("name", ["ac-trunnion", "bc-head-table"])
def test_linearization_on_demo_blade(demo, name):
    """Dense sampling of joint-linear motion between blocks stays within the chord tolerance
    of the planned CL segment (the demo's leading edge turns the rotaries fastest), and no
    rotary turns more than 5° between consecutive feed blocks."""
    m = load_machine(name)
    pr = demo.program
    ik = solve_poses(m, pr.tip, pr.axis, moves=pr.move)
    raw = joint_deviation(m, ik.xyz[:-1], ik.angles[:-1], ik.xyz[1:], ik.angles[1:],
                          pr.tip[:-1], pr.tip[1:], samples=64)
    feed = pr.move[1:] != MOVE_RAPID
    tip, ax, mv, xyz, q, sing, src, rep = linearize(m, pr.tip, pr.axis, pr.move, ik,
                                                    chord=demo.chord)
    assert rep.unresolved == 0
    if raw[feed].max() > demo.chord:
        assert rep.inserted > 0
    # original poses kept in order
    assert np.array_equal(tip[src >= 0], pr.tip)
    dev = joint_deviation(m, xyz[:-1], q[:-1], xyz[1:], q[1:], tip[:-1], tip[1:], samples=64)
    f = mv[1:] != MOVE_RAPID
    assert dev[f].max() <= demo.chord * 1.02, dev[f].max()
    cut = (mv[1:] == MOVE_CUT) & (mv[:-1] == MOVE_CUT)
    assert np.degrees(np.abs(np.diff(q, axis=0))[cut]).max() <= 5.0 + 1e-9
    # inserted blocks lie on the planned segments and satisfy the forward model
    t2, a2 = forward(m, xyz, q)
    assert np.abs(t2 - tip).max() < 1e-9 and np.abs(a2 - ax).max() < 1e-12
    # the leading edge: the poses where the axis turns fastest got blocks inserted
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", pr.axis[1:], pr.axis[:-1]), -1, 1))
    worst = int(np.argmax(np.where(pr.move[1:] == MOVE_CUT, turn, 0))) + 1
    k = int(np.nonzero(src == worst)[0][0])
    if turn[worst - 1] > math.radians(5):
        assert src[k - 1] == -1


def test_reach_error_is_a_bliskcam_error():
    assert issubclass(ReachError, BliskCamError)


def test_near_singular_pass_is_linearized():
    """The axis passes 0.05° beside the C axis: C swings ~180° over a few mm; linearization
    inserts blocks until every C step is ≤ 5° and the sampled tip stays within the chord."""
    m = load_machine("ac-trunnion")
    n = 21
    t = np.linspace(-1, 1, n)
    ang = np.radians(10) * t
    eps = np.radians(0.05)
    axes = np.stack([np.full(n, np.sin(eps)), np.sin(ang), np.cos(ang)], 1)
    axes /= np.linalg.norm(axes, axis=1)[:, None]
    tips = np.stack([np.full(n, 200.0), 20 * t, np.full(n, 10.0)], 1)
    mv = np.zeros(n, np.int8)
    ik = solve_poses(m, tips, axes, moves=mv)
    assert np.ptp(np.degrees(ik.angles[:, 1])) > 150
    tip, ax, mv2, xyz, q, sing, src, rep = linearize(m, tips, axes, mv, ik, chord=0.01)
    assert rep.unresolved == 0 and rep.inserted > 100
    assert np.degrees(np.abs(np.diff(q, axis=0))).max() <= 5.0 + 1e-9
    dev = joint_deviation(m, xyz[:-1], q[:-1], xyz[1:], q[1:], tip[:-1], tip[1:], samples=64)
    assert dev.max() <= 0.0102
