"""The Blender workflow through the operators (issue #5): fit cones, generate, export, the output
objects, save/reload, bad input, cancel, verify colour map, preview — and that the batch CLI
runs the very same operators (its JSON equals the in-process one).

Plumbing tests: a small demo blade (resolution 0.3, 9k triangles) and coarse tolerances
(cusp = chord = 0.3 mm) so that a generation takes about a second.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from blisk_cam.blender import demo_scene, render
from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import path_objects as output
from blisk_cam.cli import main as cli
from blisk_cam.cli import paths as cli_paths
from blisk_cam.core.geometry.distance import closest_points
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.runtime import Cancelled
from blisk_cam.operators import generate_paths as gen_mod
from blisk_cam.operators.common import blade_problem, cones_problem
from blisk_cam.operators.modal_job import ModalRunner
from tests.support.mesh_files import write_binary_stl

REPO = Path(__file__).resolve().parents[2]
CUSP = CHORD = 0.3  # mm: coarse, the tests are about plumbing
POSE_CAP = 40


def _new_scene():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def _blade_scene(demo, **settings):
    """A factory scene with the demo blade only (1 BU = 1 mm), settings for a quick run."""
    scene = _new_scene()
    blade = blender_io.arrays_to_object(
        "Blade", demo.blade_vertices, demo.blade_faces, color=(0.85, 0.62, 0.3, 1.0)
    )
    s = scene.blisk_cam
    s.blade = blade
    s.cone1, s.cone2 = demo.hub_cone.as_list(), demo.tip_cone.as_list()
    s.cusp, s.chord, s.verify, s.pose_count = CUSP, CHORD, False, POSE_CAP
    for k, v in settings.items():
        setattr(s, k, v)
    return scene, blade


def _poll_error(op):
    """The message of a failed poll (the text after '.poll()')."""
    with pytest.raises(RuntimeError) as info:
        op()
    msg = str(info.value)
    assert ".poll()" in msg, msg
    return msg.split(".poll()", 1)[1].strip()


def _mesh_data(ob):
    co = np.empty(len(ob.data.vertices) * 3)
    ob.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def _attr(mesh, name, width):
    a = mesh.attributes[name]
    field = {"FLOAT_VECTOR": "vector"}.get(a.data_type, "value")
    out = np.empty(len(a.data) * width, dtype=np.float64)
    a.data.foreach_get(field, out)
    return out.reshape(-1, width) if width > 1 else out


def _json_poses(d, key):
    return np.concatenate([np.asarray(c[key], dtype=np.float64) for c in d["curves"]])


def _measure_outputs(blade_name):
    """What the output collection holds, in mm, read back from the Blender objects."""
    coll = output.find_output_collection(blade_name)
    assert coll is not None and coll.name == f"Blisk CAM – {blade_name}"
    objs = output.output_objects(coll)
    pc = objs["poses"]
    empties = sorted(objs["pose_empties"], key=lambda o: o["blisk_cam_pose_index"])
    return {
        "collection": coll.name,
        "cc": output.curve_points_mm(objs["cc"]),
        "tip": output.curve_points_mm(objs["tip"]),
        "cyclic": [sp.use_cyclic_u for sp in objs["cc"].data.splines],
        "pc_co": _mesh_data(pc),
        "pc_axis": _attr(pc.data, "axis", 3),
        "pc_pass": _attr(pc.data, "pass", 1),
        "pc_s": _attr(pc.data, "s", 1),
        "pc_move": _attr(pc.data, "move", 1),
        "pc_status": _attr(pc.data, "status", 1),
        "links": output.curve_points_mm(objs["links"]) if objs["links"] else None,
        "empty_index": np.array([o["blisk_cam_pose_index"] for o in empties]),
        "empty_loc": np.array([tuple(o.matrix_world.translation) for o in empties]),
        "empty_z": np.array([tuple(o.matrix_world.col[2][:3]) for o in empties]),
        "empty_type": {o.empty_display_type for o in empties},
        "points_modifier": [m.type for m in pc.modifiers],
    }


def _check_outputs_match_json(m, d, pose_cap):
    curves = d["curves"]
    assert len(m["cc"]) == len(curves) == len(m["tip"])
    for got_cc, got_tip, c in zip(m["cc"], m["tip"], curves, strict=True):
        # float32 object coordinates at r ≈ 200 mm: ≈ 1e-5 mm
        np.testing.assert_allclose(got_cc, np.asarray(c["cc"]), atol=1e-3, rtol=0)
        np.testing.assert_allclose(got_tip, np.asarray(c["tip"]), atol=1e-3, rtol=0)
    assert m["cyclic"] == [bool(c["closed"]) and len(c["cc"]) > 2 for c in curves]
    tips, axes = _json_poses(d, "tip"), _json_poses(d, "axis")
    n = len(tips)
    # the point cloud holds every pose, in order, with its axis and pass
    np.testing.assert_allclose(m["pc_co"], tips, atol=1e-3, rtol=0)
    np.testing.assert_allclose(m["pc_axis"], axes, atol=1e-6, rtol=0)
    s = np.concatenate([[c["s"]] * len(c["tip"]) for c in curves])
    np.testing.assert_allclose(m["pc_s"], s, atol=1e-6)
    levels = np.unique([c["s"] for c in curves])
    np.testing.assert_array_equal(m["pc_pass"], np.searchsorted(levels, s))
    # move types and flags per pose (the JSON's names → the attribute's codes)
    moves = [x for c in curves for x in c.get("move", ["cut"] * len(c["tip"]))]
    np.testing.assert_array_equal(m["pc_move"], [output.MOVE_TYPES.index(x) for x in moves])
    flags = [x for c in curves for x in c.get("flags", [0] * len(c["tip"]))]
    np.testing.assert_array_equal(m["pc_status"], flags)
    # the linking moves of the program: a spline per run of non-cut moves, from the pose before
    if "program" in d:
        prog_tip = np.asarray(d["program"]["tip"], dtype=np.float64)
        move = np.array(d["program"]["move"])
        cut = move == "cut"
        starts = [j for j in range(len(move)) if not cut[j] and (j == 0 or move[j - 1] != move[j])]
        assert m["links"] is not None and len(m["links"]) == len(starts)
        for pts, a in zip(m["links"], starts, strict=True):
            np.testing.assert_allclose(pts, prog_tip[max(a - 1, 0):max(a - 1, 0) + len(pts)],
                                       atol=1e-3, rtol=0)
            assert not np.any(cut[a:a + len(pts) - (1 if a else 0)])
    # pose empties: at most the cap, spread over the whole path, at the tips along the axes
    k = len(m["empty_index"])
    assert k == min(pose_cap, n) and 0 < k <= pose_cap < n
    assert m["empty_index"][0] == 0 and m["empty_index"][-1] == n - 1
    assert np.all(np.diff(m["empty_index"]) > 0)
    np.testing.assert_allclose(m["empty_loc"], tips[m["empty_index"]], atol=1e-3, rtol=0)
    np.testing.assert_allclose(m["empty_z"], axes[m["empty_index"]], atol=1e-5, rtol=0)
    assert m["empty_type"] == {"SINGLE_ARROW"}


@pytest.fixture(scope="module")
def generated(addon, demo, tmp_path_factory):
    """The demo .blend → fit cones → generate → export, all by the operators; the objects'
    contents measured, the result saved as a .blend. Built once for the module."""
    tmp = tmp_path_factory.mktemp("ops")
    _new_scene()
    demo_scene.build_demo_scene(bpy.context.scene, blades=1, demo=demo)
    demo_blend = tmp / "demo.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(demo_blend))

    # the user's workflow: open the demo, fit, generate, export
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.wm.open_mainfile(filepath=str(demo_blend))
    s = bpy.context.scene.blisk_cam
    assert s.blade is not None and s.blade.name == "Blade"
    blade = s.blade
    blade_before = _mesh_data(blade).copy()
    s.cone1 = s.cone2 = (0.0, 0.0, 0.0, 0.0)
    assert "Cone 1 and 2 not set" in _poll_error(bpy.ops.blisk_cam.generate_paths)
    assert bpy.ops.blisk_cam.fit_cones() == {"FINISHED"}
    fitted = (tuple(s.cone1), tuple(s.cone2), s.fit_residual1, s.fit_residual2)
    s.cusp, s.chord, s.verify, s.pose_count = CUSP, CHORD, False, POSE_CAP
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    out_json = tmp / "paths.json"
    assert bpy.ops.blisk_cam.export_paths(filepath=str(out_json)) == {"FINISHED"}
    measured = _measure_outputs("Blade")
    stats = {k: getattr(s, k) for k in ("stat_curves", "stat_passes", "stat_poses",
                                         "stat_length", "stat_blade", "has_result")}
    V, F = blender_io.object_to_arrays(blade)
    saved = tmp / "generated.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved))
    return {
        "tmp": tmp, "json": out_json, "blend": saved, "measured": measured, "stats": stats,
        "fitted": fitted, "blade_before": blade_before, "blade_after": _mesh_data(blade),
        "V": V, "F": F,
    }


def test_fit_generate_export_on_the_demo_blend(generated, demo):
    d = json.loads(generated["json"].read_text())
    assert d["format"] == "blisk_cam.paths" and d["units"] == "mm"
    # fitted cones: the generatrix lines of the true hub and tip cones (the fit extends them)
    (c1, c2, res1, res2) = generated["fitted"]
    for fitted, true in ((c1, demo.hub_cone), (c2, demo.tip_cone)):
        p, q = np.array(fitted[:2]), np.array(fitted[2:])
        u = (q - p) / np.linalg.norm(q - p)
        for pt in (true.p1, true.p2):
            w = np.asarray(pt) - p
            assert abs(w[0] * u[1] - w[1] * u[0]) < 1e-3  # meridional distance, mm
    assert 0.0 <= res1 < 1e-3 and 0.0 <= res2 < 1e-3
    assert d["cone1"] == pytest.approx(list(c1), abs=1e-4)
    assert d["tolerances"] == {"cusp": CUSP, "chord": CHORD}  # float32 props → typed decimals
    assert d["tool"]["radius"] == 6.0

    m = generated["measured"]
    _check_outputs_match_json(m, d, POSE_CAP)
    assert "NODES" in m["points_modifier"]  # the cloud is shown as points
    # CC points lie on the blade (measured on the mesh, not taken from the generator)
    mesh = TriMesh.from_arrays(generated["V"], generated["F"])
    cc = _json_poses(d, "cc")
    assert float(closest_points(mesh, cc).distance.max()) < 1e-4
    # statistics agree with the JSON
    st = generated["stats"]
    tips = [np.asarray(c["tip"]) for c in d["curves"]]
    length = sum(
        float(np.linalg.norm(np.diff(np.vstack([t, t[:1]]) if c["closed"] else t, axis=0),
                             axis=1).sum())
        for t, c in zip(tips, d["curves"], strict=True)
    )
    assert st["stat_poses"] == sum(len(t) for t in tips)
    assert st["stat_curves"] == len(d["curves"])
    assert st["stat_length"] == pytest.approx(length, rel=1e-5)
    assert st["has_result"] and st["stat_blade"] == "Blade"
    # the user's blade object is not modified
    np.testing.assert_array_equal(generated["blade_before"], generated["blade_after"])


def test_save_and_reload_keeps_settings_outputs_and_export(generated, addon, tmp_path):
    bpy.ops.wm.open_mainfile(filepath=str(generated["blend"]))
    s = bpy.context.scene.blisk_cam
    assert s.blade.name == "Blade" and s.axis_object.name == "Blisk Axis"
    assert tuple(s.cone1) == pytest.approx(generated["fitted"][0])
    assert s.cusp == pytest.approx(CUSP) and s.pose_count == POSE_CAP and not s.verify
    for k, v in generated["stats"].items():
        assert getattr(s, k) == (pytest.approx(v) if isinstance(v, float) else v), k
    again = _measure_outputs("Blade")
    d = json.loads(generated["json"].read_text())
    _check_outputs_match_json(again, d, POSE_CAP)
    # export works after the reload and writes the same file, byte for byte
    out = tmp_path / "again.json"
    assert bpy.ops.blisk_cam.export_paths(filepath=str(out)) == {"FINISHED"}
    assert out.read_bytes() == generated["json"].read_bytes()
    # clear removes the collection and the stored JSON; export is then disabled
    assert bpy.ops.blisk_cam.clear_paths() == {"FINISHED"}
    assert output.find_output_collection("Blade") is None
    assert not [t for t in bpy.data.texts if t.name.startswith("Blisk CAM")]
    assert "No generated paths" in _poll_error(bpy.ops.blisk_cam.export_paths)
    assert bpy.data.objects.get("Blade") is not None and not s.has_result


def test_cli_runs_the_same_operators(addon, demo, tmp_path):
    """python -m blisk_cam paths writes the JSON the operators write for the same inputs,
    and its --blend holds the objects, its --preview shows the paths."""
    stl = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    # the inputs by hand in this process, as a user sets them in the panels
    _new_scene()
    blade = blender_io.import_mesh_file(stl)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.tool_type, s.tool_radius, s.cusp, s.chord = "BALL", 6.0, CUSP, CHORD
    s.lead = s.tilt = 0.0
    s.verify = False
    assert bpy.ops.blisk_cam.fit_cones() == {"FINISHED"}
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    mine = tmp_path / "mine.json"
    assert bpy.ops.blisk_cam.export_paths(filepath=str(mine)) == {"FINISHED"}
    # the CLI with the cones the panel holds (float32 properties: their decimals), so both
    # routes start from the same numbers
    cones = [[str(np.float32(x)) for x in getattr(s, f"cone{k}")] for k in (1, 2)]
    out, blend, png = tmp_path / "cli.json", tmp_path / "cli.blend", tmp_path / "cli.png"
    cmd = [sys.executable, "-m", "blisk_cam", "paths", "--mesh", str(stl), "--tool", "ball",
           "--tool-radius", "6", "--cusp", str(CUSP), "--chord", str(CHORD),
           "--cone1", *cones[0], "--cone2", *cones[1],
           "--out", str(out), "--blend", str(blend), "--preview", str(png),
           "--quiet"]  # no progress lines: stderr stays empty (issue 28 row 13)
    env = {k: v for k, v in os.environ.items() if k not in ("BLISK_CAM_VERBOSE",)}
    proc = subprocess.run(["timeout", "--kill-after=10", "240", *cmd], cwd=REPO, env=env,
                          capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=270)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert str(out) in proc.stdout
    a, b = json.loads(out.read_text()), json.loads(mine.read_text())
    a.pop("stats"), b.pop("stats")  # timings differ
    assert a == b
    name = blade.name

    # the CLI's .blend: settings and objects; its preview is not blank and shows the paths
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    assert bpy.context.scene.blisk_cam.stat_poses == sum(len(c["tip"]) for c in a["curves"])
    m = _measure_outputs(name)
    assert len(m["cc"]) == len(a["curves"])
    assert render.image_coverage(png) > 0.05
    assert _path_pixel_fraction(png) > 0.002


def _path_pixel_fraction(png):
    """Fraction of pixels in the colours of the path curves (solid cyan, or the blue/cyan/
    green end of the MORPH ramp), where green or blue clearly beats red; the blade is gold,
    the background dark grey."""
    img = bpy.data.images.load(str(png), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * img.channels, dtype=np.float32)
        img.pixels.foreach_get(px)
        c = px.reshape(-1, img.channels)[:, :3]
    finally:
        bpy.data.images.remove(img)
    r, g, b = c[:, 0], c[:, 1], c[:, 2]
    return float(np.mean(np.maximum(g, b) > r + 0.25))


def test_preview_shows_the_paths(addon, demo, tmp_path):
    scene, blade = _blade_scene(demo, color_mode="SOLID", cusp=0.5, chord=0.5)
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    bevel = output.output_objects(output.find_output_collection("Blade"))["cc"].data.bevel_depth
    with_paths = tmp_path / "with.png"
    assert bpy.ops.blisk_cam.render_preview(
        filepath=str(with_paths), resolution=(480, 270)) == {"FINISHED"}
    assert render.image_coverage(with_paths) > 0.05  # not blank
    # the bevel was thickened for the render only
    cc = output.output_objects(output.find_output_collection("Blade"))["cc"]
    assert cc.data.bevel_depth == pytest.approx(bevel)
    assert bpy.ops.blisk_cam.clear_paths() == {"FINISHED"}
    without = tmp_path / "without.png"
    assert bpy.ops.blisk_cam.render_preview(
        filepath=str(without), resolution=(480, 270)) == {"FINISHED"}
    # the solid path colour (cyan) is in the picture with the paths, not without them
    f_with = _path_pixel_fraction(with_paths)
    f_without = _path_pixel_fraction(without)
    assert f_with > 0.005 and f_without < 0.1 * f_with, (f_with, f_without)
    assert scene.camera is None  # the preview camera was not left behind


def test_regenerate_replaces_only_its_collection_and_cancel_keeps_it(addon, demo):
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, pose_count=10)
    other = bpy.data.objects.new("User Empty", None)
    scene.collection.objects.link(other)
    user_coll = bpy.data.collections.new("User Stuff")
    scene.collection.children.link(user_coll)
    before = _mesh_data(blade).copy()

    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    first = _measure_outputs("Blade")
    first_json = output.stored_paths_json("Blade")
    assert len(first["empty_index"]) == 10

    # a started and abandoned run (ESC in the modal) leaves the previous result alone
    scene.blisk_cam.pose_count = 25
    scene.blisk_cam.cusp = 0.35
    job = gen_mod.PathJob(bpy.context)
    fractions = []
    for _ in range(3):
        if job.step(0.0):
            break
        fractions.append(job.fraction)
    assert fractions and all(0.0 <= f <= 1.0 for f in fractions)
    assert fractions == sorted(fractions)
    del job
    kept = _measure_outputs("Blade")
    assert len(kept["empty_index"]) == 10 and output.stored_paths_json("Blade") == first_json
    assert len(kept["cc"]) == len(first["cc"])

    # regenerate: the collection is replaced, not duplicated; nothing else is touched
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    second = _measure_outputs("Blade")
    assert len(second["empty_index"]) == 25
    assert output.stored_paths_json("Blade") != first_json
    colls = [c.name for c in bpy.data.collections if c.name.startswith("Blisk CAM")]
    assert sorted(colls) == ["Blisk CAM – Blade", "Blisk CAM – Blade poses"]
    names = {o.name for o in bpy.data.objects}
    assert {"Blade", "User Empty", "Blade CC paths", "Blade tool tips", "Blade poses"} <= names
    assert not [n for n in names if n.endswith(".001")]
    assert bpy.data.collections.get("User Stuff") is not None
    np.testing.assert_array_equal(_mesh_data(blade), before)
    assert len(blade.modifiers) == 0 and blade.data.materials[0].name == "Blisk CAM Blade"

    # display options re-style the existing curves: bevel and colour bins
    cc = output.output_objects(output.find_output_collection("Blade"))["cc"]
    scene.blisk_cam.curve_bevel = 0.75
    assert cc.data.bevel_depth == pytest.approx(0.75)
    scene.blisk_cam.color_mode = "MORPH"
    idx = np.array([sp.material_index for sp in cc.data.splines])
    s = np.array(cc.data[output.KEY_S])
    assert idx[np.argmin(s)] == 0 and idx[np.argmax(s)] == output.COLOR_BINS - 1
    assert np.all(np.diff(idx[np.argsort(s)]) >= 0)
    scene.blisk_cam.color_mode = "SOLID"
    assert len(cc.data.materials) == 1


def test_bad_input_is_disabled_with_a_reason_or_reported(addon, demo, tmp_path):
    scene = _new_scene()
    gen, fit = bpy.ops.blisk_cam.generate_paths, bpy.ops.blisk_cam.fit_cones
    # no blade, no active object
    assert "No blade" in _poll_error(gen) and "No blade" in _poll_error(fit)
    assert "No generated paths" in _poll_error(bpy.ops.blisk_cam.clear_paths)
    # a non-mesh active object
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    scene.collection.objects.link(cam)
    bpy.context.view_layer.objects.active = cam
    assert "'Cam' is a camera object, not a mesh" in _poll_error(fit)
    # a mesh without faces (set as the blade from Python, past the UI filter)
    verts = blender_io.arrays_to_object("Points", np.eye(3) * 10.0, np.zeros((0, 3), int))
    scene.blisk_cam.blade = verts
    assert "'Points' has no faces" in _poll_error(gen)
    # a closed mesh has no boundary loops to fit cones to: an error report, no traceback
    cube = blender_io.arrays_to_object(
        "Cube", np.array([[x, y, z] for x in (0, 10) for y in (0, 10) for z in (0, 10)], float),
        np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]]),
    )
    scene.blisk_cam.blade = cube
    with pytest.raises(RuntimeError, match="boundary loop"):
        fit()
    assert tuple(scene.blisk_cam.cone1) == (0.0, 0.0, 0.0, 0.0)

    # the demo blade with a first result
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5)
    assert gen() == {"FINISHED"}
    first = output.stored_paths_json("Blade")
    s = scene.blisk_cam
    # crossing cones: disabled with the reason
    s.cone2 = (165.0, -25.0, 150.0, 35.0)
    assert "cross" in _poll_error(gen)
    assert "cross" in cones_problem(s)
    # a cone with a negative radius
    s.cone2 = (-1.0, -25.0, 150.0, 35.0)
    assert "Cone 2" in _poll_error(gen)
    # cones that do not cut the blade: an error report, the previous result kept
    s.cone1, s.cone2 = (400.0, -25.0, 410.0, 35.0), (450.0, -25.0, 460.0, 35.0)
    assert gen.poll()
    with pytest.raises(RuntimeError, match="(does not cut|miss)"):
        gen()
    assert output.stored_paths_json("Blade") == first
    assert len([c for c in bpy.data.collections if c.name.startswith("Blisk CAM")]) == 2
    # export to a missing directory: an error naming it
    with pytest.raises(RuntimeError, match="does not exist"):
        bpy.ops.blisk_cam.export_paths(filepath=str(tmp_path / "nope" / "p.json"))
    assert blade_problem(bpy.context) is None
    # every operator that changes the scene is undoable in one step
    from blisk_cam.operators import CLASSES

    changing = {c.bl_idname for c in CLASSES} - {"blisk_cam.export_paths",
                                                  "blisk_cam.export_nc",
                                                  "blisk_cam.export_robot",
                                                  "blisk_cam.export_job"}  # files only
    assert changing == {f"blisk_cam.{n}" for n in
                        ("fit_cones", "generate_paths", "clear_paths", "render_preview",
                         "set_scene_mm", "check_collisions", "next_unresolved_pose",
                         "animate_program", "per_blade_paths", "load_blade_results",
                         "show_robot", "simulate_stock", "operation_add",
                         "operation_remove", "operation_move", "tool_add", "tool_remove",
                         "generate_all")}
    for cls in CLASSES:
        if cls.bl_idname in changing:
            assert {"REGISTER", "UNDO"} <= set(cls.bl_options), cls.bl_idname


def test_verify_colour_map_on_a_copy(addon, demo):
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, verify=True, verify_map=True)
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    s = scene.blisk_cam
    assert s.stat_verified and s.stat_material_left > 0.0 and s.stat_gouge >= 0.0
    ob = output.output_objects(output.find_output_collection("Blade"))["verify"]
    assert ob is not None and ob is not blade and ob.data is not blade.data
    V = _mesh_data(ob)
    np.testing.assert_allclose(V, _mesh_data(blade), atol=1e-4)  # a copy of the blade
    left = _attr(ob.data, "material_left", 1)
    inside = np.isfinite(left)
    assert 0.5 < inside.mean() <= 1.0  # the region between the cones is most of the blade
    # vertex values are material left at vertices: ≤ the measured maximum, ≥ −max gouge
    assert np.nanmax(left) <= s.stat_material_left + 1e-6
    assert np.nanmin(left) >= -s.stat_gouge - 1e-6
    col = ob.data.color_attributes["verify"]
    rgba = np.empty(len(col.data) * 4, dtype=np.float32)
    col.data.foreach_get("color", rgba)
    expect = output.verify_colors(left, 0.5, 0.5)
    np.testing.assert_allclose(rgba.reshape(-1, 4), expect, atol=1e-5)
    assert np.all(rgba.reshape(-1, 4)[~inside, :3] == pytest.approx(0.5))  # grey outside
    # colour by measured cusp: every spline carries the cusp measured next to its pass
    cc = output.output_objects(output.find_output_collection("Blade"))["cc"]
    s.color_mode = "CUSP"
    cusp = np.array(cc.data[output.KEY_SPLINE_CUSP])
    assert np.all(np.isfinite(cusp)) and np.all(cusp > 0.0)
    assert cusp.max() <= s.stat_material_left + 1e-6
    idx = np.array([sp.material_index for sp in cc.data.splines])
    np.testing.assert_array_equal(
        idx, output.spline_bins("CUSP", cc.data[output.KEY_S], cusp, 0.5))
    assert len(set(idx)) > 1 and len(cc.data.materials) == output.COLOR_BINS


def test_generate_runs_synchronously_in_background_with_invoke(addon, demo):
    """INVOKE_DEFAULT in background mode does not go modal (no event loop): it finishes."""
    assert bpy.app.background
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5)
    assert bpy.ops.blisk_cam.generate_paths("INVOKE_DEFAULT") == {"FINISHED"}
    assert scene.blisk_cam.has_result and not gen_mod._RUNNING


def test_lead_tilt_degrees_become_radians_in_properties(addon):
    args = cli.build_parser().parse_args(
        ["paths", "--mesh", "x.stl", "--tool", "bull", "--tool-radius", "6",
         "--corner-radius", "2", "--cusp", "0.05", "--chord", "0.02", "--lead", "3",
         "--tilt", "-1.5", "--link", "zigzag", "--out", "p.json"]
    )
    cli_paths._check_paths_args(args)
    scene = _new_scene()
    from blisk_cam.blender.settings import set_settings_from_request
    from blisk_cam.core.geometry.axis import Axis
    from blisk_cam.core.process.blade_finish import PathRequest

    # what --blend saves: the CLI's request in the scene settings
    set_settings_from_request(scene.blisk_cam, PathRequest(Axis(), **args.stages))
    s = scene.blisk_cam
    assert s.lead == pytest.approx(math.radians(3.0))
    assert s.tilt == pytest.approx(-math.radians(1.5))
    assert (s.tool_type, s.link_mode) == ("BULL", "ZIGZAG")
    from blisk_cam.blender.settings import path_request

    req = path_request(s, None, None, None)
    assert req.tool_type == "bull" and req.link == "zigzag"
    assert (req.tool_radius, req.corner_radius, req.cusp, req.chord) == (6.0, 2.0, 0.05, 0.02)
    assert req.lead == pytest.approx(math.radians(3.0), abs=1e-7)


def _runner(op_class=None):
    """A Generate Paths run stepped by hand: the operator's own modal code (``tick``,
    ``escape``, ``_end``...) bound by ``ModalRunner``, started as ``invoke`` does."""
    op_class = op_class or gen_mod.BLISKCAM_OT_generate_paths
    runner = ModalRunner(op_class, gen_mod.PathJob(bpy.context))
    runner.start(bpy.context)
    return runner


def _until_paths_shown(runner, max_ticks=500):
    """Timer ticks until the planned paths are written with their JSON (stored by a tick
    after the one showing them when verify is on); the return set of the last tick."""
    for _ in range(max_ticks):
        result = runner.step(bpy.context)
        if result != {"RUNNING_MODAL"} or runner._job.written_json is not None:
            return result
        runner._job.wait_plan(0.05)  # the planning worker: give it time between ticks
    raise AssertionError("the paths were not planned in time")


def _without_stats(json_text):
    d = json.loads(json_text)
    d.pop("stats", None)  # wall times
    return d


def _verify_state(blade_name="Blade"):
    """What the verify left in the output: the colour-map values, the per-spline cusp of the
    CC curves, the curve materials, the stored JSON's verdict."""
    objs = output.output_objects(output.find_output_collection(blade_name))
    ob = objs["verify"]
    cc = objs["cc"]
    return {
        "map": None if ob is None else _attr(ob.data, "material_left", 1),
        "map_objects": sorted(o.name for o in bpy.data.objects if o.name.startswith(
            f"{blade_name} verify")),
        "spline_cusp": list(cc.data[output.KEY_SPLINE_CUSP]),
        "materials": [sp.material_index for sp in cc.data.splines],
        "verdict": json.loads(output.stored_paths_json(blade_name)).get("verify"),
    }


