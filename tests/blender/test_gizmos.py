"""The cone gizmos under the bpy wheel (4.5 and 5.2), without a window: registration, the
gizmo group's poll, the handles' target get/set handlers (world position ↔ cone settings, in
several unit scales and with a tilted axis Empty), the draw line sets and the live-preview
cache with its depsgraph invalidation. Drawing itself needs a GPU context and a viewport,
which background mode does not have."""

import math
from pathlib import Path

import bpy
import numpy as np
import pytest

import blisk_cam
from blisk_cam.blender import objects as blender_io
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.gizmos import cone_frame as cf

GIZMO_CLASSES = ("BLISKCAM_GT_cone_handle", "BLISKCAM_GT_cone_lines", "BLISKCAM_GGT_cones")


@pytest.fixture
def addon():
    """The add-on registered for one test, always unregistered again (bpy 4.5 hangs at exit
    with classes registered)."""
    blisk_cam.register()
    try:
        from blisk_cam.gizmos import cone_gizmos

        yield cone_gizmos
    finally:
        blisk_cam.unregister()


@pytest.fixture
def blade_scene(addon, demo):
    """A scene with the demo blade (mm, default units) and its hub and tip cones set."""
    obj = blender_io.arrays_to_object("Blade", demo.blade_vertices, demo.blade_faces)
    s = bpy.context.scene.blisk_cam
    s.blade = obj
    s.cone1 = demo.hub_cone.as_list()
    s.cone2 = demo.tip_cone.as_list()
    bpy.context.view_layer.update()
    return bpy.context.scene


def registered(name):
    for base in (bpy.types.Gizmo, bpy.types.GizmoGroup):
        cls = base.bl_rna_get_subclass_py(name)
        if cls is not None:
            return True
    return False


# --- registration ---------------------------------------------------------------------------
def test_register_and_unregister_cleanly():
    from blisk_cam.gizmos import cone_gizmos

    assert not any(registered(n) for n in GIZMO_CLASSES)
    blisk_cam.register()
    try:
        assert all(registered(n) for n in GIZMO_CLASSES)
        assert [c.__name__ for c in blisk_cam.gizmos.CLASSES] == list(GIZMO_CLASSES)
        assert cone_gizmos._on_depsgraph_update in bpy.app.handlers.depsgraph_update_post
        assert cone_gizmos._on_load_post in bpy.app.handlers.load_post
        blisk_cam.register()  # a second register starts clean
        assert bpy.app.handlers.depsgraph_update_post.count(cone_gizmos._on_depsgraph_update) == 1
        cone_gizmos._schedule_redraw(30.0)  # a pending preview redraw...
        assert bpy.app.timers.is_registered(cone_gizmos._redraw_views)
    finally:
        blisk_cam.unregister()
    assert not any(registered(n) for n in GIZMO_CLASSES)
    assert cone_gizmos._on_depsgraph_update not in bpy.app.handlers.depsgraph_update_post
    assert cone_gizmos._on_load_post not in bpy.app.handlers.load_post
    assert not bpy.app.timers.is_registered(cone_gizmos._redraw_views)  # ...is cancelled


def test_poll_needs_a_blade_the_switch_and_a_cone(addon, blade_scene):
    ggt = addon.BLISKCAM_GGT_cones
    ctx = bpy.context
    s = blade_scene.blisk_cam
    assert ggt.poll(ctx)
    s.show_gizmos = False
    assert not ggt.poll(ctx)
    s.show_gizmos = True
    s.cone1 = (0.0, 0.0, 0.0, 0.0)
    assert ggt.poll(ctx)  # cone 2 is still there to edit
    s.cone2 = (0.0, 0.0, 0.0, 0.0)
    assert not ggt.poll(ctx)  # nothing to show: fit or type the cones first
    s.cone1 = (150.0, -25.0, 165.0, 35.0)
    s.blade = None
    assert not ggt.poll(ctx)


