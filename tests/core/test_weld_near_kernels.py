"""The compiled tolerance pass of the weld for distinct points (``kernels.weld_near``) against
numpy's: the columns' extents (−0.0 as 0.0), and "no pair" exactly when numpy's scan
(``weld._close_pairs``) finds none — not for a pair within the tolerance, two equal
projections or points crowding one plane across the scan direction (numpy's k-d tree case)."""

import numpy as np

from blisk_cam.core.geometry import weld
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend, weld_near
from tests.support.kernels import needs_compiled

kernel = needs_compiled("weld_extents", "weld_no_close_pairs")

D, SCAN = weld._WELD_DIRECTION, weld._WELD_SCAN_MAX


def _numpy_pairs(V, tol):
    """numpy's scan of all the points V: its pairs, or None (it would ask a k-d tree)."""
    u = (V[:, 0] + 0.0) * D[0] + (V[:, 1] + 0.0) * D[1]
    u = u + (V[:, 2] + 0.0) * D[2]
    order = np.argsort(u, kind="stable")
    us = u[order]
    if np.any(us[1:] == us[:-1]):
        return None
    return weld._close_pairs(V, order, tol, u=us)


@kernel
def test_extents_are_numpy_s():
    rng = np.random.default_rng(3)
    V = rng.normal(size=(1000, 3)) * [1e3, 1.0, 1e-6]
    V[:, 2] = np.where(V[:, 2] > 0, -0.0, 0.0)  # a column of signed zeros: extent +0.0
    got = weld_near.weld_extents(V)
    want = np.array([c.max() - c.min() for c in (V + 0.0).T])
    assert np.array_equal(got.view(np.uint8), want.view(np.uint8))


@kernel
def test_no_pair_exactly_when_numpy_finds_none():
    rng = np.random.default_rng(21)
    V = rng.uniform(-100.0, 100.0, size=(20_000, 3))
    tol = 1e-3
    pairs = _numpy_pairs(V, tol)
    assert pairs is not None and len(pairs) == 0
    assert weld_near.weld_no_close_pairs(V, D, tol, SCAN)
    # a point within the tolerance of another: numpy's pair
    W = np.concatenate([V, V[17:18] + [4e-4, -3e-4, 2e-4]])
    assert len(_numpy_pairs(W, tol)) == 1
    assert not weld_near.weld_no_close_pairs(W, D, tol, SCAN)
    # two points of one projection (numpy asks a k-d tree)
    W = np.concatenate([V, V[3:4]])
    assert _numpy_pairs(W, tol) is None
    assert not weld_near.weld_no_close_pairs(W, D, tol, SCAN)
    # points crowding one plane across the direction, far apart in it: no pair, but more
    # than SCAN neighbours within the slack (numpy asks a k-d tree)
    a, b = np.cross(D, [0.0, 0.0, 1.0]), np.cross(D, [0.0, 1.0, 0.0])
    k = np.arange(SCAN + 5)[:, None]
    W = np.concatenate([V, 500.0 + 10.0 * k * a + 1e-9 * k * b])
    assert _numpy_pairs(W, tol) is None
    assert not weld_near.weld_no_close_pairs(W, D, tol, SCAN)
    assert not weld_near.weld_no_close_pairs(V, D, 1e3, SCAN)  # everything close


@kernel
def test_a_soup_welded_on_both_backends():
    """An STL-like soup already welded exactly (distinct corners), once with nothing to merge
    and once with a corner moved within the tolerance of another: the same mesh."""
    x, y = np.meshgrid(np.linspace(0, 10, 40), np.linspace(0, 5, 20))
    V = np.stack([x.ravel(), y.ravel(), 0.1 * np.sin(x.ravel())], axis=1)
    i = (np.arange(39)[None, :] + 40 * np.arange(19)[:, None]).ravel()
    F = np.concatenate([np.stack([i, i + 1, i + 41], 1), np.stack([i, i + 41, i + 40], 1)])
    for nudge in (False, True):
        W, G = V.copy(), F.copy()
        if nudge:  # a new vertex 1e-9 mm from vertex 45, in one of the faces of 45
            W = np.concatenate([W, W[45:46] + 1e-9])
            f = np.flatnonzero(np.any(G == 45, axis=1))[0]
            G[f][G[f] == 45] = len(V)
        a = TriMesh.from_arrays(W, G, soup_corners=3 * len(G))
        with backend.numpy_only():
            b = TriMesh.from_arrays(W, G, soup_corners=3 * len(G))
        for name in ("V", "F", "face_map"):
            x_, y_ = getattr(a, name), getattr(b, name)
            assert np.array_equal(x_.view(np.uint8), y_.view(np.uint8)), name
        assert a.welded_vertices == b.welded_vertices
        assert a.n_vertices == len(V)  # measured: the nudged vertex merged into vertex 5