class _Layout:
    """Stands in for ``UILayout``: records the labels drawn (text only)."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = self.use_property_decorate = False
        self.scale_y = 1.0

    def _child(self, *_a, **_kw):
        return _Layout(self.log)

    row = column = box = split = _child

    def label(self, text="", **_kw):
        self.log.append(text)

    def prop(self, *_a, **_kw):
        pass

    operator = prop


def _paths_panel_labels():
    from blisk_cam.panels.paths import BLISKCAM_PT_paths

    log = []
    BLISKCAM_PT_paths.draw(type("P", (), {"layout": _Layout(log)})(), bpy.context)
    return log


def _ticks_to_the_end(runner, max_ticks=500):
    """Timer ticks until the run ends; the return set of the last tick."""
    for _ in range(max_ticks):
        result = runner.step(bpy.context)
        if result != {"RUNNING_MODAL"}:
            return result
        runner._job.wait_plan(0.05)  # the planning worker: give it time between ticks
    raise AssertionError("the run did not end in time")


def test_modal_bad_input_is_reported_and_the_previous_result_kept(addon, demo):
    """Interactively the weld and the plan run on the worker thread, so a bad mesh or cones
    that miss the blade fail on a timer tick, not at invoke: the error is reported by name
    (no traceback), the run ends cancelled, the previous paths stay, nothing keeps running."""
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, pose_count=10)
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    first = output.stored_paths_json("Blade")
    s = scene.blisk_cam

    # cones beside the blade: the planner's ConeError
    good_cones = tuple(s.cone1), tuple(s.cone2)
    s.cone1, s.cone2 = (400.0, -25.0, 410.0, 35.0), (450.0, -25.0, 460.0, 35.0)
    op = _runner()
    assert _ticks_to_the_end(op) == {"CANCELLED"}
    kind, text = op.reports[-1]
    assert kind == {"ERROR"} and "miss the blade" in text and "internal" not in text.lower()
    assert op._job._plan_thread is not None and op._job.wait_plan(60.0)
    assert output.stored_paths_json("Blade") == first and not gen_mod._RUNNING

    # every vertex on one point: the weld's MeshError, raised on the worker (the arrays read
    # at invoke are finite; only the weld finds the mesh has no extent)
    s.cone1, s.cone2 = good_cones
    co = np.empty(len(blade.data.vertices) * 3)
    blade.data.vertices.foreach_get("co", co)
    blade.data.vertices.foreach_set("co", np.full_like(co, 50.0))
    blade.data.update()
    op = _runner()
    assert op._job.mesh is None  # invoke only read the arrays: the weld is the worker's
    assert _ticks_to_the_end(op) == {"CANCELLED"}
    kind, text = op.reports[-1]
    assert kind == {"ERROR"} and "all vertices coincide" in text, op.reports
    assert output.stored_paths_json("Blade") == first and not gen_mod._RUNNING
    assert bpy.ops.blisk_cam.generate_paths.poll()  # a new run may start


def test_modal_steps_with_progress_and_esc_keeps_the_previous_result(addon, demo):
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, pose_count=10)
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    first = output.stored_paths_json("Blade")

    # ESC after a few ticks: cancelled, the previous result untouched, nothing left running
    scene.blisk_cam.cusp = 0.35
    op = _runner()
    assert "being generated" in _poll_error(bpy.ops.blisk_cam.generate_paths)
    assert op.step(bpy.context) == {"RUNNING_MODAL"}
    assert op.step(bpy.context, "MOUSEMOVE") == {"PASS_THROUGH"}
    assert op.step(bpy.context, "ESC") == {"CANCELLED"}
    assert op.reports[-1][0] == {"WARNING"} and "previous paths are kept" in op.reports[-1][1]
    assert output.stored_paths_json("Blade") == first and not gen_mod._RUNNING
    job = op._job  # the planning worker was told to stop, and stops without a result
    assert job._plan_cancel.is_set() and job.wait_plan(600.0)
    assert job.plan is None or job.fraction == 1.0  # (unless it had already finished)
    assert output.stored_paths_json("Blade") == first

    # ticks to the end: progress goes up, the result replaces the previous one
    op = _runner()
    fractions, result = [], {"RUNNING_MODAL"}
    for _ in range(500):
        result = op.step(bpy.context)
        fractions.append(op._job.fraction)
        if result != {"RUNNING_MODAL"}:
            break
        op._job.wait_plan(0.05)  # the planning worker: give it time between ticks
    assert result == {"FINISHED"}, op.reports
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert op.reports[-1][0] == {"INFO"} and "passes" in op.reports[-1][1]
    assert output.stored_paths_json("Blade") != first and not gen_mod._RUNNING
    assert json.loads(output.stored_paths_json("Blade"))["tolerances"]["cusp"] == 0.35
    assert not gen_mod._VERIFYING  # verify off: nothing pending


def test_interactive_generate_shows_the_paths_then_the_verify_map(addon, demo):
    """The paths are in the scene on the tick the plan completes, before any verify figure;
    the figures come on a later tick, from a worker thread, and the end result equals the
    synchronous run's (same JSON but wall times, same colour map, cusp colours, verdict)."""
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, verify=True, verify_map=True)
    s = scene.blisk_cam
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}  # synchronous: the reference
    ref_json = _without_stats(output.stored_paths_json("Blade"))
    ref = _verify_state()
    ref_stats = (s.stat_material_left, s.stat_gouge, s.stat_verdict, s.stat_poses)
    assert ref["map"] is not None and ref_json["verify"]["status"] in ("PASS", "FAIL")
    assert s.stat_verdict == ref_json["verify"]["status"]
    output.clear_path_objects("Blade")

    op = _runner()
    assert _until_paths_shown(op) == {"RUNNING_MODAL"}
    job = op._job
    # the paths are shown: curves, poses, empties as the JSON says; no verify figure yet
    assert output.has_paths("Blade")
    shown = output.stored_paths_json("Blade")
    assert "verify" not in json.loads(shown)
    assert _without_stats(shown) == {k: v for k, v in ref_json.items() if k != "verify"}
    _check_outputs_match_json(_measure_outputs("Blade"), json.loads(shown), POSE_CAP)
    state = _verify_state()
    assert state["map"] is None and state["map_objects"] == []
    assert not s.stat_verified and s.stat_verdict == "" and s.has_result
    assert gen_mod.verify_pending(scene.name) and job.verify_pending
    labels = _paths_panel_labels()  # the panel: the paths' figures and "Verifying…"
    assert "Verifying… (ESC skips it)" in labels and f"Blade: {s.stat_blade}" in labels
    assert not [x for x in labels if x.startswith(("Verify:", "Measured", "Not verified"))]
    # the UI is free: the panel's Generate is enabled again (a new run would drop the verify)
    assert scene.name not in gen_mod._RUNNING
    assert bpy.ops.blisk_cam.generate_paths.poll()

    # ticks while the worker runs change nothing; once it is done one tick attaches it all
    assert job.wait_verify(600.0)
    assert job.verify is None and output.stored_paths_json("Blade") == shown
    assert op.step(bpy.context) == {"FINISHED"}, op.reports
    assert op.reports[-1][0] == {"INFO"} and "measured max material left" in op.reports[-1][1]
    assert not gen_mod.verify_pending(scene.name) and not gen_mod._VERIFYING
    assert _without_stats(output.stored_paths_json("Blade")) == ref_json
    got = _verify_state()
    np.testing.assert_array_equal(got["map"], ref["map"])
    assert got["spline_cusp"] == ref["spline_cusp"] and got["materials"] == ref["materials"]
    assert got["map_objects"] == ["Blade verify"]
    assert (s.stat_material_left, s.stat_gouge, s.stat_verdict, s.stat_poses) == ref_stats
    assert s.stat_verified
    labels = _paths_panel_labels()  # then the verdict and the measured figures
    assert f"Verify: {ref_json['verify']['status']}" in labels
    assert f"Measured max material left: {s.stat_material_left:.4f} mm" in labels
    assert not [x for x in labels if x.startswith("Verifying")]


