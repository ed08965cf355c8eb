"""The "Robot" panel and its operators (issue 26 item 6): Export Robot Program writes a program
our reader turns back onto the path through forward kinematics; the inline head on a path
through the wrist singularity writes nothing and names the ranges; Show Robot animates the arm
so that the tool point sits on every planned pose, the last frame on the last pose."""

import dataclasses

import bpy
import numpy as np
import pytest

from blisk_cam.core.robot import kinematics as K
from blisk_cam.core.robot.description import load_robot
from blisk_cam.core.robot.readers import decode_joints, read_program
from blisk_cam.core.toolpath.types import Program
from tests.support.nc import rotor37_path

N_POSES = 200


@pytest.fixture(scope="module")
def small_path():
    """Rotor 37's linked program cut to its first poses (as tests/core/test_cli_robot.py)."""
    path = rotor37_path()
    p = path.program
    cut = {f.name: (None if getattr(p, f.name) is None else getattr(p, f.name)[:N_POSES])
           for f in dataclasses.fields(Program)}
    return dataclasses.replace(path, program=Program(**cut))


def _scene_with_paths(path):
    """A fresh scene whose blade has ``path`` as its generated paths (stored JSON + objects);
    the robot panel's settings at small sample counts."""
    from blisk_cam.blender.objects import arrays_to_object
    from blisk_cam.blender.path_objects import write_path_objects

    bpy.ops.wm.read_factory_settings(use_empty=True)
    V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    blade = arrays_to_object("blade", V, np.array([[0, 1, 2]]))
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.stat_blade = blade.name
    write_path_objects(bpy.context.scene, blade, path, s)
    s.robot, s.robot_samples, s.robot_feed = "kr120-r2700-angled", 24, 600.0
    return blade, s


def test_robot_panel_and_operators_register(addon):
    assert hasattr(bpy.types, "BLISKCAM_PT_robot")
    assert hasattr(bpy.ops.blisk_cam, "export_robot") and hasattr(bpy.ops.blisk_cam,
                                                                  "show_robot")
    s = bpy.context.scene.blisk_cam
    # the joint step is an angle: stored radians, shown in degrees (subtype ANGLE)
    prop = s.bl_rna.properties["robot_max_step"]
    assert prop.subtype == "ANGLE" and s.robot_max_step == pytest.approx(np.radians(10.0))
    # without paths the operators refuse with the reason
    assert not bpy.ops.blisk_cam.export_robot.poll()


def test_export_robot_program_reads_back_onto_the_path(addon, small_path, tmp_path):
    _, s = _scene_with_paths(small_path)
    out = tmp_path / "krl"
    s.robot_post, s.robot_out, s.robot_force = "krl", str(out), 25.0
    assert bpy.ops.blisk_cam.export_robot() == {"FINISHED"}
    files = {f.name: f.read_text() for f in out.iterdir()}
    assert "blisk_main.src" in files
    assert "contact force setpoint: 25 N" in files["blisk_main.src"]
    assert "min wrist-singularity margin" in s.robot_summary
    robot = load_robot("kr120-r2700-angled")
    read = read_program("krl", files, "blisk_main.src")
    q = decode_joints(robot, "krl", read)
    F = robot.pose_of(K.flange_pose(robot, q))
    assert len(F) == N_POSES
    assert np.abs(F[:, :3, 3] - small_path.program.tip).max() < 1e-3 + 5e-5
    # a file the user owns is never replaced: error, the file kept
    (out / "blisk_main.src").write_text("my own program\n")
    with pytest.raises(RuntimeError, match="not written by Blisk CAM"):
        bpy.ops.blisk_cam.export_robot()
    assert (out / "blisk_main.src").read_text() == "my own program\n"


