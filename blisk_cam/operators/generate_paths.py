"""``blisk_cam.generate_paths``: scene settings → ``core.pipeline`` → path objects.

Interactively (invoke with a window) it runs as a modal operator driven by a timer: each tick
advances ``core.pipeline.iter_plan_paths`` for a short time slice, the status bar shows the
progress, ESC cancels and leaves the previous result as it was (the new objects are only
built once the path is complete). In background mode, or called with EXEC_DEFAULT, it runs
synchronously. After planning, ``core.verify.verify_path`` measures the path (when the
``verify`` setting is on) and :func:`blisk_cam.output.write_path_objects` replaces the blade's
output collection.
"""

from __future__ import annotations

import time

import bpy
import numpy as np

from ..core.errors import BliskCamError
from ..core.mesh import input_vertex_values
from .common import (
    blade_axis,
    blade_problem,
    cones_problem,
    path_request,
    read_blade,
    report_exception,
    resolve_blade,
    settings_cones,
)

#: names of scenes with a modal generation running (names, never bpy objects)
_RUNNING: set[str] = set()
#: the core's warnings about a path beyond this many are only counted in the summary
MAX_WARNING_REPORTS = 3


class PathJob:
    """One generation: inputs read from the scene up front, then planned step by step.

    Holds arrays and names only (no bpy objects across steps: undo or deletion while a modal
    run is going must not leave dangling references).
    """

    def __init__(self, context):
        from ..core.mesh import TriMesh
        from ..core.pipeline import iter_plan_paths

        settings = context.scene.blisk_cam
        problem = blade_problem(context) or cones_problem(settings)
        if problem:
            raise BliskCamError(problem)
        blade = resolve_blade(context)
        self.scene_name = context.scene.name
        self.blade_name = blade.name
        self.set_blade = settings.blade is None
        axis = blade_axis(settings, blade)
        cone1, cone2 = settings_cones(settings)
        self.V, self.F = read_blade(context, blade)
        self.mesh = TriMesh.from_arrays(self.V, self.F)
        self.request = path_request(settings, axis, cone1, cone2)
        self.want_verify = bool(settings.verify)
        self.want_map = bool(settings.verify_map) and self.want_verify
        self.fraction = 0.0
        self.message = "starting"
        self.plan = None
        self.verify = None
        self.warnings = []
        self.verdict = None  # core.verdict.Verdict once verified
        self.t0 = time.perf_counter()
        self._it = iter_plan_paths(self.mesh, self.request)

    @property
    def planned(self) -> bool:
        return self.plan is not None

    def step(self, budget: float = 0.1) -> bool:
        """Advance the planning for about ``budget`` seconds (at least one step). True once
        the path is planned."""
        t_end = time.perf_counter() + budget
        while self.plan is None:
            try:
                progress = next(self._it)
            except StopIteration as stop:
                self.plan = stop.value
                self.fraction, self.message = 1.0, "planned"
                break
            self.fraction = float(getattr(progress, "fraction", self.fraction))
            self.message = str(getattr(progress, "message", ""))
            if time.perf_counter() >= t_end:
                break
        return self.plan is not None

    def run_verify(self):
        """Measure the planned path (when asked)."""
        if self.want_verify and self.verify is None:
            from ..core.verify import verify_path

            self.verify = verify_path(self.mesh, self.plan.path)

    def finish(self, context) -> str:
        """Write the objects and statistics; returns the summary for the report."""
        from .. import output

        scene = context.scene
        settings = scene.blisk_cam
        blade = bpy.data.objects.get(self.blade_name)
        if blade is None:
            raise BliskCamError(
                f"the blade '{self.blade_name}' was deleted or renamed while the paths were "
                "generated; generate again"
            )
        path = self.plan.path
        values = None
        if self.want_map and self.verify is not None:
            values = input_vertex_values(self.mesh, self.V, self.verify.vertex_values)
        json_text = None
        self.verdict = None
        if self.verify is not None:  # the verdict goes into the paths JSON ("verify")
            import json

            from ..core.paths_io import path_to_dict
            from ..core.verdict import judge, verdict_dict

            self.verdict = judge(self.verify, path.cusp, path.chord, path.tool, path=path)
            json_text = json.dumps({**path_to_dict(path), "verify": verdict_dict(self.verdict)},
                                   allow_nan=False)
        output.write_path_objects(
            scene, blade, path, settings,
            json_text=json_text,
            verify=self.verify,
            blade_arrays=(self.V, self.F) if values is not None else None,
            vertex_values=values,
        )
        if self.set_blade:
            settings.blade = blade
        fit = self.plan.fit
        if fit is not None:
            settings.fit_residual1, settings.fit_residual2 = fit.residual1, fit.residual2
        store_statistics(settings, blade.name, path, self.verify, time.perf_counter() - self.t0)
        self.warnings = self.plan.warnings  # the generator's and the planning's
        if self.verdict is not None and not self.verdict.passed:
            from ..core.verdict import verdict_lines

            self.warnings = [*self.warnings, " ".join(x.strip() for x in verdict_lines(
                self.verdict)[:3])]
        return summary(settings)

    def run(self, context) -> str:
        """Everything, synchronously."""
        while not self.step(1e9):
            pass
        self.run_verify()
        return self.finish(context)


