"""``blisk_cam.fit_cones``: fit cone 1 (hub) and cone 2 (tip) to the blade's boundary loops.

What is fitted follows ``scene.blisk_cam.fit_generatrix`` (straight cones, polyline profiles
for a curved hub or tip — LMRS, paper 001 §4.2 — or per end whichever fits: ``core.part.fitting``).
A fitted profile is stored in full in ``profile1``/``profile2``; the cone and the middle
generatrix are shown at once in the blade's output collection (:func:`output.write_cone_objects`).
"""

import bpy
import numpy as np

from ..blender.settings import FIT_NAMES
from .common import blade_axis, blade_problem, read_blade, report_exception, resolve_blade


class BLISKCAM_OT_fit_cones(bpy.types.Operator):
    """Fit the hub and tip cones (or profiles, see Fit) to the blade mesh's two open boundary
    loops"""

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
        from ..blender import path_objects as output
        from ..blender.settings import set_generatrix
        from ..core.geometry.mesh import TriMesh
        from ..core.part.fitting import fit_cones_to_mesh

        settings = context.scene.blisk_cam
        try:
            problem = blade_problem(context)
            if problem:
                from ..core.errors import BliskCamError

                raise BliskCamError(problem)
            blade = resolve_blade(context)
            axis = blade_axis(settings, blade)
            V, F = read_blade(context, blade)
            mesh = TriMesh.from_arrays(V, F)
            fit = fit_cones_to_mesh(mesh, axis, generatrix=FIT_NAMES[settings.fit_generatrix])
            if settings.blade is None:
                settings.blade = blade
            set_generatrix(settings, 1, fit.cone1)
            set_generatrix(settings, 2, fit.cone2)
            settings.fit_residual1 = fit.residual1
            settings.fit_residual2 = fit.residual2
            loops = mesh.V[np.concatenate([fit.hub_loop, fit.tip_loop])]
            output.write_cone_objects(context.scene, blade, fit.cone1, fit.cone2, axis, loops)
        except Exception as exc:
            return report_exception(self, exc)
        kinds = fit.kinds
        extra = f"; {fit.other_loops} other boundary loop(s) ignored" if fit.other_loops else ""
        self.report(
            {"INFO"},
            f"Fitted to '{blade.name}': hub {kinds[0]} residual {fit.residual1:.4f} mm, "
            f"tip {kinds[1]} residual {fit.residual2:.4f} mm{extra}",
        )
        return {"FINISHED"}