# --- the handles' get/set handlers -----------------------------------------------------------
def check_handles_on_settings(addon, scene, axis_mm, f):
    """Every handle's world position (BU) has the meridional (r, z) of its setting and lies
    in the half-plane through the blade's bounding-box centre."""
    s = scene.blisk_cam
    obj = s.blade
    corners = np.array([tuple(c) for c in obj.bound_box]) @ np.array(obj.matrix_world)[:3, :3].T
    centre = (corners + np.array(obj.matrix_world)[:3, 3]).mean(axis=0) * f
    theta = cf.half_plane_angle(axis_mm, centre)
    for h in cf.HANDLES:
        p = np.array(addon.handle_get(scene, h.name)) * f  # mm
        r, z = meridional(p[None], axis_mm)
        vals = tuple(getattr(s, h.prop))
        i, j = h.indices
        assert r[0] == pytest.approx(vals[i], abs=1e-6 * f)
        assert z[0] == pytest.approx(vals[j], abs=1e-6 * f)
        assert cf.half_plane_angle(axis_mm, p) == pytest.approx(theta, abs=1e-9)


def test_handle_get_maps_the_cone_settings_to_world_positions(addon, blade_scene, demo):
    check_handles_on_settings(addon, blade_scene, Axis(), 1.0)
    # the half-plane is the blade's: near the blade centre's angle (about 0 for blade 0)
    plane = addon.scene_plane(blade_scene)
    assert abs(plane.theta) < demo.pitch / 2


def test_handle_set_projects_into_the_half_plane_and_writes_mm(addon, blade_scene):
    s = blade_scene.blisk_cam
    plane = addon.scene_plane(blade_scene)
    before = {"cone1": tuple(s.cone1), "cone2": tuple(s.cone2)}
    targets = {"P1": (152.0, -20.0), "P2": (170.0, 40.0), "Q1": (210.0, -30.0), "Q2": (230.0, 30.5)}
    for name, (r, z) in targets.items():
        # the dragged point is 7 mm off the plane: it is projected back onto (r, z)
        world = plane.to_world(r, z) + 7.0 * plane.normal
        assert addon.handle_set(blade_scene, name, world)
        h = cf.handle(name)
        vals = tuple(getattr(s, h.prop))
        i, j = h.indices
        assert (vals[i], vals[j]) == pytest.approx((r, z), abs=1e-4)
        # the other end point of that cone did not move
        k, m = (2, 3) if h.end == 0 else (0, 1)
        assert (vals[k], vals[m]) == before[h.prop][k : m + 1]
        before[h.prop] = vals
    assert tuple(s.cone1) == pytest.approx((152.0, -20.0, 170.0, 40.0), abs=1e-4)
    assert tuple(s.cone2) == pytest.approx((210.0, -30.0, 230.0, 30.5), abs=1e-4)
    # get ∘ set is the identity on the half-plane
    for name, (r, z) in targets.items():
        assert addon.handle_get(blade_scene, name) == pytest.approx(
            tuple(plane.to_world(r, z)), abs=1e-4
        )


def test_handle_set_constraints(addon, blade_scene):
    s = blade_scene.blisk_cam
    plane = addon.scene_plane(blade_scene)
    c1 = tuple(s.cone1)
    # onto the other end point of the same cone: refused, nothing written
    assert not addon.handle_set(blade_scene, "P1", plane.to_world(c1[2], c1[3]))
    assert tuple(s.cone1) == c1
    # beyond the axis: r clamps to 0
    assert addon.handle_set(blade_scene, "P1", plane.to_world(-40.0, -25.0))
    assert tuple(s.cone1)[:2] == pytest.approx((0.0, -25.0), abs=1e-5)
    with pytest.raises(cf.GizmoError):
        addon.handle_set(blade_scene, "X9", (0.0, 0.0, 0.0))


def test_handles_follow_units_and_a_tilted_axis_empty(addon, blade_scene):
    """1 BU = 10 mm (centimetre scene) and an axis Empty away from the world Z: positions are
    in BU, settings stay in mm, the handles lie on the Empty's axis."""
    scene = blade_scene
    scene.unit_settings.scale_length = 0.01
    f = blender_io.mm_per_blender_unit(scene)
    assert f == pytest.approx(10.0)
    empty = bpy.data.objects.new("Axis", None)
    scene.collection.objects.link(empty)
    empty.location = (1.5, -2.0, 0.5)  # BU
    empty.rotation_euler = (0.3, -0.2, 0.4)
    scene.blisk_cam.axis_object = empty
    bpy.context.view_layer.update()
    axis = blender_io.object_axis(empty, mm_per_unit=f)
    assert np.allclose(axis.o, [15.0, -20.0, 5.0])
    check_handles_on_settings(addon, scene, axis, f)
    plane = addon.scene_plane(scene)
    assert plane.mm_per_unit == pytest.approx(10.0)
    assert addon.handle_set(scene, "Q2", plane.to_world(240.0, 33.0))
    assert tuple(scene.blisk_cam.cone2)[2:] == pytest.approx((240.0, 33.0), abs=1e-4)
    p = np.array(addon.handle_get(scene, "Q2"))
    assert np.linalg.norm(p * f - axis.o) == pytest.approx(math.hypot(240.0, 33.0), abs=1e-3)


