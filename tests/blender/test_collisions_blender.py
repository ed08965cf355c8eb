"""blisk_cam.check_collisions, the Collisions panel's view and blisk_cam.next_unresolved_pose:
the stored paths are checked against the blade's neighbours with a large holder, the poses
are coloured by status (point attribute = the stored JSON), the summary, the tool assembly
at the worst pose and the neighbours are written, everything survives save and reload, bad
input is refused with a clear message."""

import json

import bpy
import numpy as np
import pytest
from _layout import drawn
from _scenes import radial_demo_paths

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import path_objects as output
from blisk_cam.blender.collision_objects import collision_summary

HOLDER = "36 6 60 6 60 16 120 16"


def _setup(demo, tmp_path, *, generate=True):
    blade, s = radial_demo_paths(demo, tmp_path, generate=generate)
    s.blade_count, s.holder = 24, HOLDER
    return blade, s


def _drawn_panel():
    from blisk_cam.panels.collisions import BLISKCAM_PT_collisions

    return drawn(BLISKCAM_PT_collisions)


def _stored(blade):
    return json.loads(output.stored_paths_json(blade.name))


def _pose_attribute(blade, name="collision_status"):
    pc = output.output_objects(output.find_output_collection(blade.name))["poses"]
    attr = pc.data.attributes.get(name)
    if attr is None:
        return None
    vals = np.zeros(len(pc.data.vertices), dtype=np.int32)
    attr.data.foreach_get("value", vals)
    return vals


def _json_statuses(data):
    return np.concatenate([c["collision"]["status"] for c in data["curves"]])


