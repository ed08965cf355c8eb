"""``blisk_cam.per_blade_paths`` and ``blisk_cam.load_blade_results``: every blade of a
whole-blisk scan gets its own path, run here or read back from a run made elsewhere.

Per-Blade Paths reads the scan object (the Per-Blade panel's Scan, else the active object) as
arrays (world frame, mm; the object is never modified) and runs the core per-blade process
on it (:mod:`..core.process.per_blade`, no Dask: the batch front end is the command line's):
the part model splits hub and blades (Blade Count of the scene, 0: found from the scan's
rotational symmetry), and each blade is fitted, planned with the path options of the panels
above (tool, cusp, chord, lead/tilt, …), checked for collisions against its *scanned*
neighbours (Neighbours per side; mode Off checks) and, with Verify on, verified against its
own faces. A blade that fails is reported by number with the reason and never stops the
others. Interactively it runs modal (:class:`.modal_job.ModalJobOperator`): the blades are
planned on a worker thread, the status bar shows "blade k of N", ESC stops the worker (within
the blade it is planning) and keeps the previous result; in background mode or with
EXEC_DEFAULT synchronously. The result: one output collection per blade that passed
(:mod:`..blender.per_blade_objects`, "Blade k").

Load Results reads the job folder a per-blade batch run wrote (``python -m blisk_cam batch``
with a ``blades`` job, on a cluster or ``--serial``: ``blades.csv`` and ``blade_<k>.json``,
:func:`..core.process.blade_results.read_blade_results`) and shows it the same way.
"""

from __future__ import annotations

import dataclasses
import threading
import time

import bpy

from ..blender.settings import group_values, path_request
from ..core.collision.options import DEFAULT_CHECK_MODE, CollisionOptions
from ..core.errors import BliskCamError
from ..core.runtime import on_one_blas_thread
from .common import blade_axis, report_exception
from .modal_job import ModalJobOperator

#: names of scenes with a modal per-blade run
_RUNNING: set[str] = set()


def scan_object(context):
    """The Per-Blade panel's Scan, or the active object while it is empty (or None)."""
    settings = getattr(context.scene, "blisk_cam", None)
    scan = settings.per_blade_scan if settings is not None else None
    return scan if scan is not None else getattr(context, "active_object", None)


def scan_problem(context) -> str | None:
    """Why no scan can be read, in words the user can act on (None: fine). Cheap (poll)."""
    if getattr(context.scene, "blisk_cam", None) is None:
        return "Blisk CAM settings are missing: enable the Blisk CAM add-on"
    scan = scan_object(context)
    if scan is None:
        return "No scan: choose the whole-blisk mesh in the Per-Blade Paths panel (or make it "\
               "active)"
    if scan.type != "MESH":
        return f"'{scan.name}' is a {scan.type.lower()} object, not a mesh: choose the " \
               "whole-blisk scan mesh"
    if len(scan.data.polygons) == 0 and len(scan.modifiers) == 0:
        return f"'{scan.name}' has no faces: the scan must be a surface mesh"
    return None


def _collision_options(settings) -> CollisionOptions:
    """The collision options of the settings for one blade against its scanned neighbours:
    mode Off checks; the blade count is the split's (set per blade by the core); Avoid stays
    inside the Machine & NC panel's machine's reach (as Check Collisions)."""
    from ..core.tool.assembly import AssemblyError, holder_profile

    values = group_values(settings, CollisionOptions)
    if values.get("mode", "off") == "off":
        values["mode"] = DEFAULT_CHECK_MODE
    values["blade_count"] = max(2, int(values.get("blade_count") or 2))
    text = (settings.holder or "").strip()
    if text:
        try:
            values["holder"] = holder_profile(text, "Holder")
        except AssemblyError as exc:
            raise BliskCamError(str(exc)) from None
    options = CollisionOptions(**values)
    if options.mode == "avoid":
        from ..core.machine.description import load_machine
        from .export_nc import nc_machine

        options = dataclasses.replace(options, machine=load_machine(nc_machine(settings)))
    return options


