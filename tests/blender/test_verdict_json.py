"""Issue 14, item 3 (Blender side): with Verify on, the paths JSON carries the verdict."""

import json

import bpy

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import path_objects as output


def test_verified_paths_json_has_the_verdict(addon, demo, tmp_path):
    scene = bpy.context.scene
    blade = blender_io.arrays_to_object("Blade", demo.blade_vertices, demo.blade_faces)
    s = scene.blisk_cam
    s.blade = blade
    s.cone1, s.cone2 = demo.hub_cone.as_list(), demo.tip_cone.as_list()
    s.cusp, s.chord, s.verify, s.pose_count = 0.5, 0.5, True, 10
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    f = tmp_path / "p.json"
    assert bpy.ops.blisk_cam.export_paths(filepath=str(f)) == {"FINISHED"}
    d = json.loads(f.read_text())
    v = d["verify"]
    assert v["status"] in ("PASS", "FAIL") and (v["cusp"], v["chord"]) == (0.5, 0.5)
    left, gouge = v["checks"]["material_left"], v["checks"]["gouge"]
    assert left["bound"] == 1.0 and gouge["bound"] == 0.5
    # the figures are the verifier's, as stored on the settings
    assert abs(left["value"] - s.stat_material_left) < 1e-6
    assert abs(gouge["value"] - s.stat_gouge) < 1e-6
    assert v["status"] == ("PASS" if left["status"] == gouge["status"] == "PASS" else "FAIL")
    assert 0 <= left["curve"] < len(d["curves"]) and len(left["at"]) == 3
    # without Verify there is no verdict, and the JSON is the plain paths JSON
    s.verify = False
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    assert "verify" not in json.loads(output.stored_paths_json("Blade"))
