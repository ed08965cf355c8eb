"""The one of each kernel (geometry.vectors, geometry.closest): measured truths, so that a
wrong kernel fails."""

import math
import warnings

import numpy as np
import pytest

from blisk_cam.core.geometry.closest import (
    barycentric,
    closest_on_segments,
    segment_distance,
    segment_distance2_2d,
    segment_offsets,
)
from blisk_cam.core.geometry.vectors import (
    angle_between,
    cross2,
    dot,
    perpendicular,
    rotate,
    rotate_about,
    rotation_matrix,
    slerp,
    unit,
)

RNG = np.random.default_rng(20)


def _units(k):
    v = RNG.normal(size=(k, 3))
    return v / np.linalg.norm(v, axis=1)[:, None]


def _angle(a, b):
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1), np.sum(a * b, axis=-1))


# ----------------------------------------------------------------------------- dot, cross2
def test_dot_is_the_row_wise_sum_of_products():
    a, b = RNG.normal(size=(50, 3)), RNG.normal(size=(50, 3))
    want = [float(np.sum(x * y)) for x, y in zip(a, b, strict=True)]
    assert np.allclose(dot(a, b), want, rtol=0, atol=1e-13)


def test_cross2_is_the_z_of_the_3d_cross_and_positive_counter_clockwise():
    a, b = RNG.normal(size=(50, 2)), RNG.normal(size=(50, 2))
    z = np.cross(np.hstack([a, np.zeros((50, 1))]), np.hstack([b, np.zeros((50, 1))]))[:, 2]
    assert np.array_equal(cross2(a, b), z)
    assert cross2(np.array([1.0, 0]), np.array([0.0, 1])) == 1.0  # x → y turns left


# ----------------------------------------------------------------------------------- unit
def test_unit_has_norm_one_and_keeps_the_direction():
    v = RNG.normal(size=(200, 3)) * RNG.uniform(1e-6, 1e6, size=(200, 1))
    u = unit(v)
    assert np.allclose(np.linalg.norm(u, axis=1), 1.0, rtol=0, atol=1e-15)
    assert np.all(np.einsum("ij,ij->i", u, v) > 0)
    assert np.allclose(np.cross(u, v / np.linalg.norm(v, axis=1)[:, None]), 0.0, atol=1e-15)
    # both forms are v / |v| bit for bit where |v| > 0, for any leading shape
    assert np.array_equal(u, v / np.linalg.norm(v, axis=1)[:, None])
    assert np.array_equal(unit(v, keep_zero=False), u)
    assert np.array_equal(unit(v.reshape(10, 20, 3)), u.reshape(10, 20, 3))
    assert np.allclose(unit([3.0, 0, 4]), [0.6, 0, 0.8])


def test_unit_zero_rows_stay_zero_or_become_nan_as_documented():
    v = np.array([[0.0, 0, 0], [0, 2.0, 0]])
    assert np.array_equal(unit(v), [[0.0, 0, 0], [0, 1.0, 0]])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        plain = unit(v, keep_zero=False)
    assert np.all(np.isnan(plain[0])) and np.array_equal(plain[1], [0, 1.0, 0])


def test_angle_between_measures_known_angles_accurately_near_zero():
    a = np.array([[1.0, 0, 0]] * 4)
    th = np.array([0.0, 1e-9, 1.0, math.pi])
    b = np.stack([np.cos(th), np.sin(th), np.zeros(4)], axis=1)
    assert np.allclose(angle_between(a, b), th, rtol=1e-12, atol=0)