def test_check_collisions_colours_writes_and_survives_reload(addon, demo, tmp_path):
    blade, s = _setup(demo, tmp_path)
    before = _stored(blade)
    assert "collision" not in before and _pose_attribute(blade) is None
    from blisk_cam.core.collision.options import CollisionOptions
    from blisk_cam.core.options import fields

    drawn = _drawn_panel()  # every declared option, the holder, obstacles and the button
    declared = [spec.prop_name(n) for n, spec, _ in fields(CollisionOptions) if spec.blender]
    assert [x for x in drawn if x in declared] == declared
    assert {"holder", "obstacles", "blisk_cam.check_collisions"} <= set(drawn)
    assert "blisk_cam.next_unresolved_pose" not in drawn
    s.mode = "OFF"  # the button checks even when the mode is off
    assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}
    data = _stored(blade)
    summary = data["collision"]
    drawn = _drawn_panel()  # the counts and the worst clearance of the stored summary
    assert f"label: Unresolved: {summary['unresolved']}" in drawn
    assert f"label: Colliding before: {summary['colliding_before']}" in drawn
    assert any(x.startswith(f"label: Worst clearance: {summary['min_clearance']:.3f} mm")
               for x in drawn)
    assert "blisk_cam.next_unresolved_pose" in drawn
    assert summary["mode"] == "check"
    assert summary["checked_poses"] == len(data["program"]["tip"])
    status = _json_statuses(data)
    assert len(status) == sum(len(c["tip"]) for c in data["curves"])
    # the large holder reaches the neighbour blade: some poses collide (check: unresolved)
    assert summary["unresolved"] > 0 and np.any(status == 2)
    assert summary["colliding_before"] == summary["unresolved"]
    assert summary["obstacles"]["blade_count"] == 24
    assert summary["assembly"]["profile"][-1] == [120.0, 16.0]
    # the point cloud's attribute is the stored status per pose
    assert np.array_equal(_pose_attribute(blade), status)
    objs = output.output_objects(output.find_output_collection(blade.name))
    pc = objs["poses"]
    assert not pc.hide_render  # the status colours render
    # the evaluated cloud: one point cloud per status with its material
    dg = bpy.context.evaluated_depsgraph_get()
    mats = {}
    for inst in dg.object_instances:
        if inst.is_instance and inst.parent is not None and inst.parent.name == pc.name \
                and inst.object.type == "POINTCLOUD":
            pts = inst.object.data
            mats[pts.materials[0].name] = len(pts.points)
    assert mats.get("Blisk CAM collision unresolved") == int(np.sum(status == 2))
    assert mats.get("Blisk CAM collision clear") == int(np.sum(status == 0))
    # pose empties carry the status colour
    for ob in objs["pose_empties"]:
        k = ob["blisk_cam_pose_index"]
        assert ob[output.KEY_STATUS] == status[k]
        assert tuple(ob.color) == pytest.approx(output.STATUS_RGBA[status[k]], abs=1e-6)
    # the neighbours (±1, ±2 by default) are in the output collection, greyed
    names = sorted(ob.name for ob in objs["neighbours"])
    assert names == sorted(f"{blade.name} neighbour {t}" for t in ("+1", "-1", "+2", "-2"))
    V0, _ = blender_io.object_to_arrays(blade)
    V1, _ = blender_io.object_to_arrays(bpy.data.objects[f"{blade.name} neighbour +1"])
    r0, r1 = np.hypot(V0[:, 0], V0[:, 1]), np.hypot(V1[:, 0], V1[:, 1])
    assert np.allclose(r0, r1, atol=1e-3) and np.allclose(V0[:, 2], V1[:, 2], atol=1e-3)
    turn = np.angle(np.mean(np.exp(1j * (np.arctan2(V1[:, 1], V1[:, 0])
                                         - np.arctan2(V0[:, 1], V0[:, 0])))))
    assert abs(turn - 2 * np.pi / 24) < 1e-5
    # the tool assembly at the worst pose: tip vertex at the stored tip, Z = the axis
    asm = objs["tool_assembly"]
    clr = np.array([np.inf if c is None else c for c in data["program"]["clearance"]])
    row = int(np.argmin(clr))
    tip = np.array(data["program"]["tip"][row])
    axis = np.array(data["program"]["axis"][row])
    assert asm["blisk_cam_row"] == row
    assert np.allclose(asm["blisk_cam_tip_mm"], tip, atol=1e-6, rtol=0)
    assert asm["blisk_cam_clearance_mm"] == pytest.approx(summary["min_clearance"], abs=1e-9)
    M = np.array(asm.matrix_world)
    co = np.zeros(len(asm.data.vertices) * 3, dtype=np.float32)
    asm.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3).astype(np.float64) @ M[:3, :3].T + M[:3, 3]
    d = np.linalg.norm(co - tip, axis=1)
    # float32 storage (coordinates ≈ 190 mm): half an ulp ≈ 8e-6 mm per coordinate
    assert d.min() < 2e-5
    assert np.allclose(M[:3, 2] / np.linalg.norm(M[:3, 2]), axis, atol=1e-6)
    top = co[np.argmax(co @ axis)]
    assert (top - tip) @ axis == pytest.approx(120.0, abs=1e-3)
    # save, reload: attribute, JSON and objects still there
    blade_name = blade.name
    blend = tmp_path / "checked.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    blade = bpy.data.objects[blade_name]
    assert _stored(blade)["collision"] == summary
    assert np.array_equal(_pose_attribute(blade), status)
    assert collision_summary(blade.name)["unresolved"] == summary["unresolved"]
    objs = output.output_objects(output.find_output_collection(blade.name))
    assert objs["tool_assembly"] is not None and len(objs["neighbours"]) == 4
    # next unresolved pose: the cursor goes to an unresolved pose's tip, then the next one
    un = [r for r, st in enumerate(data["program"]["collision_status"]) if st == 2]
    tips = np.array(data["program"]["tip"])[un]
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.0)
    seen = []
    for _ in range(3):
        assert bpy.ops.blisk_cam.next_unresolved_pose() == {"FINISHED"}
        c = np.array(bpy.context.scene.cursor.location)
        d = np.linalg.norm(tips - c, axis=1)
        assert d.min() < 1e-4  # float32 cursor
        seen.append(int(np.argmin(d)))
    distinct = {tuple(np.round(t, 6)) for t in tips}
    assert seen[0] == 0
    if len(distinct) > 1:
        assert seen[1] != seen[0]


def test_face_selection_makes_the_rest_an_obstacle(addon, demo, tmp_path):
    """A whole-blisk mesh (hub strip + blade) with the blade's faces selected: the selection
    is the blade, the rest of the same mesh an extra obstacle; the user's mesh is not
    changed. Mode avoid is written as such."""
    blade, s = _setup(demo, tmp_path)
    s.mode = "AVOID"
    V, F = demo.combined([0])  # the hub strip first, then blade 0
    n_hub, n_blade = len(demo.hub_faces), len(demo.blade_faces)
    assert len(F) == n_hub + n_blade
    tmp = blender_io.arrays_to_object("whole", V, F)
    old = blade.data
    blade.data = tmp.data  # the blade object is now the whole blisk (same name: same paths)
    bpy.data.objects.remove(tmp)
    bpy.data.meshes.remove(old)
    me = blade.data
    sel = np.arange(len(F)) >= n_hub
    me.polygons.foreach_set("select", sel)
    co_before = np.zeros(len(me.vertices) * 3, dtype=np.float32)
    me.vertices.foreach_get("co", co_before)
    assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}
    summary = _stored(blade)["collision"]
    assert summary["mode"] == "avoid"
    obs = dict(zip(summary["obstacles"]["names"], summary["obstacles"]["triangles"],
                   strict=True))
    assert obs["blade"] == n_blade
    assert obs[f"{blade.name} (unselected faces)"] == n_hub
    co_after = np.zeros_like(co_before)
    me.vertices.foreach_get("co", co_after)
    sel_after = np.zeros(len(F), dtype=bool)
    me.polygons.foreach_get("select", sel_after)
    assert np.array_equal(co_before, co_after) and np.array_equal(sel, sel_after)
    assert len(me.polygons) == len(F)
    # faces interleaved with the blade's share its vertices: refused with the way out
    me.polygons.foreach_set("select", np.arange(len(F)) % 50 != 0)
    with pytest.raises(RuntimeError, match="select only the blade faces"):
        bpy.ops.blisk_cam.check_collisions()


