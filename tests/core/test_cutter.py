"""Tests of blisk_cam.core.tool.cutter: the posed cutter touches the surface at its CC point, is
tangent there, stays on the tool side of the tangent plane, and its effective radius and
the scallop it leaves are checked against figures computed another way (support functions
of the profile outline, line searches on the exact signed distance)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

from blisk_cam.core.errors import BliskCamError, ToolError
from blisk_cam.core.tool.cutter import Cutter, as_cutter
from blisk_cam.core.toolpath.types import BallTool, PassCurve

CUTTERS = {
    "ball": Cutter.ball(6.0),
    "bull": Cutter.bull(6.0, 2.0),
    "flat": Cutter.flat(5.0),
    "taper": Cutter.taper(3.0, math.radians(6.0)),
    "bull_cone_bottom": Cutter("bull", 10.0, 1.5, alpha=math.radians(4.0)),
}


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def frame(n):
    """Two unit tangents (t1, t2) ⊥ unit n."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = unit(np.cross(n, ref))
    return t1, np.cross(n, t1)


def pose_axis(n, lead, tilt):
    """Tool axis tilted from n by ``lead`` about t2 and ``tilt`` about t1."""
    t1, t2 = frame(n)
    return unit(n * math.cos(lead) * math.cos(tilt) + t1 * math.sin(lead) * math.cos(tilt)
                + t2 * math.sin(tilt))


vec = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).filter(lambda v: np.linalg.norm(v) > 0.2)
angle = st.floats(-1.2, 1.2, allow_nan=False)


# ------------------------------------------------------------------ contact / CC → CL
_NV, _CC = (0.3, -0.5, 0.8), (0.1, 0.2, -0.3)


@pytest.mark.parametrize("name", list(CUTTERS))
@settings(max_examples=60, deadline=None)
@given(nv=vec, lead=angle, tilt=angle, cc=vec)
# the axis (almost) along n: a ring contact's radial direction comes from a ~θ-long vector
# (6e-4 mm off the cutter at θ = 1e-12 before the fix); 5e-13 is inside the flush blend
@example(nv=_NV, lead=0.0, tilt=0.0, cc=_CC)
@example(nv=_NV, lead=0.0, tilt=5e-13, cc=_CC)
@example(nv=_NV, lead=0.0, tilt=1e-12, cc=_CC)
@example(nv=_NV, lead=-1e-12, tilt=1e-12, cc=_CC)
@example(nv=_NV, lead=0.0, tilt=1e-8, cc=_CC)
@example(nv=_NV, lead=1e-6, tilt=0.0, cc=_CC)
@example(nv=(1.0, 0.0, 0.0), lead=0.0, tilt=1e-12, cc=_CC)
def test_contact_is_on_cutter_and_tangent(name, nv, lead, tilt, cc):
    cut = CUTTERS[name]
    n = unit(nv)
    a = pose_axis(n, lead, tilt)
    w = np.cross(a, np.cross(n, a))  # n − (n·a) a, exactly ⊥ a even for a ≈ n
    theta = math.atan2(np.linalg.norm(w), n @ a)
    cc = 50.0 * np.asarray(cc)
    if theta > math.pi / 2 - cut.beta:
        with pytest.raises(ToolError, match="lead/tilt"):
            cut.cl_points(cc[None], n[None], a[None])
        return
    tip = cut.cl_points(cc[None], n[None], a[None])[0]
    # the CC point is on the cutter's surface
    assert abs(cut.signed_distance(cc, tip, a)) <= 1e-9
    # no point of the tangent plane near the contact is inside the (convex) cutter, and the
    # cutter reaches the plane (it is tangent, not floating): the minimum over the plane is 0
    t1, t2 = frame(n)
    g = np.linspace(-1.5, 1.5, 41) * cut.bounding_radius
    U, W = np.meshgrid(g, g)
    plane = cc + U.reshape(-1, 1) * t1 + W.reshape(-1, 1) * t2
    sd = cut.signed_distance(plane, tip, a)
    assert sd.min() >= -1e-9
    # lowest point of the cutter along −n lies on the plane: the support value in −n is at cc
    prof = cut.profile(4000)
    rad = unit(-w) if np.linalg.norm(w) > 0 else t1
    depth = -(prof[:, 0] * (rad @ -n) + prof[:, 1] * (a @ -n))  # height above tip along n…
    lowest = (tip - cc) @ n + depth.min()
    assert abs(lowest) <= 1e-6 * cut.d