class PerBladeJob:
    """One per-blade run: inputs read from the scene up front (arrays and names only, no bpy
    objects across steps), the blades planned by :meth:`work` (no bpy: the worker thread)."""

    def __init__(self, context):
        from ..blender.objects import object_to_arrays

        problem = scan_problem(context)
        if problem:
            raise BliskCamError(problem)
        settings = context.scene.blisk_cam
        scan = scan_object(context)
        self.scene_name = context.scene.name
        self.scan_name = scan.name
        axis = blade_axis(settings, scan)
        self.request = path_request(settings, axis, None, None)  # cones fitted per blade
        self.collision = _collision_options(settings)
        self.blade_count = int(settings.blade_count) or None  # 0: from the symmetry
        self.neighbours = int(settings.neighbours)
        self.verify = bool(settings.verify)
        self.V, self.F = object_to_arrays(scan, context.evaluated_depsgraph_get())
        self.fraction, self.message = 0.0, "splitting the scan"
        self.outcomes = []
        self.total = None  # N once split
        self.notes = []  # warnings for the report (neighbours clamped, …)
        self.done = False
        self.t0 = time.perf_counter()
        self._thread = self._cancel = self._error = None

    def work(self, cancel: threading.Event | None = None):
        """Split the scan and plan every blade in turn (stops once ``cancel`` is set: between
        blades, and inside one at its next chunk of work). Writes ``outcomes``, ``fraction``,
        ``message``; sets ``done`` at the end (not when cancelled)."""
        from ..core.part.model import split_blisk_mesh
        from ..core.process.per_blade import blades_of_scan, plan_blade
        from ..core.runtime import cancellable

        split = split_blisk_mesh(self.V, self.F, self.blade_count, self.request.axis)
        n = self.total = int(split.blade_count)
        j = min(self.neighbours, (n - 1) // 2)
        if j != self.neighbours:
            self.notes.append(f"{n} blades allow {j} neighbour(s) per side, not "
                              f"{self.neighbours}: checked {j}")
        blades = blades_of_scan(self.V, self.F, split, j)
        collision = dataclasses.replace(self.collision, blade_count=max(2, n), neighbours=j)
        for b in blades:
            if cancel is not None and cancel.is_set():
                return
            self.message = f"blade {b.index + 1} of {n}"
            with cancellable(cancel, f"planning blade {b.index}"):
                self.outcomes.append(plan_blade(b, self.request, collision,
                                                verify=self.verify))
            self.fraction = len(self.outcomes) / n
        self.done = True

    # --- on a worker thread (interactive) -----------------------------------------------
    def poll(self, wait: float = 0.02) -> bool:
        """Run :meth:`work` on a worker thread (started by the first call); wait up to
        ``wait`` s; True once every blade is planned. The worker's error is raised here."""
        if self._thread is None:
            cancel = self._cancel = threading.Event()

            def run():
                try:
                    self.work(cancel)
                except BaseException as exc:  # handed to the main thread, raised there
                    self._error = exc

            self._thread = threading.Thread(target=on_one_blas_thread(run),
                                            name="blisk_cam per blade", daemon=True)
            self._thread.start()
        self._thread.join(wait)
        if self._error is not None and not (self._cancel is not None and self._cancel.is_set()):
            raise self._error
        return self.done and not self._thread.is_alive()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the worker has finished (tests); True if it has."""
        if self._thread is not None:
            self._thread.join(timeout)
        return self._thread is not None and not self._thread.is_alive()

    def cancel(self):
        """Stop the worker (ESC, Blender ending the run)."""
        if self._cancel is not None:
            self._cancel.set()

    # --- writing --------------------------------------------------------------------------
    def finish(self, context) -> list[tuple[str, str]]:
        """Write the blades' objects; the reports [(kind, text)]."""
        from ..blender.per_blade_objects import write_per_blade

        summary = write_per_blade(context.scene, self.scan_name, self.outcomes)
        return result_reports(summary, self.notes, time.perf_counter() - self.t0)

    def run(self, context):
        self.work()
        return self.finish(context)


def result_reports(summary: dict, notes=(), seconds: float | None = None):
    """[(kind, text)]: a warning per failed blade (its reason), then the one-line summary."""
    out = [("WARNING", n) for n in notes]
    out += [("WARNING", reason) for _, reason in summary["failed"]]
    shown = summary["shown"]
    text = (f"{len(shown)} of {summary['blade_count']} blades with paths"
            + (f" (blades {', '.join(map(str, shown))})" if shown else ""))
    if summary["failed"]:
        text += f"; failed: blade(s) {', '.join(str(k) for k, _ in summary['failed'])}"
    if seconds is not None:
        text += f" in {seconds:.1f} s"
    out.append(("INFO", text))
    return out


class BLISKCAM_OT_per_blade_paths(ModalJobOperator, bpy.types.Operator):
    """Plan, check and verify every blade of a whole-blisk scan from its own faces, one path
    per blade (ESC cancels)"""

    bl_idname = "blisk_cam.per_blade_paths"
    bl_label = "Per-Blade Paths"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    status_label = "Blisk CAM per blade"
    cancel_text = "Per-blade run cancelled; the previous result is kept"
    start_text = "splitting the scan"

    busy_text = "The blades are being planned (ESC cancels)"

    @classmethod
    def problem(cls, context):
        return scan_problem(context)

    def execute(self, context):
        try:
            reports = PerBladeJob(context).run(context)
        except Exception as exc:
            return report_exception(self, exc)
        for kind, text in reports:
            self.report({kind}, text)
        return {"FINISHED"}

    # --- modal (ModalJobOperator) ----------------------------------------------------------
    def new_job(self, context):
        return PerBladeJob(context)

    def tick(self, context):
        job = self._job
        if not job.poll():
            context.window_manager.progress_update(int(95 * job.fraction))
            self._status(context, f"{int(100 * job.fraction)} % — {job.message}")
            return None
        for kind, text in job.finish(context):
            self.report({kind}, text)
        return {"FINISHED"}

    def end_job(self, context):
        self._job.cancel()  # ESC or an error: the worker stops


class BLISKCAM_OT_load_blade_results(bpy.types.Operator):
    """Show the per-blade paths a batch run wrote (blades.csv and blade_<k>.json of its job
    folder), one collection per blade"""

    bl_idname = "blisk_cam.load_blade_results"
    bl_label = "Load Results"
    bl_options = {"REGISTER", "UNDO"}

    directory: bpy.props.StringProperty(
        name="Folder", subtype="DIR_PATH", default="",
        description="Job folder of a per-blade run (empty: the panel's Results Folder)")

    @classmethod
    def poll(cls, context):
        if getattr(context.scene, "blisk_cam", None) is None:
            cls.poll_message_set("Blisk CAM settings are missing: enable the Blisk CAM add-on")
            return False
        return True

    def execute(self, context):
        from ..blender.per_blade_objects import write_per_blade
        from ..core.process.blade_results import find_results_folder, read_blade_results

        folder = self.directory or context.scene.blisk_cam.per_blade_folder
        try:
            if not folder:
                raise BliskCamError("No results folder: choose the job folder of a per-blade "
                                    "run (blades.csv, blade_<k>.json)")
            root = find_results_folder(bpy.path.abspath(folder))
            outcomes = read_blade_results(root)
            summary = write_per_blade(context.scene, root.name, outcomes)
        except Exception as exc:
            return report_exception(self, exc)
        for kind, text in result_reports(summary):
            self.report({kind}, text)
        return {"FINISHED"}