def store_statistics(settings, blade_name, path, verify, seconds):
    """Statistics of the result on the settings (saved in the .blend, shown by the panel)."""
    settings.has_result = True
    settings.stat_blade = blade_name
    settings.stat_curves = len(path.curves)
    settings.stat_passes = int(path.stats.get("passes", len(path.levels)))
    settings.stat_poses = path.n_poses
    settings.stat_length = path.length()
    program = getattr(path, "program", None)
    link = rapid = 0.0
    if program is not None and len(program):
        from ..output import MOVE_CUT, MOVE_RAPID, MOVE_TYPES

        feed_links = [k for k in range(len(MOVE_TYPES)) if k not in (MOVE_CUT, MOVE_RAPID)]
        link, rapid = program.length(feed_links), program.length([MOVE_RAPID])
    settings.stat_link_length, settings.stat_rapid_length = link, rapid
    settings.stat_warnings = len(path.stats.get("warnings", []) or []) + len(
        getattr(path, "warnings", []) or []
    )
    settings.stat_seconds = seconds
    cusps = [c for c in path.stats.get("measured_cusp", []) if np.isfinite(c)]
    settings.stat_cusp = max(cusps) if cusps else 0.0
    settings.stat_verified = verify is not None
    if verify is not None:
        left, gouge = float(verify.max_material_left), float(verify.max_gouge)
        settings.stat_material_left = left if np.isfinite(left) else 0.0
        settings.stat_gouge = gouge if np.isfinite(gouge) else 0.0
    else:
        settings.stat_material_left = settings.stat_gouge = 0.0


def summary(settings) -> str:
    """One line: counts, length, time and the measured figures."""
    text = (
        f"{settings.stat_passes} passes, {settings.stat_curves} curves, "
        f"{settings.stat_poses} poses, {settings.stat_length:.1f} mm of path "
        f"in {settings.stat_seconds:.1f} s"
    )
    if settings.stat_warnings:
        text += f"; {settings.stat_warnings} warning(s)"
    if settings.stat_verified:
        text += (
            f"; measured max material left {settings.stat_material_left:.4f} mm, "
            f"max gouge {settings.stat_gouge:.4f} mm"
        )
    return text


class BLISKCAM_OT_generate_paths(bpy.types.Operator):
    """Generate the finishing tool paths between the two cones (ESC cancels)"""

    bl_idname = "blisk_cam.generate_paths"
    bl_label = "Generate Paths"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        settings = getattr(context.scene, "blisk_cam", None)
        problem = blade_problem(context) or (settings is not None and cones_problem(settings))
        if not problem and context.scene.name in _RUNNING:
            problem = "Paths are being generated (ESC cancels)"
        if problem:
            cls.poll_message_set(problem)
            return False
        return True

    def execute(self, context):
        try:
            job = PathJob(context)
            text = job.run(context)
        except Exception as exc:
            return report_exception(self, exc)
        self._report_done(job, text)
        return {"FINISHED"}

    def _report_done(self, job, text):
        for w in job.warnings[:MAX_WARNING_REPORTS]:
            self.report({"WARNING"}, w)
        self.report({"INFO"}, text)

    # --- modal ---------------------------------------------------------------------------
    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = PathJob(context)
        except Exception as exc:
            return report_exception(self, exc)
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.05, window=context.window)
        wm.modal_handler_add(self)
        wm.progress_begin(0, 100)
        _RUNNING.add(self._job.scene_name)
        self._status(context, "reading the mesh")
        return {"RUNNING_MODAL"}

    def _status(self, context, text):
        if context.workspace is not None:
            context.workspace.status_text_set(f"Blisk CAM: {text} — ESC to cancel")

    def _end(self, context):
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        _RUNNING.discard(self._job.scene_name)

    def modal(self, context, event):
        job = self._job
        if event.type == "ESC":
            self._end(context)
            self.report({"WARNING"}, "Path generation cancelled; the previous paths are kept")
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            if not job.planned:
                job.step(0.15)
                context.window_manager.progress_update(int(90 * job.fraction))
                self._status(context, f"{int(100 * job.fraction)} % — {job.message}")
                if job.planned and job.want_verify:
                    self._status(context, "verifying the path")
                return {"RUNNING_MODAL"}
            job.run_verify()
            context.window_manager.progress_update(95)
            text = job.finish(context)
        except Exception as exc:
            self._end(context)
            return report_exception(self, exc)
        self._end(context)
        self._report_done(job, text)
        return {"FINISHED"}

    def cancel(self, context):
        self._end(context)
