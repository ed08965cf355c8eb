"""The frame the axis planner measures its states in (core/collision/axis_field.py): a deviation
held along a pass turns no more than the reference axis does, even where the reference sweeps
fast (a blade edge); the frame of a closed loop is continuous across the closing cut; the
exponential and logarithmic maps invert each other."""

from __future__ import annotations

import math

import numpy as np

from blisk_cam.core.collision.axis_field import (
    deviation_axes,
    deviation_of,
    transported_frames,
)


def _loop(k=400):
    """Reference axes of a closed loop on the sphere round 75° from the pole: ±35° in
    longitude, ±10° in latitude (an axis near radial round a blade section; the loop encloses
    area, so a frame carried round it comes back turned)."""
    s = np.linspace(0.0, 2 * math.pi, k, endpoint=False)
    lon = math.radians(35.0) * np.cos(s)
    lat = math.radians(75.0) + math.radians(10.0) * np.sin(s)
    return np.c_[np.sin(lat) * np.cos(lon), np.sin(lat) * np.sin(lon), np.cos(lat)]


def _turns(a):
    return np.arccos(np.clip(np.einsum("ij,ij->i", a[1:], a[:-1]), -1.0, 1.0))


def test_a_held_deviation_turns_no_more_than_the_reference():
    R = _loop()
    e1, e2 = transported_frames(R, np.array([0.0, 0.0, 1.0]))
    ref_turn = _turns(R)
    for du, dv in ((math.radians(10), 0.0), (0.0, math.radians(-25)),
                   (math.radians(40), math.radians(30))):
        A = deviation_axes(R, e1, e2, np.full(len(R), du), np.full(len(R), dv))
        assert np.all(_turns(A) <= ref_turn + 1e-9)
        # measured independently: the angle from the reference is the deviation's size
        ang = np.arccos(np.clip(np.einsum("ij,ij->i", A, R), -1.0, 1.0))
        assert np.allclose(ang, math.hypot(du, dv), atol=1e-9)


def test_the_frame_of_a_closed_loop_is_continuous_across_the_closing_cut():
    R = _loop()
    k = len(R)
    arc = np.r_[0.0, np.cumsum(np.r_[_turns(R), _turns(np.vstack([R[-1], R[0]]))])]
    e1, e2 = transported_frames(R, np.array([0.0, 0.0, 1.0]), arc)
    assert np.allclose(np.einsum("ij,ij->i", e1, R), 0.0, atol=1e-12)
    assert np.allclose(np.linalg.norm(e1, axis=1), 1.0)
    assert np.allclose(np.linalg.norm(e2, axis=1), 1.0)
    dev = math.radians(20.0)
    A = deviation_axes(R, e1, e2, np.full(k, dev), np.zeros(k))
    closing = float(np.arccos(np.clip(A[-1] @ A[0], -1.0, 1.0)))
    ref_closing = float(np.arccos(np.clip(R[-1] @ R[0], -1.0, 1.0)))
    # the holonomy spun back over the loop: a step at the cut like any other step
    assert closing <= ref_closing + 2 * np.max(_turns(A)) + 1e-9
    # without it, the frame comes back turned about the axis (the loop encloses area)
    f1, f2 = transported_frames(R, np.array([0.0, 0.0, 1.0]))
    B = deviation_axes(R, f1, f2, np.full(k, dev), np.zeros(k))
    assert float(np.arccos(np.clip(B[-1] @ B[0], -1.0, 1.0))) > closing + math.radians(1.0)


def test_log_inverts_exp():
    R = _loop(50)
    e1, e2 = transported_frames(R, np.array([0.0, 0.0, 1.0]))
    rng = np.random.default_rng(3)
    u, v = rng.uniform(-1.2, 1.2, (2, len(R)))
    A = deviation_axes(R, e1, e2, u, v)
    uu, vv = deviation_of(A, R, e1, e2)
    assert np.allclose(uu, u, atol=1e-9) and np.allclose(vv, v, atol=1e-9)


def _edge(radius, k=19, inward=False):
    """Contact points and unit normals round half a circle of ``radius`` mm (a blade edge;
    ``inward``: the normals toward the centre, a concave fillet), the planned axes fixed
    along z (no planned turn)."""
    phi = np.linspace(0.0, math.pi, k)
    n = np.c_[np.cos(phi), np.sin(phi), np.zeros(k)]
    return radius * n, (-n if inward else n), np.tile([0.0, 0.0, 1.0], (k, 1)), phi


def test_the_turn_limit_is_per_mm_of_the_tool_path_round_an_edge():
    """Round a 0.5 mm blade edge a Ø12 ball's centre runs on a circle of 6.5 mm while the
    contact runs on 0.5 mm: the limit allows turn_per_mm × the centre's chord per pose,
    2·6.5·sin(Δφ/2) (analytic), 13 times the contact's; a flat end (no corner) the
    contact's; a concave arc (the centre's circle the smaller) the contact's too."""
    from blisk_cam.core.collision.axis_field import MIN_STEP, path_steps, turn_limits

    rate = math.radians(2.0)
    cc, n, ax, phi = _edge(0.5)
    dphi = np.diff(phi)
    got = turn_limits(cc, n, ax, 6.0, rate)
    assert np.allclose(got, rate * 2 * 6.5 * np.sin(dphi / 2), rtol=1e-12)
    assert np.allclose(path_steps(cc, n, 6.0).sum(), 2 * 6.5 * np.sin(dphi / 2).sum())
    flat = turn_limits(cc, n, ax, 0.0, rate)
    assert np.allclose(flat, rate * np.maximum(2 * 0.5 * np.sin(dphi / 2), MIN_STEP))
    cc, n, ax, phi = _edge(10.0, inward=True)  # the centre on a 4 mm circle
    assert np.allclose(turn_limits(cc, n, ax, 6.0, rate),
                       rate * 2 * 10.0 * np.sin(np.diff(phi) / 2), rtol=1e-12)
    # the planned turn is added; a pose repeated counts MIN_STEP; max_turn caps the added part
    tilt = np.c_[np.sin(phi), np.zeros(len(phi)), np.cos(phi)]
    assert np.allclose(turn_limits(cc, n, tilt, 6.0, rate) - np.diff(phi),
                       rate * 2 * 10.0 * np.sin(np.diff(phi) / 2), atol=1e-12)
    same = np.zeros((2, 3)), np.tile([1.0, 0.0, 0.0], (2, 1)), np.tile([0.0, 0.0, 1.0], (2, 1))
    assert np.allclose(turn_limits(*same, 6.0, rate), rate * MIN_STEP)
    cap = math.radians(1.0)
    cc, n, ax, _ = _edge(0.5)
    assert np.allclose(turn_limits(cc, n, ax, 6.0, rate, cap),
                       np.minimum(rate * 2 * 6.5 * np.sin(dphi / 2), cap))