def test_inline_head_reports_the_singular_ranges_and_writes_nothing(addon, small_path,
                                                                    tmp_path):
    _, s = _scene_with_paths(small_path)
    out = tmp_path / "none"
    s.robot, s.robot_post, s.robot_out = "kr120-r2700", "rapid", str(out)
    with pytest.raises(RuntimeError, match=r"cannot be run by .*singularity.*stroke"):
        bpy.ops.blisk_cam.export_robot()
    assert not out.exists()
    with pytest.raises(RuntimeError, match="no program written"):
        bpy.ops.blisk_cam.show_robot()
    assert bpy.data.objects.get("blade robot TCP") is None


def test_show_robot_puts_the_tool_on_the_planned_poses(addon, small_path):
    """Scrubbing the timeline: at sampled frames the TCP (a child of the keyframed flange
    link) is on the path's tip and along its tool frame's axis (float32: 1e-3 mm); the last
    frame on the last pose; every link keeps its joint on the previous link's end (the drawn
    arm is one chain); the pose colours follow the margin."""
    from blisk_cam.blender.objects import mm_per_blender_unit
    from blisk_cam.blender.robot_objects import MARGIN_BINS_DEG, pose_margin_deg

    blade, s = _scene_with_paths(small_path)
    assert bpy.ops.blisk_cam.show_robot() == {"FINISHED"}
    scene = bpy.context.scene
    assert (scene.frame_start, scene.frame_end) == (1, N_POSES)
    f = mm_per_blender_unit(scene)
    tcp = bpy.data.objects[f"{blade.name} robot TCP"]
    tips = small_path.program.tip
    robot = load_robot("kr120-r2700-angled")
    elbow = bpy.data.objects[f"{blade.name} robot upper arm"]
    lower = bpy.data.objects[f"{blade.name} robot lower arm"]
    for k in [*np.linspace(0, N_POSES - 1, 8).astype(int), N_POSES - 1]:
        scene.frame_set(int(k) + 1)
        T = np.array(tcp.matrix_world)
        np.testing.assert_allclose(T[:3, 3] * f, tips[k], atol=1e-3)
        # the elbow joint is c2 along the lower arm from its joint
        L = np.array(lower.matrix_world)
        E = np.array(elbow.matrix_world)
        np.testing.assert_allclose((E[:3, 3] - L[:3, 3]) * f, L[:3, 2] * robot.opw["c2"],
                                   atol=1e-3)
    # the tool axis of the program (z into the part) is minus the paths' spindle axis
    np.testing.assert_allclose(T[:3, 2], -small_path.program.axis[-1], atol=1e-5)
    poses = bpy.data.objects[f"{blade.name} robot poses"]
    mats = np.zeros(len(poses.data.polygons), np.int32)
    poses.data.polygons.foreach_get("material_index", mats)
    margin = np.zeros(len(mats), np.float32)
    poses.data.attributes["margin_deg"].data.foreach_get("value", margin)
    # the margins are those of the plan's joints (the same plan as the export's)
    from blisk_cam.blender.settings import robot_options
    from blisk_cam.core.robot.free_angle import plan_robot

    plan = plan_robot(robot, small_path, robot_options(s)[0])
    q = np.concatenate([st.q for st in plan.strokes])
    per_pose = margin.reshape(N_POSES, -1)
    assert np.all(per_pose == per_pose[:, :1])
    np.testing.assert_allclose(per_pose[:, 0], pose_margin_deg(robot, q), atol=1e-4)
    assert np.min(per_pose) > 0.0
    assert np.array_equal(mats, np.searchsorted(MARGIN_BINS_DEG, margin, side="right"))