# ---------------------------------------------------------------------------------- slerp
@pytest.mark.parametrize("weights_first", [False, True])
def test_slerp_rows_stay_on_the_great_circle_with_angles_proportional_to_t(weights_first):
    a0, a1 = _units(300), _units(300)
    t = RNG.uniform(0, 1, 300)
    v = slerp(a0, a1, t, weights_first=weights_first)
    om = _angle(a0, a1)
    assert np.allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-15)
    assert np.allclose(_angle(a0, v), t * om, atol=1e-12)
    assert np.allclose(_angle(v, a1), (1 - t) * om, atol=1e-12)
    # in the plane of a0 and a1
    assert np.allclose(np.einsum("ij,ij->i", np.cross(a0, a1), v), 0.0, atol=1e-12)
    assert np.allclose(slerp(a0, a1, np.zeros(300), weights_first=weights_first), a0,
                       atol=1e-15)
    assert np.allclose(slerp(a0, a1, np.ones(300), weights_first=weights_first), a1,
                       atol=1e-15)


def test_slerp_forms_agree_and_one_pair_equals_its_rows():
    a0, a1 = _units(100), _units(100)
    t = RNG.uniform(0, 1, 100)
    assert np.allclose(slerp(a0, a1, t), slerp(a0, a1, t, weights_first=True), atol=1e-15)
    tt = np.linspace(0, 1, 7)
    pair = slerp(a0[0], a1[0], tt)
    rows = slerp(np.repeat(a0[:1], 7, 0), np.repeat(a1[:1], 7, 0), tt)
    assert pair.shape == (7, 3) and np.allclose(pair, rows, atol=1e-15)


def test_slerp_nearly_equal_vectors_interpolate_linearly():
    a0 = np.array([[0.0, 0, 1]])
    a1 = unit(np.array([[1e-12, 0, 1]]))
    v = slerp(a0, a1, np.array([0.5]))
    assert np.allclose(v, unit(a0 + a1), atol=1e-15) and np.all(np.isfinite(v))


@pytest.mark.parametrize("weights_first", [False, True])
def test_slerp_antipodal_turns_through_pi_on_one_half_circle(weights_first):
    a0 = np.array([0.0, 0.6, 0.8])
    t = np.linspace(0, 1, 11)
    v = slerp(a0, -a0, t, weights_first=weights_first)  # one pair
    assert np.allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-15)
    assert np.allclose(_angle(np.broadcast_to(a0, v.shape), v), t * math.pi, atol=1e-12)
    normal = np.cross(v[1], v[3])  # every point on one great circle
    assert np.allclose(v @ normal, 0.0, atol=1e-12)
    rows = slerp(np.repeat(a0[None], 11, 0), np.repeat(-a0[None], 11, 0), t,
                 weights_first=weights_first)
    assert np.allclose(rows, v, atol=1e-15)


# ------------------------------------------------------------------------------ rotations
@pytest.mark.parametrize("form", ["square", "outer"])
def test_rotation_matrix_is_orthonormal_and_turns_right_handed_by_the_angle(form):
    k = _units(1)[0]
    th = RNG.uniform(0.1, 3.0, 20)
    R = rotation_matrix(k, th, form=form)
    assert R.shape == (20, 3, 3)
    assert np.allclose(R @ R.transpose(0, 2, 1), np.eye(3), atol=1e-15)
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-14)
    assert np.allclose(R @ k, k, atol=1e-15)  # the axis is fixed
    v = np.cross(k, _units(1)[0])
    v /= np.linalg.norm(v)  # ⟂ k
    w = R @ v
    assert np.allclose(_angle(np.broadcast_to(v, w.shape), w), th, atol=1e-12)
    assert np.all(np.cross(v, w) @ k > 0)  # right-handed about k
    # a scalar angle gives the one matrix, bit for bit the row of the stack
    assert np.array_equal(rotation_matrix(k, th[3], form=form), R[3])
    z = rotation_matrix([0, 0, 1.0], math.pi / 2, form=form)
    assert np.allclose(z @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-15)


def test_rotation_matrix_forms_agree_and_an_unknown_form_is_refused():
    k, th = _units(1)[0], RNG.uniform(-3, 3, 10)
    assert np.allclose(rotation_matrix(k, th), rotation_matrix(k, th, form="outer"), atol=1e-15)
    with pytest.raises(ValueError, match="form"):
        rotation_matrix(k, 1.0, form="quaternion")