@pytest.mark.parametrize("name", ["bull", "flat"])
def test_flush_contact_is_exact_and_continuous(name):
    """Axis tilted from n by θ from 0 to 1e-3 (log-spaced, both sides of the flush blend at
    1e-12 rad), vectorised: the CC point is on the cutter, the cutter does not dip below the
    tangent plane (its support in −n, from the profile, is at cc), the contact moves from the
    tip (θ = 0) continuously out to the bottom's rim, and is at the ring point e + r sin θ
    along −(n − (n·a) a) above the blend."""
    cut = CUTTERS[name]
    rng = np.random.default_rng(11)
    th = np.concatenate([[0.0], np.geomspace(1e-16, 1e-3, 400)])
    k = len(th)
    n = unit(rng.normal(size=(k, 3)))
    t1 = unit(np.cross(n, rng.normal(size=(k, 3))))
    a = unit(np.cos(th)[:, None] * n + np.sin(th)[:, None] * t1)
    cc = rng.normal(size=(k, 3)) * 50
    tip = cut.cl_points(cc, n, a)
    assert np.abs(cut.signed_distance(cc, tip, a)).max() <= 1e-9
    # support of the posed cutter in −n: the lowest point along n of the outline, in the
    # meridional half-plane facing −n (exact: sin θ = |n × a| from the construction)
    phi = np.concatenate([th, np.linspace(0.0, math.pi / 2, 200)])  # corner arc samples,
    prof = np.vstack([cut.profile(200),  # including each pose's θ (exact support there)
                      np.stack([cut.e + cut.r * np.sin(phi), cut.f - cut.r * np.cos(phi)], 1)])
    lowest = (np.einsum("ij,ij->i", tip - cc, n)[:, None]
              - prof[None, :, 0] * np.sin(th)[:, None] + prof[None, :, 1] * np.cos(th)[:, None])
    assert np.abs(lowest.min(axis=1)).max() <= 1e-9
    rho = np.linalg.norm(np.cross(cc - tip, a), axis=1)  # contact distance from the axis
    assert rho[0] == 0.0  # the whole bottom is flush: contact at the tip
    # it moves out monotonically and without a jump (consecutive θ differ by 8 %, so a
    # continuous blend moves < 10 % of e per step; the old contact jumped 0 → e). Below 1e-14
    # rad the axis built here is itself only θ ± 1e-16: no order to check there
    dr = np.diff(rho[th >= 1e-14])
    assert np.all(dr >= -1e-9) and np.all(dr <= 0.1 * cut.e)
    ring = th >= 1e-11
    assert np.allclose(rho[ring], cut.e + cut.r * np.sin(th[ring]), rtol=0, atol=1e-9)
    # above the blend the contact is toward the side n leans to, i.e. along t1
    assert np.all(np.einsum("ij,ij->i", cc - tip, t1)[ring] > 0)


@pytest.mark.parametrize("name", ["ball", "bull", "taper", "bull_cone_bottom"])
def test_outward_normal_at_contact_is_minus_n(name):
    """At a smooth contact the gradient of the signed distance is −n (the cutter lies on the
    tool side, touching the surface whose outward normal is n)."""
    cut = CUTTERS[name]
    rng = np.random.default_rng(3)
    n = unit(rng.normal(size=(300, 3)))
    lead = rng.uniform(0.05, 1.2, 300)
    tilt = rng.uniform(-0.4, 0.4, 300)
    a = np.array([pose_axis(n[i], lead[i], tilt[i]) for i in range(300)])
    cc = rng.normal(size=(300, 3)) * 20
    tip = cut.cl_points(cc, n, a)
    eps = 1e-6
    grad = np.stack([(cut.signed_distance(cc + eps * e, tip, a)
                      - cut.signed_distance(cc - eps * e, tip, a)) / (2 * eps)
                     for e in np.eye(3)], axis=1)
    assert np.abs(grad + n).max() < 1e-6