def test_export_robot_modal_shows_progress_and_esc_writes_nothing(addon, small_path, tmp_path):
    """Interactively the plan runs on its own thread (the timer ticks read its progress);
    ESC stops it and nothing is written; a run to the end writes the program."""
    import time

    from blisk_cam.operators import export_robot as mod
    from blisk_cam.operators.modal_job import ModalRunner

    _, s = _scene_with_paths(small_path)
    out = tmp_path / "modal"
    s.robot_post, s.robot_out = "pdl2", str(out)
    ctx = bpy.context
    op = ModalRunner(mod.BLISKCAM_OT_export_robot, mod.RobotPlanJob(ctx, export=True))
    op.start(ctx)
    assert ctx.scene.name in mod._RUNNING and not bpy.ops.blisk_cam.export_robot.poll()
    assert op.step(ctx, "MOUSEMOVE") == {"PASS_THROUGH"}
    assert op.step(ctx, "ESC") == {"CANCELLED"}
    assert op._job.cancel.is_set() and not op._job.running and not mod._RUNNING
    assert "nothing written" in op.reports[-1][1] and not out.exists()

    op = ModalRunner(mod.BLISKCAM_OT_export_robot, mod.RobotPlanJob(ctx, export=True))
    op.start(ctx)
    fractions, result = [], {"RUNNING_MODAL"}
    for _ in range(20000):
        result = op.step(ctx)
        fractions.append(op._job.fraction)
        if result != {"RUNNING_MODAL"}:
            break
        time.sleep(0.002)
    assert result == {"FINISHED"}, op.reports
    assert fractions == sorted(fractions) and fractions[-1] == 1.0 and not mod._RUNNING
    assert (out / "blisk_main.pdl").exists() and "min wrist" in op.reports[-1][1]


def test_show_robot_holding_the_blisk_keeps_the_tool_on_the_path(addon, small_path):
    """Robot holds the part against a fixed spindle: seen from the standing part the arm
    moves, and the (fixed) tool point is on the path's tip at every sampled frame."""
    from blisk_cam.blender.objects import mm_per_blender_unit

    blade, s = _scene_with_paths(small_path)
    s.robot = "kr120-r2700-holds-blisk"
    assert bpy.ops.blisk_cam.show_robot() == {"FINISHED"}
    scene = bpy.context.scene
    f = mm_per_blender_unit(scene)
    tcp = bpy.data.objects[f"{blade.name} robot TCP"]
    flange = bpy.data.objects[f"{blade.name} robot flange"]
    robot = load_robot("kr120-r2700-holds-blisk")
    tips = small_path.program.tip
    for k in [0, N_POSES // 2, N_POSES - 1]:
        scene.frame_set(k + 1)
        np.testing.assert_allclose(np.array(tcp.matrix_world)[:3, 3] * f, tips[k], atol=1e-3)
        # the part frame is the robot's part frame on the flange: flange · part = identity
        Fl = np.array(flange.matrix_world)
        Fl[:3, 3] *= f
        np.testing.assert_allclose(Fl @ robot.part, np.eye(4), atol=1e-3)


def test_show_robot_draws_a_link_from_its_mesh_when_given(addon, small_path, tmp_path):
    """A robot TOML with [meshes] link3 (in metres, scale 1000): the upper arm is that mesh
    (its vertices, scaled, in the link's frame), the other links the simple shapes."""
    from blisk_cam.blender.objects import mm_per_blender_unit
    from blisk_cam.core.robot.description import ROBOTS_DIR
    from tests.support.mesh_files import write_binary_stl

    V = np.array([[0, 0, 0], [0.05, 0, 0], [0, 0.05, 0], [0, 0, 1.2]], float)  # metres
    F = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    write_binary_stl(tmp_path / "upper.stl", V, F)
    toml = tmp_path / "arm.toml"
    toml.write_text((ROBOTS_DIR / "kr120-r2700-angled.toml").read_text()
                    + '\n[meshes]\nlink3 = "upper.stl"\nscale = 1000.0\n')
    blade, s = _scene_with_paths(small_path)
    s.robot, s.robot_file = "FILE", str(toml)
    assert bpy.ops.blisk_cam.show_robot() == {"FINISHED"}
    f = mm_per_blender_unit(bpy.context.scene)
    upper = bpy.data.objects[f"{blade.name} robot upper arm"]
    co = np.zeros(3 * len(upper.data.vertices), np.float32)
    upper.data.vertices.foreach_get("co", co)
    np.testing.assert_allclose(np.unique(co.reshape(-1, 3) * f, axis=0),
                               np.unique(V * 1000.0, axis=0), atol=1e-3)
    assert len(bpy.data.objects[f"{blade.name} robot lower arm"].data.vertices) > 4