@pytest.mark.parametrize("form", ["square", "outer", "coordinate"])
def test_rotate_about_keeps_the_line_and_the_distance_to_it(form):
    o, d = np.array([1.0, -2.0, 3.0]), np.array([0.0, 0, 1])
    P = RNG.normal(size=(50, 3)) * 10
    Q = rotate_about(P, d, 0.7, o, form=form)

    def radial(X):
        r = X - o
        return r - np.outer(r @ d, d)

    assert np.allclose(np.linalg.norm(radial(Q), axis=1), np.linalg.norm(radial(P), axis=1),
                       atol=1e-12)
    assert np.allclose((Q - o) @ d, (P - o) @ d, atol=1e-12)
    assert np.allclose(_angle(radial(P), radial(Q)), 0.7, atol=1e-10)
    assert np.all(np.cross(radial(P), radial(Q)) @ d > 0)
    assert np.allclose(Q, rotate_about(P, d, 0.7, o), atol=1e-12)
    # vectors (no origin): the same turn without the shift
    assert np.allclose(rotate_about(P, d, 0.7, form=form), P @ rotation_matrix(d, 0.7).T,
                       atol=1e-12)


def test_rotate_about_a_coordinate_axis_copies_that_coordinate():
    P = RNG.normal(size=(30, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = 1.0
        Q = rotate_about(P, e, 1.1, form="coordinate")
        assert np.array_equal(Q[:, i], P[:, i])
        assert np.allclose(Q, P @ rotation_matrix(e, 1.1).T, atol=1e-14)
    with pytest.raises(ValueError, match="coordinate axis"):
        rotate_about(P, unit(np.array([1.0, 1, 0])), 1.0, form="coordinate")


@pytest.mark.parametrize("scale_last", [False, True])
def test_rotate_equals_the_rotation_matrices_for_one_axis_and_for_rows(scale_last):
    k = _units(1)[0]
    th = RNG.uniform(-3, 3, 40)
    v = RNG.normal(size=(40, 3))
    R = rotation_matrix(k, th)
    want = np.einsum("kij,kj->ki", R, v)
    assert np.allclose(rotate(v, k, th, scale_last=scale_last), want, atol=1e-14)
    # one vector turned by every angle
    assert np.allclose(rotate(v[0], k, th, scale_last=scale_last), R @ v[0], atol=1e-14)
    # one axis per row
    ks = _units(40)
    Rs = np.stack([rotation_matrix(ks[i], th[i]) for i in range(40)])
    assert np.allclose(rotate(v, ks, th, scale_last=scale_last),
                       np.einsum("kij,kj->ki", Rs, v), atol=1e-14)


# ------------------------------------------------------------------------- closest points
def _brute_segment_distance(p, a, b, n=20001):
    s = np.linspace(0.0, 1.0, n)
    pts = a[:, None] + s[None, :, None] * (b - a)[:, None]
    return np.linalg.norm(pts - p[:, None], axis=2).min(axis=1)


def test_segment_distance_against_a_brute_force_sample_of_the_segment():
    k = 60
    a, b = RNG.normal(size=(k, 3)) * 5, RNG.normal(size=(k, 3)) * 5
    p = RNG.normal(size=(k, 3)) * 8
    d = segment_distance(p, a, b)
    brute = _brute_segment_distance(p, a, b)
    step = np.linalg.norm(b - a, axis=1) / 20000
    assert np.all(d <= brute + 1e-12) and np.all(brute <= d + step)
    t, d2 = closest_on_segments(p, a, b)
    assert np.allclose(np.sqrt(d2), d, atol=1e-12) and np.all((t >= 0) & (t <= 1))
    q = a + t[:, None] * (b - a)
    assert np.allclose(np.linalg.norm(p - q, axis=1), d, atol=1e-12)
    # the offset of an interior closest point is perpendicular to the segment
    dd = np.einsum("ij,ij->i", b - a, b - a)
    t2, e = segment_offsets(p, a, b - a, dd)
    inner = (t2 > 0) & (t2 < 1)
    assert np.array_equal(t2, t) and inner.any()
    assert np.allclose(np.einsum("ij,ij->i", e, b - a)[inner], 0.0, atol=1e-10)


def test_segment_distance_of_a_point_segment_and_broadcast_rows():
    a = RNG.normal(size=(5, 3))
    p = RNG.normal(size=(5, 3))
    assert np.allclose(segment_distance(p, a, a), np.linalg.norm(p - a, axis=1), atol=1e-15)
    t, _ = closest_on_segments(p, a, a)
    assert np.array_equal(t, np.zeros(5))
    # (n, s, 3) points against (n, 1, 3) segments: each point against its row's segment
    b = RNG.normal(size=(5, 3))
    P = RNG.normal(size=(5, 7, 3))
    D = segment_distance(P, a[:, None], b[:, None])
    for i in range(5):
        assert np.allclose(D[i], segment_distance(P[i], a[i][None], b[i][None]), atol=1e-15)


def test_segment_distance2_2d_equals_the_3d_distance_in_a_plane():
    px, py = RNG.normal(size=100) * 4, RNG.normal(size=100) * 4
    for ax, ay, bx, by in ((0.0, 0.0, 1.0, 2.0), (1.0, -1.0, 1.0, -1.0), (-2.0, 3.0, 2.0, 3.0)):
        d2 = segment_distance2_2d(px, py, ax, ay, bx, by)
        P = np.stack([px, py, np.zeros(100)], axis=1)
        A = np.broadcast_to([ax, ay, 0.0], P.shape)
        B = np.broadcast_to([bx, by, 0.0], P.shape)
        assert np.allclose(np.sqrt(d2), _brute_segment_distance(P, A, B), atol=1e-3)
        assert np.allclose(d2, closest_on_segments(P, A, B)[1], atol=1e-12)


def test_barycentric_reconstructs_the_projection_of_the_point():
    k = 100
    A, B, C = (RNG.normal(size=(k, 3)) * 3 for _ in range(3))
    w = RNG.dirichlet([1, 1, 1], size=k) * 1.6 - 0.2  # some outside the triangle
    w[:, 2] = 1.0 - w[:, 0] - w[:, 1]
    inplane = w[:, :1] * A + w[:, 1:2] * B + w[:, 2:] * C
    n = unit(np.cross(B - A, C - A))
    P = inplane + RNG.normal(size=(k, 1)) * n  # off the plane along its normal
    bc = barycentric(P, A, B, C)
    assert np.allclose(bc.sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(bc, w, atol=1e-9)
    assert np.allclose(bc[:, :1] * A + bc[:, 1:2] * B + bc[:, 2:] * C, inplane, atol=1e-9)
    # a degenerate triangle gives finite numbers, not a division by zero
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        deg = barycentric(P[:1], A[:1], A[:1], A[:1])
    assert np.all(np.isfinite(deg))


def test_perpendicular_is_unit_and_normal_to_each_row_single_or_rows():
    rng = np.random.default_rng(7)
    a = rng.normal(size=(500, 3))
    a[:4] = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0.95, 0.3, 0.05]]  # near and on X
    a /= np.linalg.norm(a, axis=1)[:, None]
    p = perpendicular(a)
    assert p.shape == a.shape
    assert np.allclose(np.linalg.norm(p, axis=1), 1.0, atol=1e-14)
    assert np.abs(np.einsum("ij,ij->i", p, a)).max() < 1e-14
    for row, one in zip(a[:20], p[:20], strict=True):
        assert np.array_equal(perpendicular(row), one)  # one vector: the same as its row