def test_ball_matches_the_old_ball_tool():
    """Cutter.ball ≡ BallTool: tip + ρ a = cc + ρ n (the centres verify always used), and the
    signed distance of the posed ball is |p − centre| − ρ below the flute length."""
    rho = 6.0
    cut = Cutter.ball(rho)
    rng = np.random.default_rng(5)
    n = unit(rng.normal(size=(500, 3)))
    a = np.array([pose_axis(v, *rng.uniform(-1.0, 1.0, 2)) for v in n])
    cc = rng.normal(size=(500, 3)) * 30
    tip = cut.cl_points(cc, n, a)
    pc = PassCurve(0.0, False, cc, n, tip, a)
    assert np.abs(pc.centres(BallTool(rho).radius) - (cc + rho * n)).max() < 1e-12
    p = tip + rho * a + rng.normal(size=(500, 3)) * 5
    in_ball_zone = ((p - tip) * a).sum(1) <= rho  # below the ball's equator
    sd = cut.signed_distance(p, tip, a)
    ref = np.linalg.norm(p - (tip + rho * a), axis=1) - rho
    assert np.abs(sd - ref)[in_ball_zone].max() < 1e-12
    assert as_cutter(BallTool(rho)) == cut
    assert as_cutter({"type": "ball", "radius": rho}) == cut