# --- draw geometry -----------------------------------------------------------------------------
def test_line_sets_draw_the_two_cones_and_the_middle_one(addon, blade_scene, demo):
    key, sets = addon.scene_line_sets(blade_scene, preview=False)
    assert key is not None and len(sets) == 3
    (l1, col1, _), (l2, col2, _), (lm, colm, _) = sets
    assert col1 == addon.COLOR_CONE1 and col2 == addon.COLOR_CONE2 and colm == addon.COLOR_MIDDLE
    mid = Cone(*(0.5 * (np.array(demo.hub_cone.as_list()) + demo.tip_cone.as_list())))
    for lines, cone in ((l1, demo.hub_cone), (l2, demo.tip_cone), (lm, mid)):
        r, z = meridional(lines, Axis())
        assert np.abs(cone.signed_distance(r, z)).max() < 1e-3  # float32 settings
    # a pair that cannot morph: both cones in red, no middle cone, no preview
    blade_scene.blisk_cam.cone2 = (215.0, -25.0, 140.0, 35.0)  # crosses cone 1
    _, sets = addon.scene_line_sets(blade_scene, preview=True)
    assert [c for _, c, _ in sets] == [addon.COLOR_INVALID, addon.COLOR_INVALID]


# --- live preview -------------------------------------------------------------------------------
def test_preview_curves_cache_and_depsgraph_invalidation(addon, blade_scene, demo):
    scene = blade_scene
    s = scene.blisk_cam
    preview = addon.PREVIEW
    assert addon.update_preview(scene) is None or getattr(s, "live_preview", False)
    res = addon.update_preview(scene, enabled=True)
    assert res is not None and res.error is None
    assert sorted({c.s for c in res.curves}) == pytest.approx(list(preview.levels))
    mc = MorphingCones(Cone(*s.cone1), Cone(*s.cone2))
    for c in res.curves:
        r, z = meridional(c.points, Axis())
        # the end levels are the float32 boundary vertices (the slicer's on_tol = 1e-4 mm)
        tol = 1e-4 if c.s in (0.0, 1.0) else 1e-6
        assert np.abs(mc.cone_at(c.s).signed_distance(r, z)).max() < tol
    loads = preview.mesh_loads
    # the same request: cached; new cones: sliced again on the cached mesh
    assert addon.update_preview(scene, enabled=True) is res
    s.cone1 = (151.0, -25.0, 166.0, 35.0)
    res2 = addon.update_preview(scene, enabled=True)
    assert res2 is not res and preview.mesh_loads == loads
    # the preview curves are drawn, one set per level, in BU
    _, sets = addon.scene_line_sets(scene, preview=True)
    assert len(sets) == 3 + len(preview.levels)
    # an unrelated object changes: the cache stays
    other = blender_io.arrays_to_object("Other", [[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    bpy.context.view_layer.update()
    other.location.x = 5.0
    bpy.context.view_layer.update()
    assert preview.has_mesh()
    # the blade moves 2 mm along the axis: depsgraph update → cache dropped → new curves
    z_before = np.concatenate([c.points[:, 2] for c in res2.curves if c.s == 0.5])
    s.blade.location.z = 2.0
    bpy.context.view_layer.update()
    assert not preview.has_mesh()
    res3 = addon.update_preview(scene, enabled=True)
    assert preview.mesh_loads == loads + 1 and res3.error is None
    # the axis is the blade's own Z through its origin, so it moved with it: the curves at
    # s = 0.5 are the same relative to the blade, 2 mm higher in the world
    z_after = np.concatenate([c.points[:, 2] for c in res3.curves if c.s == 0.5])
    assert z_after.mean() == pytest.approx(z_before.mean() + 2.0, abs=1e-6)
    # a mesh edit (vertex moved) also drops it
    s.blade.data.vertices[0].co.x += 0.5
    s.blade.data.update()
    bpy.context.view_layer.update()
    assert not preview.has_mesh()


def _fresh_slice(scene):
    """The preview curves of the scene's cones sliced from scratch: the blade read again, a
    slicer over its whole mesh (no cache, no index)."""
    from blisk_cam.gizmos.lmc_preview import LmcPreview

    s = scene.blisk_cam
    V, F = blender_io.object_to_arrays(s.blade)
    res = LmcPreview(indexed=False).compute("fresh", lambda: (V, F), addon_axis(scene),
                                            tuple(s.cone1), tuple(s.cone2))
    assert res.error is None
    return res


def addon_axis(scene):
    from blisk_cam.gizmos import cone_gizmos

    return cone_gizmos.scene_axis(scene)


def _assert_same_curves(a, b):
    assert [(c.s, c.closed, len(c.points)) for c in a.curves] == [
        (c.s, c.closed, len(c.points)) for c in b.curves]
    for x, y in zip(a.curves, b.curves, strict=True):
        np.testing.assert_allclose(x.points, y.points, rtol=0, atol=1e-9)


def test_preview_of_a_changed_mesh_equals_a_fresh_slice(addon, blade_scene):
    """The cached mesh and meridional index follow the blade: after a mesh edit — seen by
    the depsgraph handler, or only by the vertex and face counts of the key when no depsgraph
    update ran — the preview is that of the edited mesh, as a slicer over all of it gives."""
    scene = blade_scene
    s = scene.blisk_cam
    preview = addon.PREVIEW
    res = addon.update_preview(scene, enabled=True)
    assert res.error is None and preview.indexed
    _assert_same_curves(res, _fresh_slice(scene))
    s.cone1 = (151.0, -25.0, 166.0, 35.0)  # a drag step: sliced on the cached index
    res = addon.update_preview(scene, enabled=True)
    _assert_same_curves(res, _fresh_slice(scene))
    loads, before = preview.mesh_loads, res

    # every vertex 1 % further out (the mesh data, not the object): a depsgraph update
    me = s.blade.data
    co = np.empty(len(me.vertices) * 3)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, :2] *= 1.01
    me.vertices.foreach_set("co", co.ravel())
    me.update()
    bpy.context.view_layer.update()
    res = addon.update_preview(scene, enabled=True)
    assert preview.mesh_loads == loads + 1 and res.error is None
    _assert_same_curves(res, _fresh_slice(scene))
    assert not np.allclose(res.curves[3].points, before.curves[3].points, atol=1e-3)

    # the mesh rebuilt with one face less and no depsgraph update: the counts tell
    V, F = blender_io.object_to_arrays(s.blade)
    me.clear_geometry()
    me.from_pydata(V[:, :].tolist(), [], F[:-1].tolist())
    me.update()
    assert preview.has_mesh()  # the handler has not run
    res = addon.update_preview(scene, enabled=True)
    assert preview.mesh_loads == loads + 2 and res.error is None
    _assert_same_curves(res, _fresh_slice(scene))


def test_preview_is_throttled_while_dragging(addon, blade_scene):
    scene = blade_scene
    s = scene.blisk_cam
    first = addon.update_preview(scene, enabled=True)  # unthrottled: computes now
    assert first is not None and first.error is None
    assert addon._THROTTLE.interval >= addon.PREVIEW_INTERVAL
    addon._THROTTLE.interval = 60.0  # (a slow test machine must not end the interval)
    addon._THROTTLE.mark()
    s.cone1 = (150.5, -25.0, 165.0, 35.0)
    # within the interval: nothing now, a redraw of the views is scheduled for its end
    assert addon.update_preview(scene, throttled=True, enabled=True) is None
    assert bpy.app.timers.is_registered(addon._redraw_views)
    # while waiting, the drawn preview keeps the last curves of this blade
    _, sets = addon.scene_line_sets(scene, dragging=True, preview=True)
    assert len(sets) == 3 + len(addon.PREVIEW.levels)
    addon._THROTTLE.reset()
    res = addon.update_preview(scene, throttled=True, enabled=True)
    assert res is not None and res is not first


def test_preview_is_computed_for_handle_moves_not_on_every_redraw(addon, blade_scene):
    scene = blade_scene
    s = scene.blisk_cam
    n_levels = len(addon.PREVIEW.levels)
    # cones typed in (not a handle drag) and no cached curves: the draw does not slice
    _, sets = addon.scene_line_sets(scene, preview=True)
    assert len(sets) == 3 and addon.PREVIEW.result is None
    # a handle moved: the next redraw computes the preview (the trailing update of a drag)
    plane = addon.scene_plane(scene)
    assert addon.handle_set(scene, "Q2", plane.to_world(223.0, 35.0))  # 2 mm into the blade
    _, sets = addon.scene_line_sets(scene, preview=True)
    res = addon.PREVIEW.result
    assert res is not None and res.error is None
    assert {c.s for c in res.curves} == set(addon.PREVIEW.levels)  # s = 1 now cuts the tip
    assert len(sets) == 3 + n_levels
    # ... and later redraws draw the cached curves while they match the cones
    _, sets = addon.scene_line_sets(scene, preview=True)
    assert len(sets) == 3 + n_levels and addon.PREVIEW.result is res
    # the blade in edit mode: no preview (each edit would re-read the mesh)
    bpy.context.view_layer.objects.active = s.blade
    bpy.ops.object.mode_set(mode="EDIT")
    try:
        assert addon.update_preview(scene, enabled=True) is None
    finally:
        bpy.ops.object.mode_set(mode="OBJECT")


def test_preview_reports_a_blade_without_faces(addon, blade_scene):
    scene = blade_scene
    empty_mesh = bpy.data.meshes.new("Points")
    empty_mesh.from_pydata([(150.0, 0.0, 0.0), (160.0, 0.0, 10.0)], [], [])
    obj = bpy.data.objects.new("Points", empty_mesh)
    scene.collection.objects.link(obj)
    scene.blisk_cam.blade = obj
    res = addon.update_preview(scene, enabled=True)
    assert res.curves == [] and "no faces" in res.error


# --- drawing (Blender 5.x can initialise the GPU module in background mode) -----------------
GPU_DRAW_SCRIPT = r"""
import json, sys
import bpy, gpu
import numpy as np
from mathutils import Matrix
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.gizmos import cone_frame as cf
from blisk_cam.gizmos.cone_gizmos import build_line_batches, draw_line_batches

gpu.init()
N = 128
plane = cf.MeridionalPlane(Axis(), 0.0, 1.0)
cone = (40.0, -10.0, 50.0, 10.0)
lines = cf.cone_wire_lines(plane, cone, generatrices=8, circle_segments=64)
sets = [(lines, (1.0, 0.0, 0.0, 1.0), 2.0), (np.zeros((0, 3)), (0.0, 1.0, 0.0, 1.0), 2.0)]
batches = build_line_batches(sets)
off = gpu.types.GPUOffScreen(N, N)
with off.bind():
    fb = gpu.state.active_framebuffer_get()
    fb.clear(color=(0.0, 0.0, 0.0, 0.0))
    with gpu.matrix.push_pop():
        gpu.matrix.load_matrix(Matrix.Identity(4))
        # orthographic top view of x, y in [-64, 64] mm
        gpu.matrix.load_projection_matrix(Matrix.Diagonal((1 / 64, 1 / 64, -1 / 100, 1.0)))
        draw_line_batches(batches)
    buf = fb.read_color(0, 0, N, N, 4, 0, "FLOAT")
off.free()
buf.dimensions = N * N * 4
img = np.array(buf, dtype=np.float32).reshape(N, N, 4)
ys, xs = np.nonzero(img[..., 0] > 0.5)
rad = np.hypot(xs + 0.5 - N / 2, ys + 0.5 - N / 2)  # pixels = mm here
out = {"n": len(batches), "lit": int(len(xs)), "green": int((img[..., 1] > 0.5).sum())}
out["rmin"] = float(rad.min()) if len(xs) else -1.0
out["rmax"] = float(rad.max()) if len(xs) else -1.0
print(json.dumps(out))
"""


def test_line_batches_draw_the_cone_offscreen(tmp_path):
    """Build and draw a cone's line set with the gizmo's own functions into an offscreen
    buffer (top view): the lit pixels lie between the cone's two end circles (r 40 … 50 mm)."""
    import json
    import subprocess
    import sys

    import gpu

    from blisk_cam.blender import render

    if not hasattr(gpu, "init"):
        pytest.skip("gpu.init() (GPU drawing in background mode) needs Blender 5.x")
    if not render.gl_available():
        pytest.skip("no headless OpenGL (EGL) here")
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run(
        [sys.executable, "-c", GPU_DRAW_SCRIPT], cwd=root, capture_output=True, text=True,
        timeout=180, stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["n"] == 1 and out["green"] == 0  # the empty set makes no batch
    assert out["lit"] > 300  # two circles of ~250 and ~310 px circumference plus 8 generatrices
    assert 40.0 - 2.0 <= out["rmin"] and out["rmax"] <= 50.0 + 2.0
