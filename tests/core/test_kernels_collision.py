"""Collision detection's compiled refine against the numpy reference on the same poses: the
same collision status per pose, clearances within 1e-9 mm (bench_collision's case, small)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.collision.obstacles import Obstacles
from blisk_cam.core.collision.scene import CollisionScene
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.tool.assembly import ToolAssembly
from blisk_cam.core.tool.cutter import Cutter

compiled = pytest.mark.skipif(
    backend.extension() is None or not hasattr(backend.extension(), "refine_pairs"),
    reason="the compiled kernels are not installed (make kernels), were built before the "
           "collision refine, or BLISK_CAM_KERNELS=numpy: only the numpy backend can run",
)


def _poses(V, F, axis, n, seed=0):
    """Bull-nose poses at random blade vertices, the axis leaned 20° off the normal away
    from the blisk axis (bench_collision's case: many touch the neighbours)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vn = np.zeros_like(V)
    for i in range(3):
        np.add.at(vn, F[:, i], fn)
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    pick = np.random.default_rng(seed).choice(len(V), size=n, replace=False)
    cc, nrm = V[pick], vn[pick]
    radial = cc - np.outer(cc @ axis.d, axis.d)
    radial -= np.einsum("ij,ij->i", radial, nrm)[:, None] * nrm
    a = nrm + math.tan(math.radians(20.0)) * radial / np.maximum(
        np.linalg.norm(radial, axis=1), 1e-12)[:, None]
    a /= np.linalg.norm(a, axis=1)[:, None]
    cutter = Cutter.bull(3.0, 1.0)
    return cutter, cutter.cl_points(cc, nrm, a), a


@compiled
@pytest.mark.parametrize("holder", [((12.0, 3.0), (47.0, 3.0), (47.0, 12.0), (107.0, 12.0)),
                                    ((12.0, 3.0), (30.0, 6.0), (60.0, 10.0))])
def test_collision_status_and_clearance_agree_on_both_backends(holder):
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=24)
    V, F = d.blade_vertices, d.blade_faces
    cutter, tips, axes = _poses(V, F, d.axis, 1500)
    ob = Obstacles.build(V, F, d.axis, 24, 2, check_extra=False)
    sc = CollisionScene(ob, cutter, ToolAssembly(12.0, holder, 1.0))
    with backend.numpy_only():
        ref = sc.detect(tips, axes, workers=1)
    got = sc.detect(tips, axes, workers=2)
    assert 0 < ref.colliding.sum() < len(tips)  # both outcomes occur: the check can fail
    np.testing.assert_array_equal(got.colliding, ref.colliding)
    np.testing.assert_allclose(got.clearance, ref.clearance, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(got.part, ref.part)


@compiled
def test_compiled_walk_agrees_with_hub_flute_on_target_and_small_batches():
    """The compiled detection (tree walk and refine in one call) against numpy with a second
    obstacle group (the hub: one copy, owners per triangle), the flute counted on the target
    blade too, several chunks per call, and a batch so small that numpy keeps every node
    (its beams start only past 32 frontier pairs a chunk): every figure the same."""
    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=24)
    V, F = d.blade_vertices, d.blade_faces
    cutter, tips, axes = _poses(V, F, d.axis, 400, seed=1)
    ob = Obstacles.build(V, F, d.axis, 24, 1, extra=[("hub", d.hub_vertices, d.hub_faces)],
                         check_extra=False)
    sc = CollisionScene(ob, cutter, ToolAssembly(12.0, ((12.0, 3.0), (30.0, 6.0), (60.0, 10.0)),
                                                 1.0))
    for fot, chunk, n in ((False, 64, 400), (True, 64, 400), (False, 1024, 3)):
        with backend.numpy_only():
            ref = sc.detect(tips[:n], axes[:n], workers=1, chunk=chunk, flute_on_target=fot)
        got = sc.detect(tips[:n], axes[:n], workers=2, chunk=chunk, flute_on_target=fot)
        np.testing.assert_array_equal(got.colliding, ref.colliding)
        np.testing.assert_allclose(got.clearance, ref.clearance, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(got.obstacle, ref.obstacle)
        np.testing.assert_array_equal(got.part, ref.part)
        np.testing.assert_allclose(got.point, ref.point, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.normal, ref.normal, rtol=0, atol=1e-12)
        if n > 3 and not fot:  # (with the flute on the target blade every pose touches it)
            assert 0 < ref.colliding.sum() < n  # both outcomes occur
            assert np.any(ref.obstacle == len(ob.meshes) - 1)  # the hub is met
