"""``blisk_cam.animate_program``: Blender as the simulator. The tool assembly is animated
along the NC block stream of the machine in the "Machine & NC" panel, one keyframe per block
(``core.machine.motion``): in the part view the tool moves over the standing blade; in the machine
view the tool stands at the programmed X Y Z and a copy of the blade and its paths (the
user's objects are not touched) turns with the tables. Scrubbing the timeline shows the
motion; a preview render can be any frame of it."""

import bpy
import numpy as np
from bpy.props import EnumProperty

from ..blender.settings import nc_options
from ..core.errors import BliskCamError
from .common import (
    poll_generated_paths,
    report_exception,
    result_blade_name,
    settings_of,
    stored_path,
)

#: object names (prefixed with the blade name) of the animation
TOOL_SUFFIX = "animated tool"
PART_SUFFIX = "moving part"


def _keyframe_matrices(ob, matrices, mm_per_unit):
    """One keyframe per row of ``matrices`` (n, 4, 4), mm, on frames 1..n: location and
    quaternion F-curves filled in bulk (linear interpolation)."""
    from mathutils import Matrix

    n = len(matrices)
    loc = matrices[:, :3, 3] / mm_per_unit
    quats = np.array([tuple(Matrix(m[:3, :3].tolist()).to_quaternion()) for m in matrices])
    # no flips between neighbours: keep each quaternion on the side of the previous one
    for i in range(1, n):
        if np.dot(quats[i], quats[i - 1]) < 0:
            quats[i] = -quats[i]
    ob.rotation_mode = "QUATERNION"
    ob.animation_data_clear()
    ob.animation_data_create()
    action = bpy.data.actions.new(f"{ob.name} motion")
    ob.animation_data.action = action
    frames = np.arange(1, n + 1, dtype=np.float64)
    for path, values in (("location", loc), ("rotation_quaternion", quats)):
        for k in range(values.shape[1]):
            fc = _new_fcurve(ob, action, path, k)
            fc.keyframe_points.add(n)
            co = np.column_stack([frames, values[:, k]]).ravel()
            fc.keyframe_points.foreach_set("co", co)
            fc.keyframe_points.foreach_set("interpolation", np.full(n, 1, dtype=np.int32))
            fc.update()


def _new_fcurve(ob, action, path, index):
    ensure = getattr(action, "fcurve_ensure_for_datablock", None)
    if ensure is not None:  # Blender 4.4+: slotted actions (assigns the object's slot)
        return ensure(ob, path, index=index)
    return action.fcurves.new(path, index=index)  # Blender 4.2/4.3


class BLISKCAM_OT_animate_program(bpy.types.Operator):
    """Animate the tool along the NC program of the generated paths (one keyframe per block)"""

    bl_idname = "blisk_cam.animate_program"
    bl_label = "Animate Program"
    bl_options = {"REGISTER", "UNDO"}

    view: EnumProperty(
        name="View", default="PART",
        items=[("PART", "Part View", "The blade stands, the tool moves"),
               ("MACHINE", "Machine View", "The tool stands at X Y Z, a copy of the blade "
                "turns with the tables")])

    @classmethod
    def poll(cls, context):
        return poll_generated_paths(cls, context)

    def execute(self, context):
        from ..blender import path_objects as output
        from ..blender.objects import arrays_to_object, mm_per_blender_unit
        from ..core.collision.options import default_assembly
        from ..core.machine.description import forward
        from ..core.machine.motion import machine_view, part_view
        from ..core.post.blocks import build_blocks
        from ..core.tool.assembly import assembly_mesh
        from .export_nc import loaded_machine

        scene = context.scene
        settings = settings_of(context)
        try:
            name = result_blade_name(context)
            path = stored_path(name)
            machine = loaded_machine(settings)
            blocks = build_blocks(path, machine, nc_options(settings),
                                  indexable=False).expanded()
            if len(blocks) == 0:
                raise BliskCamError("the program has no blocks to animate")
            if self.view == "PART":  # every block, safe retracts included: through FK
                part, tool = part_view(*forward(machine, blocks.xyz, blocks.angles))
            else:
                part, tool = machine_view(machine, blocks.xyz, blocks.angles)
            coll = output.find_output_collection(name)
            f = mm_per_blender_unit(scene)
            for suffix in (TOOL_SUFFIX, PART_SUFFIX):
                old = bpy.data.objects.get(f"{name} {suffix}")
                if old is not None:
                    bpy.data.objects.remove(old, do_unlink=True)
            V, F = assembly_mesh(default_assembly(path.tool), path.tool)
            ob = arrays_to_object(f"{name} {TOOL_SUFFIX}", V, F, coll,
                                  color=(0.75, 0.78, 0.82, 1.0))
            _keyframe_matrices(ob, tool, f)
            if self.view == "MACHINE":
                src = [bpy.data.objects.get(name)] + [
                    o for o in coll.objects if o.get(output.KEY_ROLE) == "cc"]
                part_ob = bpy.data.objects.new(f"{name} {PART_SUFFIX}", None)
                coll.objects.link(part_ob)
                for o in src:
                    if o is None:
                        continue
                    copy = o.copy()  # shares the data: the user's object stays as it is
                    copy.animation_data_clear()
                    copy.name = f"{name} {PART_SUFFIX} ({o.name})"
                    coll.objects.link(copy)
                    copy.parent = part_ob
                    copy.matrix_parent_inverse.identity()
                _keyframe_matrices(part_ob, part, f)
            scene.frame_start, scene.frame_end = 1, len(blocks)
            scene.frame_set(1)
        except Exception as exc:
            return report_exception(self, exc)
        self.report({"INFO"}, f"Animated {len(blocks)} blocks on frames 1–{len(blocks)} "
                    f"({self.view.lower()} view, {machine.name})")
        return {"FINISHED"}
