import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from blisk_cam.core.errors import ConeError
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.part.cones import Cone, MorphingCones, fit_cone

PAIRS = {
    "cones": (Cone(150, -20, 165, 40), Cone(215, -20, 225, 40)),
    "cylinders": (Cone(100, 0, 100, 50), Cone(130, 0, 130, 50)),
    "disks": (Cone(100, 0, 150, 0), Cone(100, 30, 150, 30)),
    "lines_cross_outside": (Cone(100, 0, 110, 50), Cone(200, 0, 170, 50)),
    "reversed_order": (Cone(150, -20, 165, 40), Cone(225, 40, 215, -20)),
}


@pytest.mark.parametrize("name", PAIRS)
@settings(max_examples=30, deadline=None)
@given(s=st.floats(0.0, 1.0), t=st.floats(-0.2, 1.2), th=st.floats(-np.pi, np.pi))
def test_ratio_recovers_s_of_points_built_on_the_lmc(name, s, t, th):
    mc = MorphingCones(*PAIRS[name])
    a, b = mc.generatrix(s)
    r, z = a + t * (b - a)
    p = np.array([[r * np.cos(th), r * np.sin(th), z]])
    rr, zz = meridional(p, Axis())
    assert abs(mc.ratio(rr, zz)[0] - s) < 1e-9
    assert abs(mc.f(s, rr, zz)[0]) < 1e-9
    # f is a signed distance: moving 0.1 mm toward cone 2 along the LMC normal gives +0.1
    al, be, _ = mc.line_coefficients(s)
    assert mc.f(s, rr + 0.1 * al, zz + 0.1 * be)[0] == pytest.approx(0.1, abs=1e-9)


def test_f_positive_toward_cone2_and_monotone_in_s():
    mc = MorphingCones(*PAIRS["cones"])
    q = mc.cone2
    assert mc.f(0.0, q.r1, q.z1) > 0
    p = mc.cone1
    assert mc.f(1.0, p.r1, p.z1) < 0


def test_rotated_axis_gives_same_ratios():
    mc = MorphingCones(*PAIRS["cones"])
    rng = np.random.default_rng(1)
    pts = rng.uniform([-200, -200, -20], [200, 200, 40], (50, 3))
    d = np.array([1.0, 2.0, 3.0]) / np.linalg.norm([1, 2, 3])
    o = np.array([5.0, -3.0, 7.0])
    # build the rotation taking +Z to d
    z = np.array([0, 0, 1.0])
    v = np.cross(z, d)
    c = z @ d
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    R = np.eye(3) + vx + vx @ vx / (1 + c)
    moved = pts @ R.T + o
    s0 = mc.ratio(*meridional(pts, Axis()))
    s1 = mc.ratio(*meridional(moved, Axis(tuple(o), tuple(d))))
    assert np.allclose(s0, s1, atol=1e-9, equal_nan=True)


@pytest.mark.parametrize(
    "c1,c2,msg",
    [
        (Cone(150, 0, 160, 40), Cone(150, 0, 160, 40), "same cone"),
        (Cone(150, 0, 200, 40), Cone(200, 0, 150, 40), "cross"),
        (Cone(150, 0, 160, 40), Cone(155, 20, 170, 60), "cross"),
    ],
)
def test_bad_cone_pairs_are_refused(c1, c2, msg):
    with pytest.raises(ConeError, match=msg):
        MorphingCones(c1, c2)


@pytest.mark.parametrize("vals", [(1, 2, 1, 2), (-1, 0, 5, 5), (np.nan, 0, 1, 1)])
def test_bad_cones_are_refused(vals):
    with pytest.raises(ConeError):
        Cone(*vals)