def test_bad_input_is_refused_clearly(addon, demo, tmp_path):
    blade, s = _setup(demo, tmp_path, generate=False)
    with pytest.raises(RuntimeError, match="press Generate Paths first"):
        bpy.ops.blisk_cam.check_collisions()
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    s.blade_count = 0
    with pytest.raises(RuntimeError, match="set the Blade Count"):
        bpy.ops.blisk_cam.check_collisions()
    s.blade_count, s.holder = 24, "36 6 60"
    with pytest.raises(RuntimeError, match="Holder"):
        bpy.ops.blisk_cam.check_collisions()
    assert "collision" not in _stored(blade)  # nothing was written
    assert not bpy.ops.blisk_cam.next_unresolved_pose.poll()
    # the meshes of the Obstacles collection are extra obstacles (the blade itself is not)
    coll = bpy.data.collections.new("Fixture")
    bpy.context.scene.collection.children.link(coll)
    blender_io.arrays_to_object("hub", demo.hub_vertices, demo.hub_faces, coll)
    coll.objects.link(blade)
    s.obstacles, s.holder = coll, HOLDER
    assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}
    obs = _stored(blade)["collision"]["obstacles"]
    assert obs["names"][-1] == "hub" and obs["triangles"][-1] == len(demo.hub_faces)
    assert len(obs["names"]) == 1 + 4 + 1  # blade, ±1, ±2, hub: not the blade object again


def test_modal_check_steps_esc_keeps_and_finishes_like_exec(addon, demo, tmp_path):
    """Check Collisions through the shared modal machinery (``ModalJobOperator``), stepped
    by hand: a second run is refused while one goes, ESC keeps the previous result, ticking
    to the end writes what the synchronous operator writes."""
    from blisk_cam.operators import check_collisions as cc_mod
    from blisk_cam.operators.modal_job import ModalRunner

    blade, s = _setup(demo, tmp_path)
    before = output.stored_paths_json(blade.name)
    op = ModalRunner(cc_mod.BLISKCAM_OT_check_collisions, cc_mod.CollisionJob(bpy.context))
    op.start(bpy.context)
    assert bpy.context.scene.name in cc_mod._RUNNING
    assert not bpy.ops.blisk_cam.check_collisions.poll()
    assert op.step(bpy.context, "MOUSEMOVE") == {"PASS_THROUGH"}
    assert op.step(bpy.context, "ESC") == {"CANCELLED"}
    assert op.reports[-1][0] == {"WARNING"} and "previous result is kept" in op.reports[-1][1]
    assert output.stored_paths_json(blade.name) == before and not cc_mod._RUNNING

    op = ModalRunner(cc_mod.BLISKCAM_OT_check_collisions, cc_mod.CollisionJob(bpy.context))
    op.start(bpy.context)
    fractions, result = [], {"RUNNING_MODAL"}
    for _ in range(1000):
        result = op.step(bpy.context)
        fractions.append(op._job.fraction)
        if result != {"RUNNING_MODAL"}:
            break
    assert result == {"FINISHED"}, op.reports
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and not cc_mod._RUNNING
    assert op.reports[-1][0] == {"INFO"} and "poses checked" in op.reports[-1][1]
    modal = _stored(blade)
    output.write_path_objects(bpy.context.scene, blade, _from_json(before))
    assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}  # the same check, EXEC
    assert _stored(blade)["collision"] == modal["collision"]
    np.testing.assert_array_equal(_json_statuses(_stored(blade)), _json_statuses(modal))


def _from_json(text):
    from blisk_cam.core.toolpath.paths_io import path_from_dict

    return path_from_dict(json.loads(text))
