"""The "Machine & NC" panel and blisk_cam.export_nc: the NC options come from their one
declaration (core NcOptions), the operator posts the generated paths, refuses unresolved
collisions unless told, and the program runs in rs274 and comes back to the path."""

import json
import shutil
import subprocess

import bpy
import numpy as np
import pytest
from _mesh_files import write_binary_stl

from blisk_cam import blender_io
from blisk_cam.core.machine import forward, load_machine


def _parse_linuxcnc_joints(text):
    """(X Y Z A C) of the G1 feed blocks of a joint program without subprogram (blades 1)."""
    rows = []
    for line in text.splitlines():
        if not line.startswith("G1 "):
            continue
        words = dict((w[0], float(w[1:])) for w in line.split()[1:] if w[0] in "XYZAC")
        if len(words) == 5:
            rows.append([words[k] for k in "XYZAC"])
    return np.array(rows)


def test_export_nc_posts_the_generated_paths(addon, demo, tmp_path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    stl = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    blade = blender_io.import_mesh_file(stl)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1 = (170.0, -25.0, 185.0, 35.0)  # above the hub fillet (reachable on A ≤ 110°)
    s.cone2 = demo.tip_cone.as_list()
    s.tool_diameter, s.cusp, s.chord = 12.0, 0.5, 0.1
    s.axis_mode, s.radial_tilt, s.verify = "RADIAL", np.radians(75.0), False
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    # the NC options are generated properties with the declared defaults
    assert (s.feed, s.spindle, s.blades, s.tool_number) == (1000.0, 10000.0, 1, 1)
    s.machine, s.post, s.spindle = "ac-trunnion", "linuxcnc", 8000.0
    out = tmp_path / "blade.ngc"
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    text = out.read_text()
    assert "T1 M6" in text and "S8000 M3" in text  # (rs274's own tool table has T1)
    if shutil.which("rs274"):
        cp = subprocess.run(["rs274", "-g", str(out), str(tmp_path / "c.txt")],
                            stdin=subprocess.DEVNULL, capture_output=True, timeout=120)
        assert cp.returncode == 0
    # forward kinematics of the cut blocks lands on the planned tip path (within the
    # linearization chord 0.1 mm + printed precision): every block's tip is near a planned tip
    q = _parse_linuxcnc_joints(text)
    tips, axes = forward(load_machine("ac-trunnion"), q[:, :3], np.radians(q[:, 3:]))
    program = json.loads(bpy.data.texts[-1].as_string().replace("\n", ""))["program"]
    planned = np.asarray(program["tip"])
    d = np.min(np.linalg.norm(tips[:, None, :] - planned[None, ::1, :], axis=2), axis=1)
    assert len(q) > 100 and np.median(d) < 1e-3 and d.max() < 5.0
    assert np.allclose(np.linalg.norm(axes, axis=1), 1.0)


def test_export_nc_refuses_unresolved_collisions(addon, demo, tmp_path, monkeypatch):
    from blisk_cam.operators import export_nc

    bpy.ops.wm.read_factory_settings(use_empty=True)
    stl = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    blade = blender_io.import_mesh_file(stl)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1 = (170.0, -25.0, 185.0, 35.0)
    s.cone2 = demo.tip_cone.as_list()
    s.tool_diameter, s.cusp, s.chord = 12.0, 0.5, 0.5
    s.axis_mode, s.radial_tilt, s.verify = "RADIAL", np.radians(75.0), False
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    monkeypatch.setattr(export_nc, "unresolved_collisions", lambda path: 3)
    out = tmp_path / "x.nc"
    with pytest.raises(RuntimeError, match="3 pose"):
        bpy.ops.blisk_cam.export_nc(filepath=str(out))
    assert not out.exists()
    s.export_anyway = True
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
