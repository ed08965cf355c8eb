"""The compiled set-up of ``MeshConeSlicer`` for a cone pair (the vertices' r, z, radial
vectors and morph ratio s, the faces' least and largest s, the face index of
``_index_face_ranges``) against the numpy reference: the same bits, the same buckets in the
same order, on the demo blade about a tilted axis, on vertices off the cone family (s = ±inf),
on vertices lying exactly on cone 1, and the spans' quantile against ``np.quantile``."""

import numpy as np
import pytest

from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.core.paths.slicing import MeshConeSlicer
from tests.support.kernels import needs_compiled

kernel = needs_compiled("slicer_face_index")

_ARRAYS = ("r", "z", "radial", "s", "face_smin", "face_smax", "_narrow_faces",
           "_bucket_start", "_wide_faces")


def _bits(a, b, where):
    assert a.dtype == b.dtype and a.shape == b.shape, where
    assert np.array_equal(a.view(np.uint8), b.view(np.uint8)), where


def _both(mesh, axis, morph):
    a = MeshConeSlicer(mesh, axis, morph)
    with backend.numpy_only():
        b = MeshConeSlicer(mesh, axis, morph)
    for name in _ARRAYS:
        _bits(getattr(a, name), getattr(b, name), name)
    # the same values (the least of the narrow faces' s, a reduction, may differ in the sign
    # of a zero: no key depends on it)
    for name in ("_bucket_lo", "_bucket_scale", "_narrow_span", "s_range", "_s_margin"):
        assert getattr(a, name) == getattr(b, name), name
    return a


@kernel
def test_the_demo_blade_about_a_tilted_axis():
    d = make_demo_blisk()
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    sl = _both(mesh, d.axis, MorphingCones(d.hub_cone, d.tip_cone))
    assert len(sl._wide_faces) > 0 and len(sl._narrow_faces) > 0.99 * mesh.n_faces
    # an axis that is no coordinate axis: z is numpy's (V − o) @ d, r its own sum
    rng = np.random.default_rng(8)
    d_ax = rng.normal(size=3)
    axis = Axis(origin=(0.3, -1.7, 2.9), direction=tuple(d_ax))
    sl = _both(mesh, axis, MorphingCones(d.hub_cone, d.tip_cone))
    r, z = meridional(mesh.V, axis)
    _bits(sl.r, r, "r")
    _bits(sl.z, z, "z")


@kernel
def test_vertices_off_the_family_and_on_cone_one():
    """A meridional grid far beyond two cones: s = ±inf off the family, and vertices placed
    exactly on cone 1's line (s = 0, its sign of zero kept)."""
    c1, c2 = Cone(100.0, 0.0, 100.0, 50.0), Cone(200.0, 0.0, 150.0, 50.0)
    morph = MorphingCones(c1, c2)
    x, y = np.meshgrid(np.linspace(0.0, 800.0, 61), np.linspace(-400.0, 400.0, 41))
    V = np.stack([x.ravel(), np.zeros(x.size), y.ravel()], axis=1)
    V[::7, 0] = 100.0  # on cone 1 (r = 100, z within it or on its extension)
    i = (np.arange(60)[None, :] + 61 * np.arange(40)[:, None]).ravel()
    F = np.concatenate([np.stack([i, i + 1, i + 62], 1), np.stack([i, i + 62, i + 61], 1)])
    mesh = TriMesh(V=V, F=F)
    sl = _both(mesh, Axis(), morph)
    assert np.isinf(sl.s).any() and np.any(sl.s == 0.0)  # measured: both kinds present
    assert len(sl._wide_faces) > 0


@kernel
@pytest.mark.parametrize("n", [1, 2, 3, 1000, 1001, 4096])
def test_the_face_index_against_the_reference(n):
    """Spans with ties, infinite and NaN ends; the quantile as np.quantile interpolates."""
    rng = np.random.default_rng(n)
    lo = np.round(rng.normal(size=n), 2)
    hi = lo + np.round(rng.exponential(0.05, size=n), 3)
    if n > 3:
        lo[:5] = [-np.inf, np.nan, 0.5, -0.0, 7.0]
        hi[:5] = [0.1, 0.2, np.inf, 0.0, np.nan]
    sl = MeshConeSlicer.__new__(MeshConeSlicer)
    sl.face_smin, sl.face_smax = lo, hi
    sl._index_face_ranges()
    got = {k: getattr(sl, k) for k in ("_narrow_faces", "_bucket_start", "_wide_faces",
                                        "_bucket_lo", "_bucket_scale", "_narrow_span")}
    with backend.numpy_only():
        sl._index_face_ranges()
    for k, v in got.items():
        if isinstance(v, np.ndarray):
            _bits(v, getattr(sl, k), k)
        else:
            assert v == getattr(sl, k), k
    w = hi - lo
    want = float(np.quantile(w[np.isfinite(w)], MeshConeSlicer._NARROW_QUANTILE))
    assert got["_narrow_span"] == 2.0 * want + 1e-9
