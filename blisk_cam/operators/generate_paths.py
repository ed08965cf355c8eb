"""``blisk_cam.generate_paths``: scene settings → ``core.process.blade_finish`` → path objects.

Interactively (invoke with a window) it runs as a modal operator driven by a timer
(:class:`.modal_job.ModalJobOperator`): the weld and ``core.process.blade_finish.iter_plan_paths``
run on a worker thread (arrays only, no ``bpy``), each tick only polls it (waiting a few
milliseconds at most, so the UI never freezes for a planning step) and the status bar shows
the progress; ESC while planning stops the worker at its next step and leaves the previous
result as it was (the new objects are only built once the path is complete). As soon as the
path is planned its objects (curves, poses, empties, cones) replace the previous ones; with
the ``verify`` setting on, ``core.verify.verify_path`` then measures the path on another
worker thread while the UI stays free (that worker first makes the paths JSON, which the
next tick stores: the objects do not wait for it; ESC or any end stores it too), the panel
shows "Verifying…", and the timer attaches the figures when they are ready: the verdict in
the paths JSON, the measured cusp per curve, the statistics and (``verify_map``) the
colour-map copy of the blade
(:func:`blisk_cam.blender.path_objects.attach_verify`). The colour map comes first: the
worker hands the material left over as soon as it is measured (``verify_path``'s
``on_material_left``, before the scallops, a third of verify) and the next tick shows it
(:func:`~blisk_cam.blender.path_objects.show_verify_map`; the same values the report then
holds). ESC while verifying, or a new Generate, drops the pending figures (and a colour map
already shown) and stops the worker at its next chunk of points (``verify_path``'s cancel
hook): the new paths stay, without verify figures or a colour map.

In background mode, or called with EXEC_DEFAULT, it runs synchronously (plan, verify, then
one :func:`blisk_cam.blender.path_objects.write_path_objects` with everything): the same objects
and JSON as the interactive run once its verify is attached.
"""

from __future__ import annotations

import threading
import time

import bpy

from ..blender.path_objects import paths_json_text, text_lines
from ..blender.settings import path_request, settings_cones, store_statistics, summary
from ..core.errors import BliskCamError
from ..core.geometry.weld import input_vertex_values
from ..core.runtime import on_one_blas_thread, parallel
from .common import (
    blade_axis,
    blade_problem,
    cones_problem,
    read_blade,
    report_exception,
    resolve_blade,
)
from .modal_job import ModalJobOperator

#: names of scenes with a modal generation planning (names, never bpy objects)
_RUNNING: set[str] = set()
#: scene name → the job whose paths are shown and whose verify is still running
_VERIFYING: dict[str, PathJob] = {}
#: the core's warnings about a path beyond this many are only counted in the summary
MAX_WARNING_REPORTS = 3