def test_the_colour_map_shows_before_the_other_verify_figures(addon, demo):
    """The worker hands the material left over before its scallops: the next tick shows the
    colour map alone (no verdict yet), a later one the other figures, keeping that map; the
    end equals the synchronous run. ESC once the map is shown removes it with the figures."""
    import threading

    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, verify=True, verify_map=True)
    s = scene.blisk_cam
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}  # synchronous: the reference
    ref_json = _without_stats(output.stored_paths_json("Blade"))
    ref = _verify_state()
    output.clear_path_objects("Blade")
    handed, go = threading.Event(), threading.Event()
    for esc in (False, True):
        handed.clear()
        go.clear()
        op = _runner()
        job = op._job
        hand_over = job.material_left_measured

        def held(values, hand_over=hand_over):  # the worker held once it has handed them
            hand_over(values)
            handed.set()
            go.wait(600.0)

        job.material_left_measured = held
        try:
            assert _until_paths_shown(op) == {"RUNNING_MODAL"}
            assert handed.wait(600.0) and _verify_state()["map"] is None
            assert op.step(bpy.context) == {"RUNNING_MODAL"}  # this tick shows the map
            early = _verify_state()
            assert job.map_shown and job.verify_pending and not s.stat_verified
            np.testing.assert_array_equal(early["map"], ref["map"])
            assert early["verdict"] is None and early["map_objects"] == ["Blade verify"]
            map_object = output.output_objects(output.find_output_collection("Blade"))["verify"]
            if esc:  # the paths stay, without any verify figure: the map goes too
                assert op.step(bpy.context, "ESC") == {"FINISHED"}
                assert _verify_state()["map_objects"] == [] and not job.map_shown
        finally:
            go.set()
        assert job.wait_verify(600.0)
        if esc:
            assert _verify_state()["map_objects"] == [] and _verify_state()["verdict"] is None
            assert not gen_mod._VERIFYING and not s.stat_verified
            continue
        assert op.step(bpy.context) == {"FINISHED"}, op.reports
        got = _verify_state()
        assert _without_stats(output.stored_paths_json("Blade")) == ref_json
        # the verdict appended to the planned path's JSON: the bytes of the merged dict's
        from blisk_cam.core.toolpath.paths_io import path_to_dict
        from blisk_cam.core.verify.verdict import verdict_dict

        whole = {**path_to_dict(job.plan.path), "verify": verdict_dict(job.verdict)}
        stored = output.text_lines(json.dumps(whole, allow_nan=False))[1]  # as the Text keeps
        assert output.stored_paths_json("Blade") == stored
        np.testing.assert_array_equal(got["map"], ref["map"])
        assert got["spline_cusp"] == ref["spline_cusp"] and got["materials"] == ref["materials"]
        assert got["map_objects"] == ["Blade verify"] and s.stat_verified
        kept = output.output_objects(output.find_output_collection("Blade"))["verify"]
        assert kept.as_pointer() == map_object.as_pointer()  # the early map, not a new one


