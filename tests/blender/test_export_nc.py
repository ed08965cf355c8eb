"""The "Machine & NC" panel and blisk_cam.export_nc: the NC options come from their one
declaration (core NcOptions), the operator posts the generated paths, refuses unresolved
collisions unless told, and the program runs in rs274 and comes back to the path."""

import json
import shutil
import subprocess

import bpy
import numpy as np
import pytest
from _scenes import radial_demo_paths

from blisk_cam.core.machine.description import forward, load_machine


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
    blade, s = radial_demo_paths(demo, tmp_path, chord=0.1)
    # the NC options are generated properties with the declared defaults
    assert (s.feed, s.spindle, s.tool_number) == (1000.0, 10000.0, 1)
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
    """The operator goes through the core's collision gate (core/post/gate.py): refused
    without Export Anyway; with it, the header says how many and where (issue 28 rows 1, 9)."""
    from blisk_cam.operators import export_nc

    blade, s = radial_demo_paths(demo, tmp_path, chord=0.5)
    real = export_nc.stored_path

    def marked(name):
        p = real(name)
        m = len(p.program)
        status = np.zeros(m, np.int8)
        rows = np.flatnonzero(np.asarray(p.program.curve) == 0)[:3]
        status[rows] = 2
        p.program.collision_status = status
        p.program.clearance = np.where(status == 2, -1.0, 5.0)
        p.collision = {"mode": "check", "unresolved": 3, "checked_poses": m}
        return p

    monkeypatch.setattr(export_nc, "stored_path", marked)
    out = tmp_path / "x.nc"
    with pytest.raises(RuntimeError, match="3 pose"):
        bpy.ops.blisk_cam.export_nc(filepath=str(out))
    assert not out.exists()
    s.export_anyway = True
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    head = out.read_text().upper().split("G1 ")[0]
    assert "EXPORTED ANYWAY WITH 3 UNRESOLVED COLLISION" in head and "PASS 0 POSES" in head


@pytest.mark.parametrize("view", ["PART", "MACHINE"])
def test_animate_program_puts_the_tool_on_the_program(addon, demo, tmp_path, view):
    """Blender as the simulator: at every sampled frame the animated tool, seen from the
    (moving) part, has its tip on the block's programmed tip and its axis along the block's
    axis (float32 matrices: 1e-3 mm, 1e-5)."""
    from blisk_cam.core.machine.description import load_machine
    from blisk_cam.core.post.blocks import NcOptions, build_blocks
    from blisk_cam.operators.common import stored_path

    blade, s = radial_demo_paths(demo, tmp_path, chord=0.5)
    s.machine = "ac-trunnion"
    assert bpy.ops.blisk_cam.animate_program(view=view) == {"FINISHED"}
    blocks = build_blocks(stored_path(blade.name), load_machine("ac-trunnion"), NcOptions(),
                          indexable=False).expanded()
    scene = bpy.context.scene
    assert (scene.frame_start, scene.frame_end) == (1, len(blocks))
    tool = bpy.data.objects[f"{blade.name} animated tool"]
    part = bpy.data.objects.get(f"{blade.name} moving part")
    assert (part is not None) == (view == "MACHINE")
    feed = np.flatnonzero(np.all(np.isfinite(blocks.tip), axis=1))  # blocks with a path tip
    assert len(feed) > 0.9 * len(blocks)
    for k in feed[np.linspace(0, len(feed) - 1, 15).astype(int)]:
        scene.frame_set(int(k) + 1)
        T = np.array(tool.matrix_world)
        P = np.array(part.matrix_world) if part is not None else np.eye(4)
        rel = np.linalg.inv(P) @ T
        np.testing.assert_allclose(rel[:3, 3], blocks.tip[k], atol=1e-3)
        np.testing.assert_allclose(rel[:3, 2], blocks.axis[k], atol=1e-5)
    # the user's blade is not animated or moved
    assert blade.animation_data is None and np.allclose(np.array(blade.matrix_world), np.eye(4))


def test_export_nc_with_constant_error_colours_the_blocks(addon, demo, tmp_path):
    """Machine & NC with constant-error interpolation: the program has fewer cut blocks than
    the planned poses, and the blocks appear as a curve coloured by the measured error."""
    # a narrow band: a few passes
    blade, s = radial_demo_paths(demo, tmp_path, chord=0.01, cone2=(185.0, -25.0, 200.0, 35.0))
    s.machine, s.post = "ac-trunnion", "linuxcnc"
    s.interpolation, s.max_error = "CONSTANT_ERROR", 0.01
    out = tmp_path / "ce.ngc"
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    ob = bpy.data.objects[f"{blade.name} NC blocks"]
    share = np.asarray(ob.data["blisk_cam_block_error_share"])
    assert len(ob.data.splines) == len(share) > 10
    assert np.all(share <= 1.0 + 0.1) and np.median(share) > 0.5  # near the bound
    bins = np.array([sp.material_index for sp in ob.data.splines])
    assert len(np.unique(bins)) > 1  # coloured, not one colour
    if shutil.which("rs274"):
        cp = subprocess.run(["rs274", "-g", str(out), str(tmp_path / "c.txt")],
                            stdin=subprocess.DEVNULL, capture_output=True, timeout=120)
        assert cp.returncode == 0


def test_one_blade_count_for_collisions_and_nc(addon, demo, tmp_path):
    """Issue 28 row 14: the blade count is one property, drawn by the Collisions and the
    Machine & NC panels; Export NC repeats the program for that many blades."""
    from blisk_cam.panels.collisions import BLISKCAM_PT_collisions
    from blisk_cam.panels.paths import BLISKCAM_PT_machine

    class Layout:
        def __init__(self, log):
            self.log, self.use_property_split, self.use_property_decorate = log, False, False
            self.active, self.scale_y, self.enabled = True, 1.0, True

        def prop(self, data, name, **_kw):
            assert hasattr(data, name), name
            self.log.append(name)

        def _child(self, *_a, **_kw):
            return Layout(self.log)

        row = column = box = split = _child

        def label(self, **_kw):
            pass

        def operator(self, idname, **_kw):
            return type("Op", (), {})()

    blade, s = radial_demo_paths(demo, tmp_path, chord=0.5)
    drawn = {}
    for cls in (BLISKCAM_PT_collisions, BLISKCAM_PT_machine):
        log = []
        cls.draw(type("P", (), {"layout": Layout(log)})(), bpy.context)
        drawn[cls.__name__] = log
    assert all("blade_count" in log for log in drawn.values())
    assert not any("blades" in log for log in drawn.values())
    assert "blades" not in s.bl_rna.properties  # no second property to disagree
    s.machine, s.post, s.blade_count = "ac-trunnion", "linuxcnc", 3
    out = tmp_path / "b.ngc"
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    assert "blades: 3" in out.read_text()


def test_part_origin_field_sets_the_work_offset(addon, demo, tmp_path):
    """Issue 28 row 10: the Machine & NC panel's Part Origin places the part without a copied
    preset; a TCP program states the work offset to set."""
    blade, s = radial_demo_paths(demo, tmp_path, chord=0.5)
    s.machine, s.post = "ac-trunnion", "fanuc"
    s.use_part_origin, s.part_origin = True, (0.0, 0.0, 20.0)
    out = tmp_path / "f.nc"
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    head = out.read_text().upper()
    assert "WORK OFFSET" in head and "Z20.0000" in head
    s.use_part_origin = False
    assert bpy.ops.blisk_cam.export_nc(filepath=str(out)) == {"FINISHED"}
    assert "Z20.0000" not in out.read_text().upper().split("G90")[0]