@pytest.mark.parametrize("name", list(CUTTERS))
def test_signed_distance_is_exact(name):
    """Against brute force: the distance to a dense sampling of the revolved outline, and
    the sign from an independent inside test on the polygonised profile."""
    cut = CUTTERS[name]
    prof = cut.profile(3000)
    # dense outline including the bottom and the top cap
    segs = np.vstack([prof, [[0.0, cut.h]]])
    pts = []
    for a, b in zip(segs[:-1], segs[1:], strict=True):
        t = np.linspace(0, 1, max(2, int(np.linalg.norm(b - a) / 2e-3)))[:, None]
        pts.append(a + t * (b - a))
    outline = np.vstack(pts)
    rng = np.random.default_rng(7)
    rz = np.stack([rng.uniform(0, cut.max_radius * 1.5, 3000),
                   rng.uniform(-cut.radius, cut.h * 1.1, 3000)], axis=1)
    from scipy.spatial import cKDTree

    d_ref, _ = cKDTree(outline).query(rz)
    sd = cut.signed_distance_rz(rz[:, 0], rz[:, 1])
    assert np.abs(np.abs(sd) - d_ref).max() < 2e-3  # outline sampled every 2 µm
    # inside test by ray casting (even-odd) on the closed polygon: the outline and its mirror
    poly = np.vstack([segs, segs[::-1] * [-1, 1]])
    a, b = poly, np.roll(poly, -1, axis=0)
    x, y = rz[:, :1], rz[:, 1:]
    straddle = (a[:, 1] > y) != (b[:, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xc = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    inside_ref = (np.sum(straddle & (x < xc), axis=1) % 2) == 1
    clear = d_ref > 1e-2
    assert np.array_equal((sd < 0)[clear], inside_ref[clear])


# ------------------------------------------------------------------ effective radius
def _support(cut, tip, a, m):
    """Support function of the posed cutter in unit direction m, from the profile outline:
    max over the outline of ρ |m⊥| + z (m·a) — maximised on the corner arc by Brent."""
    ma = float(m @ a)
    mp = float(np.linalg.norm(m - ma * a))
    cands = [0.0, cut.max_radius * mp + cut.h * ma]  # tip, flute top
    if cut.r > 0:
        g = cut._g
        res = minimize_scalar(lambda t: -((cut.e + cut.r * math.sin(t)) * mp
                                          + (cut.f - cut.r * math.cos(t)) * ma),
                              bounds=(g["th_lo"], g["th_hi"]), method="bounded",
                              options={"xatol": 1e-12})
        cands.append(-res.fun)
    cands.append(cut.e * mp + cut.f * ma)
    return max(cands) + float(m @ tip)


@pytest.mark.parametrize("name", list(CUTTERS))
@pytest.mark.parametrize("lead, tilt, side_angle",
                         [(0.15, 0.0, 0.0), (0.25, 0.1, 0.7), (0.05, -0.2, 1.3), (0.3, 0.2, 2.2)])
def test_effective_radius_against_swept_section(name, lead, tilt, side_angle):
    """The radius of curvature of the swept section (the projection of the cutter along the
    feed onto the plane (n, side)) at the contact is h(ω) + h''(ω) of its support function,
    h'' by finite differences."""
    cut = CUTTERS[name]
    n = unit([0.2, -0.3, 1.0])
    a = pose_axis(n, lead, tilt)
    t1, t2 = frame(n)
    s = math.cos(side_angle) * t1 + math.sin(side_angle) * t2
    cc = np.array([1.0, 2.0, 3.0])
    tip = cut.cl_points(cc[None], n[None], a[None])[0]
    eff = float(cut.effective_radius(n, a, s)[0])

    def h(w):  # support in the direction −n rotated by ω toward s, relative to cc
        m = -math.cos(w) * n + math.sin(w) * s
        return _support(cut, tip, a, m) - float(m @ cc)

    assert abs(h(0.0)) < 1e-9  # the contact is the support point in −n
    dw = 2e-3
    curv = h(0.0) + (h(dw) - 2 * h(0.0) + h(-dw)) / dw**2
    assert eff == pytest.approx(curv, rel=2e-4, abs=1e-5)


def test_effective_radius_classic_cases():
    n = np.array([0.0, 0.0, 1.0])
    feed, side = np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    for lead in (0.05, 0.2, 0.5):
        a = np.array([math.sin(lead), 0.0, math.cos(lead)])
        assert CUTTERS["bull"].effective_radius(n, a, side)[0] == pytest.approx(
            4.0 / math.sin(lead) + 2.0, rel=1e-12)
        assert CUTTERS["flat"].effective_radius(n, a, side)[0] == pytest.approx(
            5.0 / math.sin(lead), rel=1e-12)
        assert CUTTERS["ball"].effective_radius(n, a, side)[0] == pytest.approx(6.0, rel=1e-12)
        # across the lead plane a bull-nose cuts with its corner
        assert CUTTERS["bull"].effective_radius(n, a, feed)[0] == pytest.approx(2.0, rel=1e-12)
    assert np.isinf(CUTTERS["flat"].effective_radius(n, n, side)[0])
    assert np.isinf(CUTTERS["bull"].effective_radius(n, n, side)[0])
    assert CUTTERS["ball"].effective_radius(n, n, side)[0] == pytest.approx(6.0)


def _swept_height(cut, tip, a, feed, x, n):
    """Height along n above the plane through the origin ⊥ n of the lower boundary of the
    cutter swept along the infinite line ``feed``, at offset x along the side direction
    s = n × feed... measured with the exact signed distance only (bisection on the height,
    Brent line search along the feed: the sd of a convex solid is convex along a line)."""
    side = np.cross(n, feed)

    def sweep_sd(z):
        p0 = x * side + z * n

        def f(t):
            return float(cut.signed_distance(p0 + t * feed, tip, a))

        return minimize_scalar(f, bounds=(-3 * cut.bounding_radius, 3 * cut.bounding_radius),
                               method="bounded", options={"xatol": 1e-11}).fun

    lo, hi = -1.0, 2.0  # inside / outside the swept solid
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if sweep_sd(mid) < 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


@pytest.mark.parametrize("name, lead", [("bull", 0.12), ("bull", 0.3), ("flat", 0.15),
                                        ("ball", 0.2)])
def test_scallop_of_two_passes_on_a_plane(name, lead):
    """Two straight passes on the plane z = 0 (feed x, lead about y), w apart in y: the
    scallop measured on the swept signed distance matches R_eff − sqrt(R_eff² − w²/4)."""
    cut = CUTTERS[name]
    n = np.array([0.0, 0.0, 1.0])
    feed = np.array([1.0, 0.0, 0.0])
    a = np.array([math.sin(lead), 0.0, math.cos(lead)])
    tip = cut.cl_points(np.zeros((1, 3)), n[None], a[None])[0]
    side = np.cross(n, feed)
    reff = float(cut.effective_radius(n, a, side)[0])
    assert abs(_swept_height(cut, tip, a, feed, 0.0, n)) < 1e-9  # touching the plane
    # pass 2 is pass 1 shifted by w along side; by the mirror symmetry (y → −y) the cusp is
    # at y = w/2 and equals the height of one pass's swept boundary there. The closed form is
    # the osculating circle's: its relative error is O(w²) — within 1 % at a ~3 µm scallop
    # and four times smaller at half the step
    errs = []
    for w in (0.15 * math.sqrt(reff), 0.075 * math.sqrt(reff)):
        h_closed = reff - math.sqrt(reff * reff - w * w / 4)
        h_meas = _swept_height(cut, tip, a, feed, 0.5 * w, n)
        errs.append(abs(h_meas / h_closed - 1.0))
    assert errs[0] < 1e-2
    assert errs[1] < 0.3 * errs[0] + 1e-6


# ------------------------------------------------------------------ zero speed, profile, IO
def test_zero_speed_only_at_the_axis():
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    a = unit([[0, 0, 1], [0.05, 0, 1], [0.5, 0, 1]])
    assert list(CUTTERS["ball"].zero_speed(n, a, tol=0.01)) == [True, False, False]
    assert list(CUTTERS["bull"].zero_speed(n, a, tol=0.01)) == [True, False, False]
    assert CUTTERS["ball"].zero_speed(n[:1], a[1:2], tol=0.5)[0]  # ρ sin(2.9°) = 0.3 mm


@pytest.mark.parametrize("name", list(CUTTERS))
def test_profile_and_dict_round_trip(name):
    cut = CUTTERS[name]
    prof = cut.profile(32)
    assert np.allclose(prof[0], 0) and prof[-1, 1] == pytest.approx(cut.h)
    assert np.all(np.diff(prof[:, 1]) >= -1e-12) and np.all(np.diff(prof[:, 0]) >= -1e-12)
    # every outline point is on the cutter's boundary
    assert np.abs(cut.signed_distance_rz(prof[:, 0], prof[:, 1])).max() < 1e-12
    d = cut.as_dict()
    assert Cutter.from_dict(d) == cut
    import json

    assert Cutter.from_dict(json.loads(json.dumps(d))) == cut


def test_from_spec_names():
    assert Cutter.from_spec("BALL", 6.0) == Cutter.ball(6.0)
    assert Cutter.from_spec("ball", 6.0, 6.0) == Cutter.ball(6.0)
    assert Cutter.from_spec("Bull", 6.0, 2.0) == Cutter.bull(6.0, 2.0)
    assert Cutter.from_spec("FLAT", 4.0, None) == Cutter.flat(4.0)
    t = Cutter.from_spec("taper", 3.0, taper_angle=0.1)
    assert t.beta == 0.1 and t.r == 3.0 and t.radius == 3.0
    assert Cutter.from_dict({"type": "ball", "radius": 6.0}).radius == 6.0


@pytest.mark.parametrize("make, words", [
    (lambda: Cutter("bull", 12.0, 7.0), "corner radius r must be in"),
    (lambda: Cutter.bull(6.0, -1.0), "corner radius r must be in"),
    (lambda: Cutter.bull(6.0, 6.0), "bull-nose cutter needs"),
    (lambda: Cutter.bull(6.0, 0.0), "bull-nose cutter needs"),
    (lambda: Cutter.ball(-3.0), "tool radius must be"),
    (lambda: Cutter.ball(float("nan")), "tool radius must be"),
    (lambda: Cutter("flat", float("inf"), 0.0), "finite"),
    (lambda: Cutter("ball", 12.0, 5.0), "corner radius is its radius"),
    (lambda: Cutter.from_spec("ball", 6.0, 2.0), "corner radius is its radius"),
    (lambda: Cutter.from_spec("flat", 6.0, 2.0), "no corner radius"),
    (lambda: Cutter.from_spec("drill", 6.0), "tool type must be one of"),
    (lambda: Cutter.taper(3.0, 0.0), "taper angle must be in"),
    (lambda: Cutter.taper(3.0, math.radians(75)), "taper angle must be in"),
    (lambda: Cutter.taper(3.0, float("nan")), "finite"),
    (lambda: Cutter("bull", 12.0, 2.0, beta=0.1), "no taper angle"),
    (lambda: Cutter("bull", 12.0, 2.0, e=3.0), "corner offset e"),
    (lambda: Cutter.ball(6.0, h=2.0), "flute length"),
    (lambda: Cutter.ball(6.0, holder_diameter=-1.0), "holder diameter"),
    (lambda: Cutter.from_dict({"type": "bull", "radius": 6.0, "corner_radius": 2.0, "d": 10.0}),
     "contradicts"),
    (lambda: Cutter.from_dict({"radius": 6.0}), "'type'"),
    (lambda: CUTTERS["bull"].cl_points([[0, 0, 0]], [[0, 0, 1]], [[1, 0, -0.1]]), "lead/tilt"),
    (lambda: CUTTERS["bull"].cl_points([[0, 0, 0]], [[0, 0, 0]], [[0, 0, 1]]), "normal"),
])
def test_bad_input(make, words):
    with pytest.raises(ToolError, match=words) as err:
        make()
    assert isinstance(err.value, BliskCamError)


def test_effective_radii_of_several_sides_equal_separate_calls():
    """One contact for several sides gives each side's effective radius bit for bit."""
    rng = np.random.default_rng(11)
    n = rng.normal(size=(200, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    tilt = rng.normal(scale=0.3, size=(200, 3))
    a = n + tilt - np.einsum("ij,ij->i", tilt, n)[:, None] * n
    a /= np.linalg.norm(a, axis=1)[:, None]
    f, k = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
    for cut in CUTTERS.values():
        ef, ek = cut.effective_radii(n, a, f, k)
        assert np.array_equal(ef, cut.effective_radius(n, a, f), equal_nan=True)
        assert np.array_equal(ek, cut.effective_radius(n, a, k), equal_nan=True)


@pytest.mark.parametrize("kind", sorted(CUTTERS))
def test_tips_and_zero_speed_from_one_contact_are_the_two_calls(kind):
    """``cl_points_and_zero_speed`` (the orient stage's one contact per pass) gives the very
    arrays of ``cl_points`` and ``zero_speed``, on poses tilted every way and on poses with
    the axis along the normal (the contact's radial direction then a perpendicular of the
    axis), for one axis per pose and one axis for all."""
    cut = CUTTERS[kind]
    rng = np.random.default_rng(7)
    n = np.array([0.0, 0.0, 1.0]) + 0.25 * rng.normal(size=(200, 3))
    n[5] = (0.0, 0.0, 1.0)  # along the single axis below
    n /= np.linalg.norm(n, axis=1)[:, None]
    tilt = 0.3 * rng.normal(size=(200, 3))
    a = n + tilt - np.einsum("ij,ij->i", tilt, n)[:, None] * n
    a /= np.linalg.norm(a, axis=1)[:, None]
    a[::7] = n[::7]  # on the axis: a flat's bottom or a ball's tip, zero speed
    cc = rng.uniform(-50.0, 50.0, size=(200, 3))
    for axes in (a, np.array([0.0, 0.0, 1.0])):
        tips, zero = cut.cl_points_and_zero_speed(cc, n, axes, 0.01)
        want = cut.cl_points(cc, n, axes)
        assert tips.dtype == want.dtype and np.array_equal(tips.view(np.uint64),
                                                           want.view(np.uint64))
        assert np.array_equal(zero, cut.zero_speed(n, axes, 0.01))
        assert zero.any()  # the poses on the axis