def _until_shown_without_json(runner, max_ticks=500):
    """Timer ticks until the tick showing the planned paths (verify on: their JSON not yet)."""
    for _ in range(max_ticks):
        assert runner.step(bpy.context) == {"RUNNING_MODAL"}, runner.reports
        if runner._job.paths_seconds is not None:
            return
        runner._job.wait_plan(0.05)
    raise AssertionError("the paths were not planned in time")


def test_the_paths_show_before_their_json_which_is_never_missing_after(addon, demo):
    """With verify on, the tick the plan completes shows the objects; the verify worker makes
    the paths JSON first and a later tick stores it, in the previous result's Text. ESC on
    the very next tick: the JSON is made then, the paths never stay without it."""
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, verify=True, verify_map=False)
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}  # an old result and its Text
    name = output.collection_name("Blade") + ".json"
    old_text = bpy.data.texts[name]
    scene.blisk_cam.cusp = 0.45
    for esc in (False, True):
        op = _runner()
        job = op._job
        _until_shown_without_json(op)
        objs = output.output_objects(output.find_output_collection("Blade"))
        assert objs["cc"] is not None and len(objs["pose_empties"]) == POSE_CAP
        assert not output.has_paths("Blade") and job.written_json is None
        if esc:
            assert op.step(bpy.context, "ESC") == {"FINISHED"}
        else:
            assert _until_paths_shown(op) == {"RUNNING_MODAL"}
        stored = output.stored_paths_json("Blade")
        expect = output.text_lines(output.paths_json_text(job.plan.path))[1]
        assert stored == expect == job.written_json and output.has_paths("Blade")
        assert json.loads(stored)["tolerances"]["cusp"] == pytest.approx(0.45)
        # the previous result's Text, reused: no "….json.001" beside it
        assert bpy.data.texts[name] == old_text
        assert [t.name for t in bpy.data.texts if t.name.startswith(name)] == [name]
        job.wait_verify(600.0)
        if not esc:
            assert _ticks_to_the_end(op) == {"FINISHED"}
            assert "verify" in json.loads(output.stored_paths_json("Blade"))


