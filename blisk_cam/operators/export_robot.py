"""``blisk_cam.export_robot``: the last generated paths → a robot program for the robot and the
language of the "Robot" panel, as ``blisk_cam robot`` writes it: the collision gate of every
export (Export Anyway), the free angle about the tool axis resolved over the path
(``core.robot.free_angle.plan_robot``), the program texts (``core.robot.programs``) and the
files written atomically into the output folder, replacing only files Blisk CAM wrote
(``core.post.common.write_program_folder``). A path the robot cannot run (reach, a joint
limit, a singularity, a joint too fast at the feed) is reported as its ranges and nothing is
written. A plain operator (the cursor shows the progress; ``plan_robot`` is not a step
iterator a modal job could drive, so it cannot be cancelled from the UI).
"""

import bpy

from ..blender.settings import robot_options
from ..core.errors import BliskCamError
from .common import (
    output_filename,
    poll_generated_paths,
    report_exception,
    result_blade_name,
    settings_of,
    stored_path,
)

#: at most this many infeasible ranges are named in the error report (then "and k more")
MAX_RANGES = 6


def robot_name(settings):
    """The robot preset name or the absolute TOML path of the settings."""
    if settings.robot != "FILE":
        return settings.robot
    if not settings.robot_file:
        raise BliskCamError("Robot is 'TOML File' but no robot file is given: choose one in "
                            "the Robot panel")
    return bpy.path.abspath(settings.robot_file)


def infeasible_message(plan) -> str:
    """One message naming the stretches ``plan`` cannot run, their reasons and what to do."""
    bad = plan.infeasible
    listed = "; ".join(b.text() for b in bad[:MAX_RANGES])
    more = len(bad) - MAX_RANGES
    reasons = sorted({b.reason for b in bad})
    return (f"{len(bad)} stretch(es) of the path cannot be run by {plan.robot.name} "
            f"({', '.join(reasons)}): {listed}{f' (and {more} more)' if more > 0 else ''}; "
            "no program written. For a wrist singularity use an angled head; for speed lower "
            "the feed; for reach or limits move the part")


def plan_summary(plan, feed) -> str:
    """The figures of a feasible plan, degrees."""
    st = plan.stats
    return (f"{len(plan.strokes)} strokes, {plan.n_poses} poses; min wrist-singularity margin "
            f"{st['min_wrist_deg']:.2f}°, min joint-limit margin "
            f"{st['min_limit_margin_deg']:.2f}°, max joint step "
            f"{st['max_joint_step_deg']:.2f}°, max joint speed "
            f"{100 * st['max_speed_ratio']:.0f}% of its limit at {feed:g} mm/min")


def robot_plan(context, settings, path, *, notes=()):
    """(robot, plan, program options) of the panel for ``path``; the cursor shows the
    progress. Raises BliskCamError (with the ranges) when the path cannot be run."""
    from ..core.robot.description import load_robot
    from ..core.robot.free_angle import plan_robot

    robot = load_robot(robot_name(settings))
    plan_opt, program_opt = robot_options(settings, notes=notes)
    wm = getattr(context, "window_manager", None)
    if wm is not None:
        wm.progress_begin(0, 100)
    try:
        def progress(p):
            if wm is not None:
                wm.progress_update(int(100 * p.fraction))

        plan = plan_robot(robot, path, plan_opt, progress=progress)
    finally:
        if wm is not None:
            wm.progress_end()
    if not plan.feasible:
        raise BliskCamError(infeasible_message(plan))
    return robot, plan, program_opt


class BLISKCAM_OT_export_robot(bpy.types.Operator):
    """Write the generated tool paths as a robot program (free angle resolved over the path)
    for the robot and controller language of the Robot panel"""

    bl_idname = "blisk_cam.export_robot"
    bl_label = "Export Robot Program"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return poll_generated_paths(cls, context)

    def execute(self, context):
        from ..core.post.common import write_program_folder
        from ..core.post.gate import collision_gate
        from ..core.robot.programs import robot_program

        settings = settings_of(context)
        try:
            name = result_blade_name(context)
            path = stored_path(name)
            folder = output_filename(settings.robot_out, "robot program folder")
            # the collision gate of every export: unresolved collisions refused unless
            # Export Anyway is ticked, and then marked in the header
            gate = collision_gate(path, bool(settings.export_anyway))
            robot, plan, popt = robot_plan(context, settings, path, notes=gate.notes)
            prog = robot_program(plan, settings.robot_post, popt, path)
            write_program_folder(folder, prog.files)
        except Exception as exc:
            settings.robot_summary = ""
            return report_exception(self, exc)
        settings.robot_summary = plan_summary(plan, settings.robot_feed)
        if gate.warning:
            self.report({"WARNING"}, gate.warning)
        self.report({"INFO"}, f"{prog.summary()} in {folder}; {robot.name}: "
                    f"{settings.robot_summary}")
        return {"FINISHED"}


__all__ = ["BLISKCAM_OT_export_robot", "infeasible_message", "plan_summary", "robot_name",
           "robot_plan"]
