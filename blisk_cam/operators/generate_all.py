"""``blisk_cam.generate_all``: the Operations panel's job run by the core
(``core.process.job.iter_run_job``: every enabled operation in order, each planned on the stock
the previous one left) and shown: one collection per operation with its paths, the stock after
the selected operation.

The job is built from the scene up front in Blender's thread (:func:`.job_scene.job_data` →
``job_from_data``: bad input is refused before any work, naming the operation and the key); the
run goes on a thread of its own; interactively the operator is modal (status bar: the
operation running and its stage, ESC cancels and keeps the previous results); in background or
with EXEC_DEFAULT synchronously. Nothing is written to the scene until every operation is done.
"""

from __future__ import annotations

import time

import bpy

from ..core.errors import BliskCamError
from .modal_job import ThreadJob, ThreadJobOperator

__all__ = ["BLISKCAM_OT_generate_all", "OperationsJob"]

#: names of scenes with a run going
_RUNNING: set[str] = set()


class OperationsJob(ThreadJob):
    """One run of the panel's job: inputs read up front, the work on a thread."""

    thread_name = "blisk_cam-operations"

    def __init__(self, context):
        from ..core.process.job import job_from_data
        from .job_scene import job_data, job_path

        s = getattr(context.scene, "blisk_cam", None)
        if s is None:
            raise BliskCamError("Blisk CAM settings are missing: enable the add-on")
        if not len(s.operations):
            raise BliskCamError("No operations: add one in the Operations panel")
        self.scene_name = context.scene.name
        self.job = job_from_data(job_data(context.scene), job_path())
        #: core index (1-based position in the panel) → uid and label
        self.uids = {k + 1: (o.uid, o.name) for k, o in enumerate(s.operations)}
        super().__init__()
        self.fraction, self.message = 0.0, "building the part"
        self.results = []
        self.run_result = None
        self.t0 = time.perf_counter()

    def _keep(self, orun):
        """``on_operation``: the stock after the operation, while it is current."""
        from ..core.stock.deviation import stock_skin

        sim = orun.simulation
        sV, sF = stock_skin(orun.stock)
        uid, _ = self.uids[orun.op.index]
        self.results.append({
            "uid": uid, "index": orun.op.index, "label": None, "path": orun.path,
            "stock": {"V": sim.V, "F": sim.F, "deviation": sim.deviation,
                      "tolerance": sim.summary["deviation_mm"]["gouge_tolerance"],
                      "skin_V": sV, "skin_F": sF, "summary": dict(sim.summary)}})

    def work(self):
        from ..core.process.job import iter_run_job
        from ..core.runtime import Cancelled, cancellable

        with cancellable(self.cancel, "the operations"):
            gen = iter_run_job(self.job, on_operation=self._keep)
            while True:
                if self.cancel.is_set():
                    raise Cancelled("the operations were cancelled")
                try:
                    pr = next(gen)
                except StopIteration as stop:
                    self.run_result = stop.value
                    break
                self.fraction, self.message = float(pr.fraction), pr.message

    def outcome(self):
        return self.run_result

    def finish(self, context) -> list:
        """Write the collections and the selected operation's stock; the summary lines."""
        from ..blender.operation_objects import (
            operation_label,
            show_operation_stock,
            write_operation_results,
        )

        run = self.result()
        for r in self.results:
            r["label"] = operation_label(r["index"], self.uids[r["index"]][1])
        write_operation_results(context.scene, self.results)
        show_operation_stock(context.scene)
        ops = {o.uid: o for o in context.scene.blisk_cam.operations}
        for o in ops.values():
            o.result = "" if o.enabled else "disabled: not run"
        lines = []
        for orun in run.operations:
            s = orun.simulation.summary
            text = (f"{len(orun.path.program)} rows, {orun.cutting.spindle:.0f} rpm, "
                    f"{orun.cutting.feed:.0f} mm/min; left max "
                    f"{s['deviation_mm']['max_left']:.3f} mm, gouge max "
                    f"{s['deviation_mm']['max_gouge']:.3f} mm, {len(s['crashes'])} crash(es), "
                    f"{'passed' if s['passed'] else 'FAILED'}")
            op = ops.get(self.uids[orun.op.index][0])
            if op is not None:
                op.result = text
            lines.append(f"{orun.op.index} {orun.op.name}: {text}")
        return lines


class BLISKCAM_OT_generate_all(ThreadJobOperator, bpy.types.Operator):
    """Run every enabled operation in order on the stock (the job's core), one collection per
    operation, the stock after the selected one (ESC cancels and keeps the previous results)"""

    bl_idname = "blisk_cam.generate_all"
    bl_label = "Generate All"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    status_label = "Blisk CAM operations"
    cancel_text = "Generate All cancelled; the previous results are kept"
    start_text = "building the part and the stock"

    busy_text = "Generate All is running (ESC cancels)"

    @classmethod
    def problem(cls, context):
        s = getattr(context.scene, "blisk_cam", None)
        return "Add an operation first" if s is None or not len(s.operations) else None

    def done(self, context, job) -> set:
        lines = job.finish(context)
        for line in lines:  # a failed verdict (gouge, crash) stands out; the run is kept
            self.report({"WARNING"} if line.endswith("FAILED") else {"INFO"}, line)
        self.report({"INFO"}, f"Generate All: {len(lines)} operation(s) in "
                              f"{time.perf_counter() - job.t0:.1f} s")
        return {"FINISHED"}

    progress_share = 100

    def make_job(self, context):
        return OperationsJob(context)
