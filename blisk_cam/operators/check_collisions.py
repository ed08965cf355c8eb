"""``blisk_cam.check_collisions``: the blade's stored paths → ``core.collision.avoid`` (check, or
avoid) → the output objects rewritten with the checked path.

Inputs: the blade's evaluated mesh (when some but not all of its faces are selected — one
blade of a whole blisk — the selected faces are the blade and the rest of the mesh an
obstacle), its stored paths JSON (Generate Paths first), the collision options of the
settings (mode off runs as check; the blade count must be set), the holder string and the
meshes of the Obstacles collection. Interactively it runs modal (timer, status bar progress,
ESC cancels and keeps the previous result); in background or with EXEC_DEFAULT
synchronously. The rewritten output holds the checked path's JSON (so the colours and the
summary survive save, reload and undo), the status colours, the tool assembly at the worst
pose and the neighbour blades. In mode avoid the corrected axes stay inside the reach of
the machine chosen in the Machine & NC panel.
"""

from __future__ import annotations

import time

import bpy

from ..blender.settings import collision_options
from ..core.errors import BliskCamError
from .common import blade_problem, obstacle_arrays, report_exception, resolve_blade, stored_path
from .modal_job import ModalJobOperator

#: names of scenes with a modal check running
_RUNNING: set[str] = set()


class CollisionJob:
    """One check: inputs read up front (arrays and names only), then run step by step."""

    def __init__(self, context):
        from ..blender.objects import blade_and_rest
        from ..core.collision.avoid import iter_run_collisions

        settings = context.scene.blisk_cam
        problem = blade_problem(context)
        if problem:
            raise BliskCamError(problem)
        blade = resolve_blade(context)
        self.scene_name = context.scene.name
        self.blade_name = blade.name
        self.path = stored_path(blade.name)
        self.options = collision_options(settings)
        if self.options.mode == "avoid":  # avoidance stays inside the NC machine's reach
            from dataclasses import replace

            from ..core.machine.description import load_machine
            from .export_nc import nc_machine

            self.options = replace(self.options, machine=load_machine(nc_machine(settings)))
        depsgraph = context.evaluated_depsgraph_get()
        (self.V, self.F), rest, (self.n_sel, self.n_all) = blade_and_rest(blade, depsgraph)
        extra = []
        if rest is not None:
            extra.append((f"{blade.name} (unselected faces)", *rest))
        extra += obstacle_arrays(settings, depsgraph, exclude={blade.name})
        self.extra_names = [e[0] for e in extra]
        self.fraction = 0.0
        self.result = None
        self.t0 = time.perf_counter()
        self._it = iter_run_collisions((self.V, self.F), self.path, extra, self.options)

    @property
    def done(self) -> bool:
        return self.result is not None

    def step(self, budget: float = 0.1) -> bool:
        """Advance for about ``budget`` seconds (at least one step); True once done."""
        t_end = time.perf_counter() + budget
        while self.result is None:
            try:
                self.fraction = float(next(self._it))
            except StopIteration as stop:
                self.result = stop.value
                self.fraction = 1.0
                break
            if time.perf_counter() >= t_end:
                break
        return self.result is not None

    def finish(self, context) -> tuple[str, int]:
        """Rewrite the output objects with the checked path; (summary line, unresolved)."""
        import json

        from ..blender import path_objects as output
        from ..blender.collision_objects import write_collision_objects
        from ..core.collision.obstacles import Obstacles
        from ..core.tool.assembly import assembly_mesh
        from ..core.toolpath.paths_io import path_to_dict

        blade = bpy.data.objects.get(self.blade_name)
        if blade is None:
            raise BliskCamError(f"the blade '{self.blade_name}' was deleted or renamed during "
                                "the check; check again")
        path, report = self.result
        scene = context.scene
        output.write_path_objects(scene, blade, path, scene.blisk_cam,
                                  json_text=json.dumps(path_to_dict(path), allow_nan=False))
        obstacles = Obstacles.build(self.V, self.F, path.axis, self.options.blade_count,
                                    self.options.neighbours, check_extra=False)
        neighbours = [(m.name, m.V, m.F) for m in obstacles.meshes[1:obstacles.extra_start]]
        assembly = assembly_mesh(self.options.assembly(path.tool), path.tool)
        write_collision_objects(scene, blade.name, path, neighbours=neighbours,
                                       assembly=assembly)
        return self.summary(report), int(report.n_unresolved)

    def summary(self, report) -> str:
        s = report.summary()
        text = (f"{s['checked_poses']} poses checked ({s['mode']}): "
                f"{s['colliding_before']} colliding, {s['corrected']} corrected, "
                f"{s['unresolved']} unresolved")
        if s["min_clearance"] is not None:
            text += f"; worst clearance {s['min_clearance']:.3f} mm"
        if self.n_sel != self.n_all:
            text += (f"; blade = {self.n_sel} selected of {self.n_all} triangles, the rest "
                     "is an obstacle")
        return text + f" in {time.perf_counter() - self.t0:.1f} s"

    def run(self, context):
        while not self.step(1e9):
            pass
        return self.finish(context)


class BLISKCAM_OT_check_collisions(ModalJobOperator, bpy.types.Operator):
    """Check the generated paths for collisions of flute, shank and holder with the blade,
    its neighbours and the obstacles; in Avoid mode turn the tool axis clear (ESC cancels)"""

    bl_idname = "blisk_cam.check_collisions"
    bl_label = "Check Collisions"
    bl_options = {"REGISTER", "UNDO"}

    running = _RUNNING
    status_label = "Blisk CAM collisions"
    cancel_text = "Collision check cancelled; the previous result is kept"

    busy_text = "Collisions are being checked (ESC cancels)"

    @classmethod
    def problem(cls, context):
        return blade_problem(context)

    def execute(self, context):
        try:
            job = CollisionJob(context)
            text, unresolved = job.run(context)
        except Exception as exc:
            return report_exception(self, exc)
        self._report_done(text, unresolved)
        return {"FINISHED"}

    def _report_done(self, text, unresolved):
        if unresolved:
            self.report({"WARNING"}, f"{unresolved} pose(s) still collide: NC export refuses "
                        "them (see Next Unresolved Pose)")
        self.report({"INFO"}, text)

    # --- modal (ModalJobOperator) ----------------------------------------------------------
    def new_job(self, context):
        return CollisionJob(context)

    def tick(self, context):
        job = self._job
        if not job.done:
            job.step(0.15)
            context.window_manager.progress_update(int(95 * job.fraction))
            self._status(context, f"{int(100 * job.fraction)} %")
            return None
        text, unresolved = job.finish(context)
        self._report_done(text, unresolved)
        return {"FINISHED"}
