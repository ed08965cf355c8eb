"""The Blender objects that show a collision check and a block-error map:
pose points coloured by status, the neighbours and the tool assembly.
"""

from __future__ import annotations

import json

import bpy
import numpy as np

from ..core.display import (
    spline_bins,
)
from ..core.errors import BliskCamError
from .objects import arrays_to_object, mm_per_blender_unit
from .path_objects import (
    ASSEMBLY_RGBA,
    KEY_COLLISION,
    KEY_NAME,
    KEY_ROLE,
    NEIGHBOUR_RGBA,
    _bin_materials,
    _curve_object,
    find_output_collection,
    output_objects,
)

__all__ = ["collision_summary", "write_collision_objects"]


def collision_summary(blade_name: str) -> dict | None:
    """The collision summary of a blade's stored paths (``ToolPath.collision``: checked
    poses, colliding before, corrected, unresolved, min clearance...), or None when its
    paths were not checked. Cheap (a copy kept on the collection): for panels."""
    coll = find_output_collection(blade_name)
    text = coll.get(KEY_COLLISION) if coll is not None else None
    if not text:
        return None
    try:
        out = json.loads(text)
    except ValueError:
        return None
    return out if isinstance(out, dict) else None


def write_collision_objects(scene, blade_name, path, *, neighbours=(), assembly=None) -> dict:
    """Add the collision view to a blade's output collection (after
    :func:`write_path_objects` of the checked path), replacing an earlier one:

    * ``neighbours`` — iterable of (name, V (n, 3) mm, F (m, 3)) meshes (the blade turned by
      ±k·360°/N), shown grey as ``"<blade> <name>"``;
    * ``assembly`` — (V (n, 3) mm, F (m, 3|4)) of the tool assembly in the tool frame (tip at
      the origin, axis +Z, :func:`blisk_cam.core.tool.assembly.assembly_mesh`): placed at the
      pose with the smallest clearance (:func:`blisk_cam.core.collision.report.worst_pose`); the
      exact tip (mm, double) is kept in its ``blisk_cam_tip_mm`` property.

    Returns ``{"tool_assembly": object or None, "neighbours": [objects]}``.
    """
    from mathutils import Matrix

    from ..core.collision.report import worst_pose

    coll = find_output_collection(blade_name)
    if coll is None:
        raise BliskCamError(f"the blade '{blade_name}' has no output collection")
    f = mm_per_blender_unit(scene)
    old = output_objects(coll)
    stale = [ob for ob in [old["tool_assembly"], *old["neighbours"]] if ob is not None]
    if stale:
        data = [ob.data for ob in stale if ob.data is not None]
        bpy.data.batch_remove(stale)
        orphans = [d for d in data if d.users == 0]
        if orphans:
            bpy.data.batch_remove(orphans)
    out = {"tool_assembly": None, "neighbours": []}
    for name, V, F in neighbours:
        label = f"{blade_name} {name.replace('blade', 'neighbour', 1)}"
        ob = arrays_to_object(label, V, F, coll, mm_per_unit=f, color=NEIGHBOUR_RGBA,
                              material_name="Blisk CAM neighbour")
        ob[KEY_ROLE] = "neighbour"
        ob[KEY_NAME] = label
        ob.name = label
        ob.data.name = label
        out["neighbours"].append(ob)
    worst = worst_pose(path)
    if assembly is not None and worst is not None:
        tip, axis, clearance, row = worst
        V, F = assembly
        label = f"{blade_name} tool assembly"
        ob = arrays_to_object(label, V, F, coll, mm_per_unit=f, color=ASSEMBLY_RGBA,
                              material_name="Blisk CAM tool assembly")  # tool frame
        z = axis
        ref = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        x = ref - (ref @ z) * z
        x /= np.linalg.norm(x)
        M = np.eye(4)
        M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = x, np.cross(z, x), z, tip / f
        ob.matrix_world = Matrix(M.tolist())
        ob[KEY_ROLE] = "tool_assembly"
        ob[KEY_NAME] = label
        ob["blisk_cam_tip_mm"] = [float(v) for v in tip]
        ob["blisk_cam_axis"] = [float(v) for v in axis]
        ob["blisk_cam_clearance_mm"] = float(clearance)
        ob["blisk_cam_row"] = int(row)
        ob.name = label
        ob.data.name = label
        out["tool_assembly"] = ob
    return out


def write_block_error_object(scene, blade_name, starts, ends, ratio):
    """The NC blocks chosen by the interpolation as a curve in the blade's output collection:
    one segment per block, coloured by its measured maximum error as a share of the bound
    (blue 0 → red 100 %, the path ramp; NaN in the first bin). Replaces the previous one."""
    coll = find_output_collection(blade_name)
    if coll is None:
        raise BliskCamError(f"'{blade_name}' has no output collection: generate the paths first")
    name = f"{blade_name} NC blocks"
    old = bpy.data.objects.get(name)
    if old is not None:
        bpy.data.objects.remove(old, do_unlink=True)
    f = mm_per_blender_unit(scene)
    sets = [np.vstack([a, b]) for a, b in zip(starts, ends, strict=True)]
    ob = _curve_object(name, sets, [False] * len(sets), f, 0.15)
    mats = _bin_materials()
    for m in mats:
        ob.data.materials.append(m)
    r = np.nan_to_num(np.asarray(ratio, dtype=np.float64), nan=0.0)
    bins = spline_bins("CUSP", np.zeros(len(r)), r, 1.0)
    ob.data.splines.foreach_set("material_index", bins.astype(np.int32))
    ob.data["blisk_cam_block_error_share"] = [float(x) for x in r]
    ob[KEY_ROLE] = "nc_blocks"
    coll.objects.link(ob)
    return ob
