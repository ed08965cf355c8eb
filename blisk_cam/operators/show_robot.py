"""``blisk_cam.show_robot``: the robot of the "Robot" panel drawn from simple link shapes and
animated along its plan of the generated paths, one keyframe per pose on frames 1..n (the same
``plan_robot`` the export runs, so what plays is what the program does); the planned tool
poses coloured by their wrist-singularity / joint-limit margin (:mod:`..blender.robot_objects`).
A path the robot cannot run is reported as its ranges, and nothing is drawn. Modal with the
plan on its thread as Export Robot Program (:class:`.export_robot.RobotModal`)."""

import bpy
import numpy as np

from ..core.errors import BliskCamError
from .animate_program import _keyframe_matrices
from .common import settings_of
from .export_robot import RobotModal, plan_summary

#: the robot objects' collection (under the blade's output collection) and the TCP's name
COLLECTION_SUFFIX = "robot"
TCP_SUFFIX = "robot TCP"
LINK_RGBA = (0.9, 0.45, 0.05, 1.0)
BASE_RGBA = (0.25, 0.25, 0.28, 1.0)


def robot_collection_name(blade_name: str) -> str:
    return f"{blade_name} {COLLECTION_SUFFIX}"


#: names of scenes with a Show Robot plan running
_RUNNING: set[str] = set()


class BLISKCAM_OT_show_robot(RobotModal, bpy.types.Operator):
    """Draw the robot of the Robot panel and animate it along the planned poses of the
    generated paths on the timeline; colour the poses by singularity / limit margin (ESC
    cancels)"""

    bl_idname = "blisk_cam.show_robot"
    bl_label = "Show Robot"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    export = False
    status_label = "Blisk CAM robot"
    cancel_text = "Show Robot cancelled; the previous display is kept"

    def done(self, context, job):
        from ..blender import path_objects as output
        from ..blender import robot_objects as draw
        from ..blender.objects import arrays_to_object, ensure_collection, mm_per_blender_unit

        scene = context.scene
        settings = settings_of(context)
        plan, robot, name = job.result(), job.robot, job.blade_name
        q = np.concatenate([s.q for s in plan.strokes])
        frames = np.concatenate([s.frame for s in plan.strokes])
        if len(q) == 0:
            raise BliskCamError("the plan has no poses to show")
        f = mm_per_blender_unit(scene)
        coll = ensure_collection(robot_collection_name(name),
                                 output.find_output_collection(name))
        draw.remove_objects(coll)
        world = draw.link_frames_world(robot, q)
        links = []
        for i, (V, F) in enumerate(draw.link_shapes(robot, q[0])):
            ob = arrays_to_object(f"{name} robot {draw.LINK_NAMES[i]}", V, F, coll,
                                  color=LINK_RGBA if i else BASE_RGBA,
                                  material_name="Blisk CAM robot link" if i else
                                  "Blisk CAM robot base")
            _keyframe_matrices(ob, world[:, i], f)
            links.append(ob)
        tcp = bpy.data.objects.new(f"{name} {TCP_SUFFIX}", None)
        tcp.empty_display_type = "ARROWS"
        tcp.empty_display_size = 50.0 / f
        coll.objects.link(tcp)
        if robot.holds_part:  # the tool stands in the cell: its pose in the part frame
            from ..core.robot.kinematics import flange_pose

            _keyframe_matrices(tcp, robot.pose_of(flange_pose(robot, q)), f)
        else:  # the head on the flange: the TCP rides the flange link
            from mathutils import Matrix

            tcp.parent = links[6]
            T = robot.tool.copy()
            T[:3, 3] /= f
            tcp.matrix_parent_inverse.identity()
            tcp.matrix_basis = Matrix(T.tolist())
        margin = draw.pose_margin_deg(robot, q)
        draw.write_margin_points(f"{name} robot poses", frames[:, :3, 3], margin, coll,
                                 0.02 * max(robot.opw["c4"], 10.0))
        scene.frame_start, scene.frame_end = 1, len(q)
        scene.frame_set(1)
        settings.robot_summary = plan_summary(plan, job.feed)
        self.report({"INFO"}, f"{robot.name} animated over {len(q)} poses on frames "
                    f"1–{len(q)}; {settings.robot_summary}")
        return {"FINISHED"}