class PathJob:
    """One generation: inputs read from the scene up front, then planned step by step.

    Holds arrays and names only (no bpy objects across steps: undo or deletion while a modal
    run is going must not leave dangling references).
    """

    def __init__(self, context):
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
        self.mesh = None  # welded by the first planning step (on the worker, interactively)
        self.request = path_request(settings, axis, cone1, cone2)
        self.want_verify = bool(settings.verify)
        self.want_map = bool(settings.verify_map) and self.want_verify
        self.fraction = 0.0
        self.message = "starting"
        self.plan = None
        self.verify = None
        self.warnings = []
        self.verdict = None  # core.verify.verdict.Verdict once verified
        # the interactive verify on a worker thread (start_verify … attach_verify)
        self._thread = None
        self._cancel = None  # threading.Event of the running worker
        self._verify_result = self._verify_error = None
        self.verify_cancelled = False
        # the colour-map values the worker hands over before its last steps, and whether
        # show_map showed them (attach_verify then keeps that map)
        self._early_values = self._news = None
        self.map_shown = False
        self.written_json = None  # the paths JSON stored for the shown paths
        self.paths_json = None  # the planned path's JSON (without verify), by the plan worker
        self._paths_text = None  # its (Text content, stored form): path_objects.text_lines
        self.paths_seconds = None  # seconds from the start until the paths were shown
        self.verify_seconds = None  # seconds the worker took
        # the interactive planning on a worker thread (poll_plan)
        self._plan_thread = self._plan_cancel = self._plan_error = None
        self.t0 = time.perf_counter()
        self._it = None  # core.process.blade_finish.iter_plan_paths, made by the first step

    @property
    def planned(self) -> bool:
        return self.plan is not None

    def step(self, budget: float = 0.1, cancel: threading.Event | None = None) -> bool:
        """Advance the planning on this thread for about ``budget`` seconds (at least one
        step; none once ``cancel`` is set). True once the path is planned."""
        if self._it is None:
            from ..core.geometry.mesh import TriMesh
            from ..core.process.blade_finish import iter_plan_paths

            self.mesh = TriMesh.from_arrays(self.V, self.F)
            self._it = iter_plan_paths(self.mesh, self.request)
        t_end = time.perf_counter() + budget
        while self.plan is None and not (cancel is not None and cancel.is_set()):
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

    # --- planning on a worker thread (interactive) ---------------------------------------
    def poll_plan(self, wait: float = 0.02) -> bool:
        """Plan on a worker thread (started by the first call); wait up to ``wait`` seconds
        for it and return True once the path is planned. The worker's error (a bad mesh, a
        path that cannot be planned) is raised here, on the main thread.

        The worker runs :meth:`step` to the end: it reads this job's arrays and request and
        writes ``mesh``, ``plan``, ``fraction``, ``message`` (or ``_plan_error``); no ``bpy``.
        """
        if self._plan_thread is None:
            cancel = self._plan_cancel = threading.Event()

            def work():
                try:
                    # the compiled kernels on every core, as verify does (the same answers)
                    with parallel(None):
                        done = self.step(float("inf"), cancel)
                    if done and not self.want_verify:  # the JSON too: less on the UI thread
                        self._make_json()  # (with verify: the verify worker, once shown)
                except BaseException as exc:  # handed to the main thread, raised there
                    self._plan_error = exc

            self._plan_thread = threading.Thread(target=on_one_blas_thread(work),
                                                 name="blisk_cam plan",
                                                 daemon=True)
            self._plan_thread.start()
        self._plan_thread.join(wait)
        if self._plan_error is not None:
            raise self._plan_error
        return self.plan is not None and not self._plan_thread.is_alive()

    def wait_plan(self, timeout: float | None = None) -> bool:
        """Block until the planning worker has finished (tests, bench); True if it has."""
        if self._plan_thread is not None:
            self._plan_thread.join(timeout)
        return self._plan_thread is not None and not self._plan_thread.is_alive()

    def cancel_plan(self):
        """Stop the planning worker at its next step (ESC, Blender ending the run)."""
        if self._plan_cancel is not None:
            self._plan_cancel.set()

    def run_verify(self):
        """Measure the planned path (when asked), on this thread."""
        if self.want_verify and self.verify is None:
            from ..core.verify.measure import verify_path

            self.verify = verify_path(self.mesh, self.plan.path)

    # --- verify on a worker thread (interactive) ---------------------------------------
    def start_verify(self) -> bool:
        """Start measuring the planned path on a worker thread; False when verify is off.

        The thread reads only this job's arrays (``mesh``, ``V``, the planned ``ToolPath``)
        and writes only ``_verify_result`` (report, verdict, paths JSON, colour-map values,
        Text content and the tail appended to the shown JSON) / ``_verify_error``: no
        ``bpy``. The main thread polls :attr:`verify_ready` and then calls
        :meth:`attach_verify`, which only writes the Blender data."""
        if not self.want_verify or self.plan is None:
            return False
        from ..core.verify.measure import verify_path

        mesh, path = self.mesh, self.plan.path
        cancel = self._cancel = threading.Event()  # set by cancel_verify: the worker stops

        early = self.material_left_measured

        def work():
            t0 = time.perf_counter()
            try:
                if self._paths_text is None:  # the shown paths' JSON first (store_text)
                    self._make_json()
                    self._news.set()
                report = verify_path(mesh, path, cancel=cancel, on_material_left=early)
                # the rest of the figures too (pure core), so attaching is only bpy work
                verdict, json_text = self._verdict_json(report)
                values = self._early_values  # the report's vertex_values, mapped already
                if values is None:
                    values = self._map_values(report)
                # the shown JSON with the verdict appended: only its end is rewritten (the
                # whole Text's content is made only when not)
                head = self.paths_json[:-1] if self.paths_json else None
                tail = json_text[len(head):] if head and json_text.startswith(head) else None
                self._verify_result = (report, verdict, json_text, values,
                                       None if tail else text_lines(json_text)[0], tail)
            except BaseException as exc:  # handed to the main thread, reported there
                self._verify_error = exc
            self.verify_seconds = time.perf_counter() - t0
            self._news.set()

        self._verify_result = self._verify_error = self._early_values = None
        self.verify_cancelled = self.map_shown = False
        self._news = threading.Event()  # set by the worker: the map's values, then its end
        self._thread = threading.Thread(target=on_one_blas_thread(work), name="blisk_cam verify",
                                        daemon=True)
        self._thread.start()
        return True

    def _make_json(self):
        """The planned path's JSON and its Text content (no bpy: the workers make them)."""
        lines = text_lines(js := paths_json_text(self.plan.path))
        self.paths_json = js
        self._paths_text = lines

    def store_text(self) -> bool:
        """Store the shown paths' JSON (:func:`~blisk_cam.blender.path_objects.store_paths_text`)
        once the verify worker has made it (its first step); True when stored now. Main
        thread (bpy)."""
        if self.written_json is not None or self._paths_text is None:
            return False
        from ..blender import path_objects as output

        if output.store_paths_text(self.blade_name, self._paths_text[0]) is None:
            return False  # the output is gone or replaced: attach_verify says so
        self.written_json = self._paths_text[1]
        return True

    def ensure_text(self):
        """The shown paths' JSON stored now, made here if the worker has not made it (a verify
        dropped, stopped or failed before): the paths are never left without their JSON."""
        if self.paths_seconds is None or self.written_json is not None:
            return
        if self._paths_text is None:
            try:
                self._make_json()
            except ValueError:  # not JSON (a non-finite value): the worker failed on it too
                return  # and attach_verify reports its error; the objects stay without JSON
        self.store_text()

    def material_left_measured(self, vertex_values):
        """The worker's ``on_material_left``: keep the colour map's values (per input vertex)
        for :meth:`show_map`. No bpy."""
        if self.want_map:
            self._early_values = input_vertex_values(self.mesh, self.V, vertex_values)
            self._news.set()

    def wait_news(self, wait: float):
        """Wait up to ``wait`` seconds for the worker's news (the colour map's values, its
        end): a tick acts on it at once instead of at the next timer event."""
        if self._news is not None and self._news.wait(wait):
            self._news.clear()

    @property
    def verify_pending(self) -> bool:
        """A verify was started, is not cancelled and its figures are not attached yet."""
        return (getattr(self, "_thread", None) is not None and not self.verify_cancelled
                and self.verify is None)

    @property
    def verify_ready(self) -> bool:
        """The worker has finished (with figures or an error)."""
        t = getattr(self, "_thread", None)
        return t is not None and not t.is_alive()

    def wait_verify(self, timeout: float | None = None) -> bool:
        """Block until the worker has finished (tests, bench, background); True if it has."""
        t = getattr(self, "_thread", None)
        if t is not None:
            t.join(timeout)
        return self.verify_ready

    def cancel_verify(self):
        """Drop the pending figures: they are never attached, and the worker stops at its
        next chunk of points (``verify_path``'s cancel hook; it ends with
        ``core.runtime.Cancelled`` in ``_verify_error`` and no result). A colour map shown
        already (:meth:`show_map`) is removed: the paths stay without any verify figure.
        Main thread (bpy)."""
        self.verify_cancelled = True
        if getattr(self, "_cancel", None) is not None:
            self._cancel.set()
        if _VERIFYING.get(self.scene_name) is self:
            del _VERIFYING[self.scene_name]
        self._drop_map()
        self.ensure_text()

    def show_map(self, context) -> bool:
        """Show the colour map as soon as the worker has handed its values over (the
        material left is measured; the scallops are not), if the shown paths are still this
        job's; True when it did now. Main thread (bpy)."""
        values = self._early_values
        if values is None or self.map_shown or self.verify_cancelled or not self._ours():
            return False
        from ..blender import path_objects as output

        output.show_verify_map(context.scene, self._blade(), self.plan.path, (self.V, self.F),
                               values)
        self.map_shown = True
        return True

    def _ours(self) -> bool:
        """The blade's output is still the one :meth:`show_paths` wrote."""
        from ..blender import path_objects as output

        return (self.written_json is not None
                and output.stored_paths_json(self.blade_name) == self.written_json)

    def _drop_map(self):
        """Remove the colour map :meth:`show_map` showed (while the paths are this job's)."""
        if getattr(self, "map_shown", False):
            self.map_shown = False
            if self._ours():
                from ..blender import path_objects as output

                output.remove_verify_map(self.blade_name)

    # --- writing ------------------------------------------------------------------------
    def _verdict_json(self, report):
        """(verdict, paths JSON with the "verify" verdict) of the path measured by
        ``report`` (core.verify.VerifyReport). No bpy: the worker thread calls it."""
        import json

        from ..core.toolpath.paths_io import path_to_dict
        from ..core.verify.verdict import judge, verdict_dict

        path = self.plan.path
        verdict = judge(report, path.cusp, path.chord, path.tool, path=path)
        verify = verdict_dict(verdict)
        head = self.paths_json
        if path.verify is None and head is not None and head.endswith("}") and len(head) > 2:
            # the planned path's JSON, made already, with "verify" appended: json.dumps of
            # the merged dict gives these very bytes (a key new to the dict goes last; a
            # nested value is written as on its own), without writing the path again
            return verdict, f'{head[:-1]}, "verify": {json.dumps(verify, allow_nan=False)}}}'
        return verdict, json.dumps({**path_to_dict(path), "verify": verify}, allow_nan=False)

    def _blade(self):
        blade = bpy.data.objects.get(self.blade_name)
        if blade is None:
            raise BliskCamError(
                f"the blade '{self.blade_name}' was deleted or renamed while the paths were "
                "generated; generate again"
            )
        return blade

    def _map_values(self, report):
        """(n,) material left per input vertex for the colour map, or None (not asked)."""
        if self.want_map and report is not None:
            return input_vertex_values(self.mesh, self.V, report.vertex_values)
        return None

    def _warnings(self):
        warnings = list(self.plan.warnings)  # the generator's and the planning's
        if self.verdict is not None and not self.verdict.passed:
            from ..core.verify.verdict import verdict_lines

            warnings.append(" ".join(x.strip() for x in verdict_lines(self.verdict)[:3]))
        return warnings

    def finish(self, context, defer_text: bool = False) -> str:
        """Write the objects and statistics (with the verify figures, if measured); returns
        the summary for the report. ``defer_text``: the paths JSON stored later
        (:meth:`store_text`)."""
        from ..blender import path_objects as output

        scene = context.scene
        settings = scene.blisk_cam
        blade = self._blade()
        path = self.plan.path
        values = self._map_values(self.verify)
        json_text, text = self.paths_json, self._paths_text
        self.verdict = None
        if self.verify is not None:  # the verdict goes into the paths JSON ("verify")
            self.verdict, json_text = self._verdict_json(self.verify)
            text = None
        output.write_path_objects(
            scene, blade, path, settings,
            json_text=json_text,
            verify=self.verify,
            blade_arrays=(self.V, self.F) if values is not None else None,
            vertex_values=values,
            text=None if text is None else text[0],
            defer_text=defer_text,
        )
        if self.set_blade:
            settings.blade = blade
        fit = self.plan.fit
        if fit is not None:
            settings.fit_residual1, settings.fit_residual2 = fit.residual1, fit.residual2
        store_statistics(settings, blade.name, path, self.verify, time.perf_counter() - self.t0,
                         self.verdict)
        self.warnings = self._warnings()
        return summary(settings)

    def show_paths(self, context) -> str:
        """Write the planned path's objects now, without verify figures; returns the summary
        of the paths (:meth:`begin_verify` then starts the verify worker)."""
        from ..blender import path_objects as output

        # self.verify is None: the paths without figures; with verify, their JSON too is
        # made by the verify worker (its first step) and stored by a later tick (store_text)
        defer = self._paths_text is None and self.want_verify
        text = self.finish(context, defer_text=defer)
        if not defer:
            self.written_json = (self._paths_text[1] if self._paths_text is not None
                                 else output.stored_paths_json(self.blade_name))
        self.paths_seconds = time.perf_counter() - self.t0
        # the worker starts after the writing: while this thread writes (bpy calls holding
        # the GIL) a verify worker would take every other GIL turn and stretch this tick
        # 2-6× (measured on Rotor 37) for a gain of this tick's length at most
        return text

    def begin_verify(self) -> bool:
        """:meth:`start_verify` and list the job as the scene's pending verify."""
        if self.start_verify():
            _VERIFYING[self.scene_name] = self
            return True
        return False

    def attach_verify(self, context) -> str:
        """Attach the worker's figures to the shown paths (main thread); returns the summary.

        Raises BliskCamError when the verify failed, or when the blade's output is no longer
        the one :meth:`show_paths` wrote (cleared, regenerated or rewritten by a collision
        check in the meantime): the figures would then describe another path."""
        from ..blender import path_objects as output

        if _VERIFYING.get(self.scene_name) is self:
            del _VERIFYING[self.scene_name]
        if self._verify_error is not None:
            self._drop_map()
            self.ensure_text()
            raise self._verify_error
        blade = self._blade()
        if not self._ours():
            raise BliskCamError(
                f"the paths of '{self.blade_name}' changed while they were being verified; "
                "the verify figures were dropped (generate again to verify)"
            )
        self.verify, self.verdict, json_text, values, lines, tail = self._verify_result
        self._verify_result = None
        path = self.plan.path
        scene = context.scene
        settings = scene.blisk_cam
        output.attach_verify(
            scene, blade, path, settings,
            json_text=json_text,
            verify=self.verify,
            # the map shown early holds these values already (the same array)
            blade_arrays=(self.V, self.F) if values is not None and not self.map_shown
            else None,
            vertex_values=values,
            text=lines,
            tail=tail,
        )
        store_statistics(settings, blade.name, path, self.verify, time.perf_counter() - self.t0,
                         self.verdict)
        self.warnings = self._warnings()
        return summary(settings)

    def run(self, context) -> str:
        """Everything, synchronously."""
        while not self.step(1e9):
            pass
        self.run_verify()
        return self.finish(context)


