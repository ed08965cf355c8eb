"""``blisk_cam.simulate_stock``: the generated paths (the program Export NC posts) run on the
stock of the "Stock" panel — ``core.stock`` (the same API as ``blisk_cam simulate``) — and
the verdict shown: the part coloured by deviation, the remaining stock of one sector, the
summary (removed volume, max/p95 left, max gouge and where, crashes with their row).

Inputs are read up front in Blender's thread (arrays and names only); the part, the blank
and the simulation run on a thread of their own; interactively the operator is modal (cursor
and status bar progress, ESC cancels and keeps the previous result); in background or with
EXEC_DEFAULT synchronously. The objects go to the collection "Blisk CAM – Stock", replaced on
every run; the user's objects are never modified. A crash (a rapid or the tool body removing
material) is reported as an ERROR naming the row.
"""

from __future__ import annotations

import os
import time

import bpy

from ..core.errors import BliskCamError
from .common import (
    generated_paths_problem,
    result_blade_name,
    settings_of,
    stored_path,
)
from .modal_job import ThreadJob, ThreadJobOperator

__all__ = ["BLISKCAM_OT_simulate_stock", "StockJob", "summary_line", "crash_line"]

#: names of scenes with a simulation running
_RUNNING: set[str] = set()


def _mesh_arrays(context, ob, what: str):
    from ..blender.objects import object_to_arrays

    if ob is None or ob.type != "MESH":
        raise BliskCamError(f"No {what}: choose a mesh object in the Stock panel (or make it "
                            "active)")
    return object_to_arrays(ob, context.evaluated_depsgraph_get())


def _csv(filepath: str, what: str):
    from ..core.part.model import read_rz_csv

    if not filepath:
        raise BliskCamError(f"No {what} file given: choose one in the Stock panel")
    filename = bpy.path.abspath(filepath)
    if not os.path.isfile(filename):
        raise BliskCamError(f"{what} file {filename} not found")
    return read_rz_csv(filename)


def summary_line(s: dict) -> str:
    """One line of a simulation summary (``core.stock.deviation.simulation_summary``)."""
    d = s["deviation_mm"]
    at = d.get("max_gouge_at_mm")
    where = f" at ({', '.join(f'{x:.2f}' for x in at)}) mm" if at and d["max_gouge"] > 0 \
        else ""
    return (f"removed {s['volume_removed_mm3']['sector']:.1f} mm³ per sector "
            f"({s['volume_removed_mm3']['blisk']:.0f} mm³ on the blisk); left max "
            f"{d['max_left']:.3f} mm (p95 {d['p95_left']:.3f}); gouge max "
            f"{d['max_gouge']:.3f} mm{where} (tolerance {d['gouge_tolerance']:.3f}); "
            f"{len(s['crashes'])} crash(es); {'passed' if s['passed'] else 'FAILED'}"
            + (f" ({d['not_judged_area_mm2']:.1f} mm² below the stock's resolution not judged)"
               if d.get("not_judged_area_mm2") else ""))


def crash_line(s: dict) -> str | None:
    """The crashes of a summary in words naming the first row, or None without crashes."""
    c = s.get("crashes") or []
    if not c:
        return None
    first = c[0]
    return (f"{len(c)} crash(es): first at row {first['row']} ({first['kind']} removing "
            f"{first['volume_mm3']:.3f} mm³ on a {first['move']} move, tip at "
            f"{tuple(first['tip_mm'])} mm)")


