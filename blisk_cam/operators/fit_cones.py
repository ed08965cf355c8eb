"""``blisk_cam.fit_cones``: fit cone 1 (hub) and cone 2 (tip) to the blade's boundary loops."""

import bpy

from .common import (
    blade_axis,
    blade_problem,
    read_blade,
    report_exception,
    resolve_blade,
)


class BLISKCAM_OT_fit_cones(bpy.types.Operator):
    """Fit the hub and tip cones to the blade mesh's two open boundary loops"""

    bl_idname = "blisk_cam.fit_cones"
    bl_label = "Fit Cones"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        problem = blade_problem(context)
        if problem:
            cls.poll_message_set(problem)
            return False
        return True

    def execute(self, context):
        from ..core.fitting import fit_cones_to_mesh
        from ..core.mesh import TriMesh

        settings = context.scene.blisk_cam
        try:
            problem = blade_problem(context)
            if problem:
                from ..core.errors import BliskCamError

                raise BliskCamError(problem)
            blade = resolve_blade(context)
            axis = blade_axis(settings, blade)
            V, F = read_blade(context, blade)
            fit = fit_cones_to_mesh(TriMesh.from_arrays(V, F), axis)
        except Exception as exc:
            return report_exception(self, exc)
        if settings.blade is None:
            settings.blade = blade
        settings.cone1 = fit.cone1.as_list()
        settings.cone2 = fit.cone2.as_list()
        settings.fit_residual1 = fit.residual1
        settings.fit_residual2 = fit.residual2
        extra = f"; {fit.other_loops} other boundary loop(s) ignored" if fit.other_loops else ""
        self.report(
            {"INFO"},
            f"Fitted cones to '{blade.name}': residual {fit.residual1:.4f} mm (hub), "
            f"{fit.residual2:.4f} mm (tip){extra}",
        )
        return {"FINISHED"}
