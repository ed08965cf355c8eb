"""``blisk_cam.export_robot``: the last generated paths → a robot program for the robot and the
language of the "Robot" panel, as ``blisk_cam robot`` writes it: the collision gate of every
export (Export Anyway), the free angle about the tool axis resolved over the path
(``core.robot.free_angle.plan_robot``), the program texts (``core.robot.programs``) and the
files written atomically into the output folder, replacing only files Blisk CAM wrote
(``core.post.common.write_program_folder``). A path the robot cannot run (reach, a joint
limit, a singularity, a joint too fast at the feed) is reported as its ranges and nothing is
written. Interactively the plan runs on a thread of its own while the operator is modal
(:mod:`.modal_job`: progress on the cursor and the status bar, ESC cancels and nothing is
written); in background or with EXEC_DEFAULT synchronously.
"""


import bpy

from ..blender.settings import robot_options
from ..core.errors import BliskCamError
from .common import (
    generated_paths_problem,
    output_filename,
    result_blade_name,
    settings_of,
    stored_path,
)
from .modal_job import ThreadJob, ThreadJobOperator

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


class RobotPlanJob(ThreadJob):
    """One free-angle plan of the generated paths for the Robot panel's robot: inputs read
    up front (the path, the robot, the options: no bpy object across steps), the plan run on
    a thread of its own (:meth:`start`; cancelled through :attr:`cancel`) or in the caller's
    (:meth:`run`). ``export``: the collision gate of every export is passed first (Export
    Anyway), and its notes go into the program header."""

    thread_name = "blisk_cam-robot"

    def __init__(self, context, *, export: bool):
        from ..core.post.gate import collision_gate
        from ..core.robot.description import load_robot

        settings = settings_of(context)
        self.scene_name = context.scene.name
        self.blade_name = result_blade_name(context)
        self.path = stored_path(self.blade_name)
        self.gate = None
        if export:
            self.folder = output_filename(settings.robot_out, "robot program folder")
            self.post = settings.robot_post
            self.gate = collision_gate(self.path, bool(settings.export_anyway))
        self.robot = load_robot(robot_name(settings))
        self.plan_options, self.program_options = robot_options(
            settings, notes=self.gate.notes if self.gate is not None else ())
        self.feed = float(settings.robot_feed)
        super().__init__()
        self.fraction = 0.0
        self.plan = None

    def _progress(self, p):
        self.fraction = float(p.fraction)

    def work(self):
        from ..core.robot.free_angle import plan_robot
        from ..core.runtime import cancellable

        with cancellable(self.cancel, "the robot plan"):
            self.plan = plan_robot(self.robot, self.path, self.plan_options,
                                   progress=self._progress)

    def outcome(self):
        """The feasible plan; BliskCamError naming the stretches the robot cannot run."""
        if not self.plan.feasible:
            raise BliskCamError(infeasible_message(self.plan))
        return self.plan


class RobotModal(ThreadJobOperator):
    """The modal run shared by Export Robot Program and Show Robot: the plan on its thread,
    its progress on the cursor and status bar, ESC cancels it (nothing written or drawn);
    then :meth:`done` in Blender's thread."""

    start_text = "resolving the free angle"
    export = True

    busy_text = "The robot plan is running (ESC cancels)"

    @classmethod
    def problem(cls, context):
        return generated_paths_problem(context)

    def done(self, context, job) -> set:
        raise NotImplementedError

    def make_job(self, context):
        return RobotPlanJob(context, export=self.export)


#: names of scenes with a robot export running
_RUNNING: set[str] = set()


class BLISKCAM_OT_export_robot(RobotModal, bpy.types.Operator):
    """Write the generated tool paths as a robot program (free angle resolved over the path)
    for the robot and controller language of the Robot panel (ESC cancels)"""

    bl_idname = "blisk_cam.export_robot"
    bl_label = "Export Robot Program"
    bl_options = {"REGISTER"}

    running = _RUNNING
    status_label = "Blisk CAM robot program"
    cancel_text = "Robot program cancelled; nothing written"

    def done(self, context, job):
        from ..core.post.common import write_program_folder
        from ..core.robot.programs import robot_program

        settings = settings_of(context)
        settings.robot_summary = ""
        plan = job.result()
        prog = robot_program(plan, job.post, job.program_options, job.path)
        write_program_folder(job.folder, prog.files)
        settings.robot_summary = plan_summary(plan, job.feed)
        if job.gate.warning:
            self.report({"WARNING"}, job.gate.warning)
        self.report({"INFO"}, f"{prog.summary()} in {job.folder}; {job.robot.name}: "
                    f"{settings.robot_summary}")
        return {"FINISHED"}


__all__ = ["BLISKCAM_OT_export_robot", "RobotModal", "RobotPlanJob", "infeasible_message",
           "plan_summary", "robot_name"]
