"""Collision detection's compiled refine against the numpy reference on the same poses: the
same collision status per pose, clearances within 1e-9 mm (bench_collision's case, small)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.collision.obstacles import Obstacles
from blisk_cam.core.collision.scene import CollisionScene
from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import collision as kernels_collision
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.tool.assembly import ToolAssembly
from blisk_cam.core.tool.cutter import Cutter
from tests.support.kernels import needs_compiled

compiled = needs_compiled("refine_pairs")


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


def _tree_arrays(tree):
    out = {k: getattr(tree, k) for k in ("cen", "rad", "A", "B", "C", "nrm", "ok")}
    for i, lv in enumerate(tree.levels):
        for name, x in zip(("centre", "radius", "rep", "half"), lv, strict=True):
            out[f"level{i}.{name}"] = x
    return out


def _compiled_arrays(tree):
    """The arrays the compiled detection walks (held in the compiled tree)."""
    tris, levels = kernels_collision.tree_arrays(tree._compiled)
    out = dict(zip(("cen", "rad", "A", "B", "C", "nrm", "ok"), tris, strict=True))
    for i, lv in enumerate(levels):
        for name, x in zip(("centre", "radius", "rep", "half"), lv, strict=True):
            out[f"level{i}.{name}"] = x
    return out


@pytest.mark.skipif(backend.extension() is None
                    or not hasattr(backend.extension(), "collision_tree_build"),
                    reason="the compiled kernels are not installed or predate the tree build")
def test_compiled_tree_build_equals_numpy_build():
    """The compiled triangle tree (Morton order, gathers, node boxes, spheres,
    representatives, normals) is the numpy build array for array, bit for bit: on the blade
    with the hub (owners per triangle, a count that fills no leaf), on a single triangle, and
    on a mesh with a degenerate triangle and equal Morton keys (the stable order)."""
    from blisk_cam.core.collision.tri_tree import _TriTree

    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=24)
    V = np.concatenate([d.blade_vertices, d.hub_vertices])
    F = np.concatenate([d.blade_faces, d.hub_faces + len(d.blade_vertices)])[:-3]
    owner = np.repeat([0, 5], [len(d.blade_faces), len(F) - len(d.blade_faces)])
    tiny_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 2, 2], [0, 0, 0]])
    tiny_F = np.array([[0, 1, 2], [0, 1, 4], [2, 1, 0], [3, 3, 3], [1, 2, 3]])
    for V_, F_, own in ((V, F, owner), (tiny_V, tiny_F[:1], np.zeros(1, np.int64)),
                        (tiny_V, tiny_F, np.arange(5))):
        ref_tree = _TriTree(V_, F_, own, compiled=False)
        ref = _tree_arrays(ref_tree)
        got_tree = _TriTree(V_, F_, own, compiled=True)
        got = _compiled_arrays(got_tree)
        np.testing.assert_array_equal(got_tree.owner, ref_tree.owner)
        T = np.arange(len(F_))[::-1]
        np.testing.assert_array_equal(got_tree.normals(T), ref_tree.normals(T))
        lazy = _tree_arrays(got_tree)  # the numpy arrays of the compiled build, when asked
        assert got.keys() == ref.keys() == lazy.keys()
        for k in ref:
            assert got[k].dtype == ref[k].dtype and got[k].shape == ref[k].shape, k
            np.testing.assert_array_equal(got[k], ref[k], err_msg=k)
            np.testing.assert_array_equal(lazy[k], ref[k], err_msg=k)
        assert got_tree.counts == ref_tree.counts
    assert got["ok"].sum() == 3  # the two degenerate triangles' normals are not used


def test_neighbours_made_by_build_are_known_copies_without_comparing_vertices():
    """Obstacles.build marks the neighbours it turns; the scene takes them as copies at
    the angle the vertex comparison gives (the same with the mark removed)."""
    from dataclasses import replace

    from blisk_cam.core.collision.scene import _copy_angle

    d = make_demo_blisk(resolution=0.3, fillet=False, blade_count=24)
    ob = Obstacles.build(d.blade_vertices, d.blade_faces, d.axis, 24, 2, check_extra=False)
    bare = replace(ob, meshes=(ob.meshes[0],) + tuple(replace(m, turned_from=None)
                                                    for m in ob.meshes[1:]))
    for i in range(1, 5):
        assert ob.meshes[i].turned_from is not None
        a = _copy_angle(ob, i)
        assert a == _copy_angle(bare, i)
        assert a == pytest.approx((1 if i % 2 else -1) * ((i + 1) // 2) * 2 * math.pi / 24)
    # a mark naming another blade array is not trusted
    other = replace(ob, meshes=(replace(ob.meshes[0], V=ob.meshes[0].V + 1.0),)
                    + ob.meshes[1:])
    assert _copy_angle(other, 1) is None