def verify_pending(scene_name: str) -> bool:
    """True while the paths of the scene are shown and their verify is still running."""
    job = _VERIFYING.get(scene_name)
    return job is not None and job.verify_pending


def cancel_pending_verify(scene_name: str) -> bool:
    """Drop the scene's pending verify (a new generation starts); True if there was one."""
    job = _VERIFYING.pop(scene_name, None)
    if job is None:
        return False
    job.cancel_verify()
    return True


class BLISKCAM_OT_generate_paths(ModalJobOperator, bpy.types.Operator):
    """Generate the finishing tool paths between the two cones (ESC cancels)"""

    bl_idname = "blisk_cam.generate_paths"
    bl_label = "Generate Paths"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    status_label = "Blisk CAM"
    cancel_text = "Path generation cancelled; the previous paths are kept"
    start_text = "reading the mesh"

    busy_text = "Paths are being generated (ESC cancels)"

    @classmethod
    def problem(cls, context):
        settings = getattr(context.scene, "blisk_cam", None)
        return blade_problem(context) or (settings is not None and cones_problem(settings)) \
            or None

    def execute(self, context):
        cancel_pending_verify(context.scene.name)
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

    # --- modal (ModalJobOperator) ----------------------------------------------------------
    def new_job(self, context):
        cancel_pending_verify(context.scene.name)  # a new Generate drops the old figures
        return PathJob(context)

    def tick(self, context):
        """Plan → show the paths → poll the verify worker → attach its figures."""
        job = self._job
        wm = context.window_manager
        # planned means the worker is done too (without verify its last step, the paths
        # JSON, follows the plan): showing while it still runs would fight it for the GIL
        if job.paths_seconds is None and not job.poll_plan():
            wm.progress_update(int(90 * job.fraction))
            self._status(context, f"{int(100 * job.fraction)} % — {job.message}")
            return None
        if job.paths_seconds is None:  # planned: show the paths now (this tick)
            text = job.show_paths(context)
            self.running.discard(job.scene_name)  # a new Generate may start (and cancel)
            if not job.want_verify:
                self._report_done(job, text)
                return {"FINISHED"}
            wm.progress_update(95)
            self._status(context, "paths shown, verifying them", escape="ESC skips the verify")
            _tag_redraw(context)
            # the worker last: from its start it takes every other GIL turn from this tick
            if not job.begin_verify():
                self._report_done(job, text)
                return {"FINISHED"}
            return None
        if job.verify_cancelled:  # a new Generate took over: the paths stay, no figures
            self.report({"WARNING"}, "Verify dropped: a new generation started")
            return {"FINISHED"}
        if not job.verify_ready:
            job.wait_news(0.02)  # the JSON, the map's values or the end, within this tick
        stored = job.store_text()  # the shown paths' JSON, the worker's first product
        if not job.verify_ready:
            if not stored and job.show_map(context):  # the map now, the other figures later
                self._status(context, "colour map shown, measuring the scallops",
                             escape="ESC skips the verify")
                _tag_redraw(context)
            return None
        try:
            text = job.attach_verify(context)
        except Exception as exc:  # the paths shown stay (FINISHED: one undo step)
            report_exception(self, exc)
            return {"FINISHED"}
        self._report_done(job, text)
        _tag_redraw(context)
        return {"FINISHED"}

    def escape(self, context):
        job = self._job
        if job.paths_seconds is None:  # still planning
            return ModalJobOperator.escape(self, context)
        # the new paths are shown: keep them (FINISHED, one undo step), drop the figures
        job.cancel_verify()
        self.report({"WARNING"}, "Verify cancelled; the new paths are kept without verify "
                    "figures (turn Verify off to skip it)")
        return {"FINISHED"}

    def end_job(self, context):
        job = self._job
        job.cancel_plan()  # ESC or an error while planning: the worker stops at its next step
        if job.verify_pending:  # ended by Blender (file load, window closed) or an error
            job.cancel_verify()
        job.ensure_text()  # the shown paths keep their JSON however the run ended
        _tag_redraw(context)


def _tag_redraw(context):
    """Redraw the sidebar (the panel's "Verifying…" line and the statistics)."""
    screen = getattr(context, "screen", None)
    for area in getattr(screen, "areas", ()):
        if area.type in {"VIEW_3D", "PROPERTIES"}:
            area.tag_redraw()