class StockJob(ThreadJob):
    """One simulation: inputs read up front, the work on a thread (:meth:`start`, cancelled
    through :attr:`cancel`) or in the caller's (:meth:`run`)."""

    def __init__(self, context):
        settings = settings_of(context)
        if settings is None:
            raise BliskCamError("Blisk CAM settings are missing: enable the add-on")
        self.scene_name = context.scene.name
        self.blade_name = result_blade_name(context)
        if self.blade_name is None:
            raise BliskCamError("No generated paths: press Generate Paths first (the program "
                                "simulated is the one Export NC posts)")
        self.path = stored_path(self.blade_name)
        if self.path.program is None:
            raise BliskCamError(f"the paths of '{self.blade_name}' have no linked program: "
                                "generate them again with linking")
        self.blade_count = int(settings.blade_count)
        if self.blade_count < 1:
            raise BliskCamError("Blade Count is not set: set the Blade Count (the blades on "
                                "the blisk) in the Stock or Collisions panel")
        self.resolution = float(settings.stock_resolution)
        if not 0.005 <= self.resolution <= 10.0:
            raise BliskCamError(f"Resolution must be in [0.005, 10] mm, got {self.resolution:g}")
        tol = float(settings.stock_gouge_tolerance)
        self.gouge_tolerance = tol if tol > 0 else None
        self.part_source = settings.stock_part_source
        if self.part_source == "MESH":
            ob = settings.stock_part or context.active_object
            self.part_arrays = _mesh_arrays(context, ob, "whole-blisk mesh")
            self.hub_profile = None
        else:
            blade = bpy.data.objects.get(self.blade_name)
            self.part_arrays = _mesh_arrays(context, blade, "blade")
            self.hub_profile = _csv(settings.stock_hub_profile, "hub profile")
        self.blank = settings.stock_blank
        self.blank_value = None
        if self.blank == "ALLOWANCE":
            self.blank_value = float(settings.stock_allowance)
        elif self.blank == "ENVELOPE":
            self.blank_value = float(settings.stock_margin)
        elif self.blank == "PROFILE":
            self.blank_value = _csv(settings.stock_profile, "blank profile")
        else:
            self.blank_value = _mesh_arrays(context, settings.stock_blank_object,
                                            "blank mesh")
        super().__init__()
        self.fraction = 0.0
        self.message = "building the part"
        self.sim = None
        self.skin = None
        self.t0 = time.perf_counter()

    # --- the work (no bpy) -------------------------------------------------------------
    def part(self):
        from ..core.part.model import part_from_blade, split_blisk_mesh

        V, F = self.part_arrays
        if self.hub_profile is not None:
            return part_from_blade(V, F, self.hub_profile, self.blade_count, self.path.axis)
        return split_blisk_mesh(V, F, self.blade_count, self.path.axis).part

    def stock(self, part):
        from ..core.stock.blank import (
            stock_from_allowance,
            stock_from_envelope,
            stock_from_mesh,
            stock_from_profile,
        )

        if self.blank == "ALLOWANCE":
            return stock_from_allowance(part, self.blank_value, self.resolution)
        if self.blank == "ENVELOPE":
            return stock_from_envelope(part, self.blank_value, self.resolution)
        if self.blank == "PROFILE":
            return stock_from_profile(self.blank_value, part.axis, part.blade_count,
                                      part.sector_start, self.resolution)
        V, F = self.blank_value
        return stock_from_mesh(V, F, part.axis, part.blade_count, part.sector_start,
                               self.resolution)

    thread_name = "blisk_cam-stock"

    def work(self):
        from ..core.runtime import Cancelled, cancellable
        from ..core.stock.deviation import stock_skin
        from ..core.stock.simulation import iter_simulate

        with cancellable(self.cancel, "the stock simulation"):
            part = self.part()
            self.message = "building the stock"
            stock = self.stock(part)
            gen = iter_simulate(part, stock, [self.path],
                                gouge_tolerance=self.gouge_tolerance)
            while True:
                if self.cancel.is_set():
                    raise Cancelled("the stock simulation was cancelled")
                try:
                    pr = next(gen)
                except StopIteration as stop:
                    sim = stop.value
                    break
                self.fraction, self.message = 0.95 * float(pr.fraction), pr.message
            self.message = "the remaining stock's skin"
            self.skin = stock_skin(sim.stock)
            self.sim = sim
            self.fraction = 1.0

    def outcome(self):
        """The core Simulation."""
        return self.sim

    # --- Blender's thread ----------------------------------------------------------------
    def finish(self, context) -> dict:
        """Write the objects (replacing the previous run's); the summary."""
        from ..blender.stock_objects import write_stock_objects

        sim = self.result()
        summary = dict(sim.summary)
        summary["seconds"] = round(time.perf_counter() - self.t0, 3)
        summary["blade"] = self.blade_name
        write_stock_objects(context.scene, sim.V, sim.F, sim.deviation,
                            summary["deviation_mm"]["gouge_tolerance"], *self.skin, summary,
                            judged=sim.judged)
        return summary


class BLISKCAM_OT_simulate_stock(ThreadJobOperator, bpy.types.Operator):
    """Run the generated program on the stock of the Stock panel: material removal, the part
    coloured by deviation (blue gouge, green within tolerance, red left), the remaining stock
    and the crashes (ESC cancels)"""

    bl_idname = "blisk_cam.simulate_stock"
    bl_label = "Simulate"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    status_label = "Blisk CAM stock simulation"
    cancel_text = "Stock simulation cancelled; the previous result is kept"
    start_text = "building the part and the stock"

    busy_text = "The stock simulation is running (ESC cancels)"

    @classmethod
    def problem(cls, context):
        return generated_paths_problem(context)

    def done(self, context, job) -> set:
        summary = job.finish(context)
        crashes = crash_line(summary)
        if crashes:
            self.report({"ERROR"}, crashes)
        self.report({"INFO"}, f"Stock: {summary_line(summary)} in {summary['seconds']:.1f} s")
        return {"FINISHED"}

    def make_job(self, context):
        return StockJob(context)