def test_cancelling_a_pending_verify_leaves_a_consistent_scene(addon, demo):
    scene, blade = _blade_scene(demo, cusp=0.5, chord=0.5, verify=True, verify_map=True)
    s = scene.blisk_cam
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}  # an old result with its map
    assert _verify_state()["map"] is not None

    # ESC while verifying: the new paths stay (FINISHED: one undo step), no stale colour map
    s.cusp = 0.45
    op = _runner()
    _until_paths_shown(op)
    job = op._job
    new_json = output.stored_paths_json("Blade")
    assert json.loads(new_json)["tolerances"]["cusp"] == pytest.approx(0.45)
    assert _verify_state()["map_objects"] == []  # the old map went with the old paths
    assert op.step(bpy.context, "ESC") == {"FINISHED"}
    assert op.reports[-1][0] == {"WARNING"} and "Verify cancelled" in op.reports[-1][1]
    assert not gen_mod.verify_pending(scene.name) and not gen_mod._RUNNING
    assert job._cancel.is_set()  # the worker's cancel hook: it stops at its next chunk
    job.wait_verify(600.0)  # the worker ends; its figures are never attached
    if job._verify_error is not None:  # stopped by the hook (unless it had already finished)
        assert isinstance(job._verify_error, Cancelled) and job._verify_result is None
    assert job.verify is None and output.stored_paths_json("Blade") == new_json
    assert _verify_state()["map_objects"] == [] and not s.stat_verified

    # a new Generate while verifying drops the pending figures: the new result is complete
    op = _runner()
    _until_paths_shown(op)
    first_job = op._job
    s.cusp = 0.4
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}  # synchronous, with verify
    newest = output.stored_paths_json("Blade")
    assert json.loads(newest)["tolerances"]["cusp"] == pytest.approx(0.4)
    assert "verify" in json.loads(newest) and s.stat_verified
    assert first_job._cancel.is_set()  # the new Generate stopped the old worker
    first_job.wait_verify(600.0)
    assert op.step(bpy.context) == {"FINISHED"}
    assert "new generation" in op.reports[-1][1]
    assert output.stored_paths_json("Blade") == newest and first_job.verify is None
    assert _verify_state()["map_objects"] == ["Blade verify"]

    # the paths cleared while verifying: the figures are dropped with a reason, nothing made
    op = _runner()
    _until_paths_shown(op)
    assert bpy.ops.blisk_cam.clear_paths() == {"FINISHED"}
    op._job.wait_verify(600.0)
    assert op.step(bpy.context) == {"FINISHED"}
    assert op.reports[-1][0] == {"ERROR"} and "generate again" in op.reports[-1][1]
    assert output.find_output_collection("Blade") is None
    assert not [o for o in bpy.data.objects if o.name.startswith("Blade verify")]