def test_fit_cone_recovers_generatrix_and_reports_residual():
    rng = np.random.default_rng(0)
    c = Cone(150, -20, 165, 40)
    t = rng.uniform(0, 1, 300)
    th = rng.uniform(0, 2 * np.pi, 300)
    r = c.r1 + t * (c.r2 - c.r1)
    z = c.z1 + t * (c.z2 - c.z1)
    pts = np.stack([r * np.cos(th), r * np.sin(th), z], 1)
    fit, resid, rms = fit_cone(pts, Axis())
    assert resid < 1e-9
    d = fit.signed_distance(np.array([c.r1, c.r2]), np.array([c.z1, c.z2]))
    assert np.abs(d).max() < 1e-9
    noisy = pts + rng.normal(0, 0.01, pts.shape)
    fit2, resid2, rms2 = fit_cone(noisy, Axis())
    assert 0.005 < rms2 < 0.02 and resid2 > rms2


def test_fit_cone_handles_disk_and_cylinder():
    th = np.linspace(0, 6, 50)
    rr = np.linspace(100, 150, 50)
    disk = np.stack([rr * np.cos(th), rr * np.sin(th), np.full(50, 7.0)], 1)
    fit, resid, _ = fit_cone(disk, Axis())
    assert abs(fit.z1 - 7) < 1e-9 and abs(fit.z2 - 7) < 1e-9 and resid < 1e-9
    cyl = np.stack([120 * np.cos(th), 120 * np.sin(th), np.linspace(0, 40, 50)], 1)
    fit, resid, _ = fit_cone(cyl, Axis())
    assert abs(fit.r1 - 120) < 1e-9 and abs(fit.r2 - 120) < 1e-9


def test_folded_pair_is_refused_although_neither_cone_crosses_the_other():
    # cone 2 lies wholly on one side of cone 1's line and cone 1 wholly on one side of cone 2's,
    # but the segments P1→Q1 and P2→Q2 cross: LMCs of different s meet inside the region
    c1, c2 = Cone(100, 0, 110, 0), Cone(120, 10, 130, 30)
    for a, b in ((c1, c2), (c2, c1)):
        on_other = a.signed_distance(np.array([b.r1, b.r2]), np.array([b.z1, b.z2]))
        assert np.all(on_other > 0) or np.all(on_other < 0)
    mc_free = MorphingCones(c1, Cone(100, 10, 115, 30))  # convex quadrilateral: accepted
    assert mc_free.sign in (1.0, -1.0)
    with pytest.raises(ConeError, match="cross inside the region"):
        MorphingCones(c1, c2)
    # and the fold is real: a point of the region lies on two LMCs with s in [0, 1]
    a = (np.array([100.0, 0.0]), np.array([110.0, 0.0]))
    b = (np.array([120.0, 10.0]), np.array([130.0, 30.0]))
    x = np.array([115.0, 7.5])  # where P1→Q1 meets P2→Q2: A(0.75) = B(0.25)
    on = []
    for s in np.linspace(0, 1, 2001):
        A = (1 - s) * a[0] + s * b[0]
        B = (1 - s) * a[1] + s * b[1]
        d = B - A
        on.append(abs(d[0] * (x[1] - A[1]) - d[1] * (x[0] - A[0])) / np.linalg.norm(d))
    on = np.array(on)
    assert np.sum((on[1:-1] < on[:-2]) & (on[1:-1] < on[2:]) & (on[1:-1] < 0.05)) >= 2


@pytest.mark.parametrize("name", [n for n in PAIRS])
def test_accepted_pairs_sweep_monotonically(name):
    """f_s(X) changes sign exactly once in s for points X of the region (the check's promise)."""
    mc = MorphingCones(*PAIRS[name])
    rng = np.random.default_rng(7)
    s0, lam = rng.uniform(0, 1, 300), rng.uniform(0, 1, 300)
    a, b = mc.generatrix(s0)
    x = a + lam[:, None] * (b - a)
    ss = np.linspace(-0.01, 1.01, 205)
    f = np.array([mc.f(s, x[:, 0], x[:, 1]) for s in ss])  # (205, 300)
    changes = np.sum(np.diff(np.sign(f), axis=0) != 0, axis=0)
    assert np.all(changes == 1)
