"""The Blender objects that show a generated tool path, in one collection per blade.

Collection ``"Blisk CAM – <blade>"`` (en dash), a child of the blade's first collection:

* ``"<blade> CC paths"`` — a curve object, one POLY spline per pass curve (cyclic for closed
  curves; a spiral is cut into one spline per colour bin of its ratio, :func:`spline_pieces`)
  through the cutter-contact points; bevelled for renders; material per spline from the
  colour mode (solid, morph ratio s of the pass, or the cusp measured next to the pass).
* ``"<blade> tool tips"`` — the same for the tool tip (CL) points.
* ``"<blade> links"`` (when the path is linked) — the approach, retract, link and rapid moves
  of the program, a spline per run (grey at feed, red rapid); not rendered.
* ``"<blade> poses"`` — one point-cloud mesh (vertices only, shown as points by a Geometry
  Nodes "Mesh to Points" modifier) with *every* pose: vertex = tool tip, point attributes
  ``axis`` (unit tool axis), ``normal`` (surface normal at CC), ``cc`` (CC point, mm),
  ``s`` (morph ratio), ``pass`` (index of the pass level), ``curve`` (index of the curve),
  ``move`` (move type code, names in the object's ``blisk_cam_move_types`` property) and
  ``status`` (the path's per-pose flags, 0 when the path has none).
  When the path was checked for collisions (``blisk_cam.check_collisions``) the cloud also
  has ``collision_status`` (0 clear, 1 corrected, 2 unresolved) and its points show it:
  green, orange, red materials in Solid view and renders (the cloud then renders).
* after a collision check: ``"<blade> tool assembly"`` — the revolved flute and holder at
  the pose with the smallest clearance (origin at the tip, local +Z the tool axis), and
  ``"<blade> neighbour ±k"`` — the blade turned by ±k·360°/N, grey, so renders show the
  channel.
* child collection ``"Blisk CAM – <blade> poses"`` — at most ``pose_count`` single-arrow
  Empties spread evenly over all poses (tip at the origin, local +Z = tool axis), never one
  per pose of a long path.
* ``"<blade> cone 1"``, ``"<blade> cone 2"``, ``"<blade> middle cone"`` — the hub and tip
  generatrices revolved over the blade's angular range, and the LMC (or LMRS) at s = 0.5
  (paper 001 Fig. 2): cone 1 as a wire grid (it usually coincides with the hub surface),
  cone 2 see-through with its grid, the middle one a wire grid; rendered. Fit Cones writes
  them too (before any path: :func:`write_cone_objects`), so the region shows at once.
* ``"<blade> verify"`` (when asked) — a copy of the blade's evaluated mesh with a point colour
  attribute ``verify`` (material left green → blue, beyond the tolerance purple; gouge red;
  grey outside the machined region) and the raw value ``material_left`` (mm, NaN outside).

The paths JSON of the result (exactly what ``core.toolpath.paths_io.write_paths_json`` writes) is
kept in a Text datablock ``"Blisk CAM – <blade>.json"`` so ``export_paths`` works after a reload.
Regenerating builds the new collection completely, then removes the old one: a failure or a
cancel leaves the previous result as it was (only the pose empties, computed before, are made
after the removal, with their final names). The blade object itself is never modified.

Coordinates: core works in mm, objects in Blender units (``mm / mm_per_blender_unit``).
"""

from __future__ import annotations

import contextlib
import json

import bpy
import numpy as np

from ..core.collision.report import pose_collision_status
from ..core.display import (
    COLLISION_STATUS_NAMES,
    COLLISION_STATUS_RGBA,
    COLOR_BINS,  # noqa: E402 - re-exported (number of colour bins)
    MAX_POSE_EMPTIES,
    pose_indices,
    spline_bins,
    spline_pieces,
    verify_colors,
)
from ..core.display import curve_cusp as _curve_cusp
from ..core.display import flags_of as _flags
from ..core.display import move_codes_of as _move_codes
from ..core.display import ramp as _ramp
from ..core.errors import BliskCamError
from ..core.geometry.axis import angular_range
from ..core.part.profiles import morph_between
from ..core.toolpath import types as _toolpath
from .objects import arrays_to_object, colored_material, cone_to_object, mm_per_blender_unit
from .paths_text import (
    TEXT_LINE,
    from_text_lines,
    paths_json_text,
    replace_last_character,
    text_lines,
    to_text_lines,
)

__all__ = [
    "COLLECTION_PREFIX",
    "MOVE_TYPES",
    "collection_name",
    "find_output_collection",
    "output_objects",
    "stored_paths_json",
    "TEXT_LINE",
    "text_lines",
    "paths_json_text",
    "write_path_objects",
    "write_cone_objects",
    "has_paths",
    "clear_path_objects",
    "restyle",
    "attach_verify",
    "store_paths_text",
    "show_verify_map",
    "remove_verify_map",
    "curve_points_mm",
]

COLLECTION_PREFIX = "Blisk CAM – "  # en dash
#: custom property names on the output collection
KEY_BLADE = "blisk_cam_blade"
KEY_TEXT = "blisk_cam_paths_text"
#: on a collection written with ``defer_text``: the previous result's Text name, until stored
KEY_TEXT_PENDING = "blisk_cam_paths_text_pending"
KEY_CUSP = "blisk_cam_cusp"
KEY_CHORD = "blisk_cam_chord"
KEY_ROLE = "blisk_cam_role"  # on objects: "cc", "tip", "poses", "pose", "verify", CONE_ROLES
KEY_NAME = "blisk_cam_name"  # on objects: the intended name (restored after the swap)
KEY_COLLISION = "blisk_cam_collision"  # on the collection: the collision summary (JSON)
KEY_STATUS = "blisk_cam_collision_status"  # on pose empties: their pose's collision status
#: colours of the collision statuses 0 clear, 1 corrected, 2 unresolved
STATUS_RGBA = COLLISION_STATUS_RGBA
STATUS_NAMES = COLLISION_STATUS_NAMES
NEIGHBOUR_RGBA = (0.55, 0.55, 0.58, 1.0)
ASSEMBLY_RGBA = (0.35, 0.45, 0.85, 0.6)
#: per-spline values stored on the curve data (for re-colouring without the path)
KEY_S = "blisk_cam_s"
KEY_SPLINE_CUSP = "blisk_cam_spline_cusp"
#: move type names, index = code, as in ``core.toolpath`` (unknown names met in a path are
#: appended per object, see the point cloud's ``blisk_cam_move_types``)
MOVE_TYPES = tuple(getattr(_toolpath, "MOVE_NAMES", ("cut", "link", "approach", "retract",
                                                      "rapid")))
MOVE_CUT = MOVE_TYPES.index("cut")
MOVE_RAPID = MOVE_TYPES.index("rapid")

SOLID_RGBA = (0.05, 0.85, 0.95, 1.0)
#: roles, names and looks of the cone objects: (role, label, RGBA, fill)
CONE_ROLES = ("cone1", "cone2", "cone_middle")
_CONE_LOOKS = (
    ("cone1", "cone 1", (0.10, 0.45, 1.00, 0.25), False),
    ("cone2", "cone 2", (1.00, 0.40, 0.10, 0.25), True),
    ("cone_middle", "middle cone", (0.20, 0.80, 0.30, 0.25), False),
)


def collection_name(blade_name: str) -> str:
    """``"Blisk CAM – <blade>"``."""
    return f"{COLLECTION_PREFIX}{blade_name}"


def find_output_collection(blade_name: str):
    """The output collection of a blade (by its stored blade name, else by name), or None."""
    for coll in bpy.data.collections:
        if coll.get(KEY_BLADE) == blade_name and coll.name.startswith(COLLECTION_PREFIX):
            return coll
    coll = bpy.data.collections.get(collection_name(blade_name))
    return coll if coll is not None and KEY_BLADE in coll else None


def output_objects(coll) -> dict:
    """Role → object(s) of an output collection: ``cc``, ``tip``, ``links``, ``poses``,
    ``verify``, ``tool_assembly``, ``cone1``, ``cone2``, ``cone_middle`` (objects or None),
    ``pose_empties`` and ``neighbours`` (lists)."""
    out = {"cc": None, "tip": None, "links": None, "poses": None, "verify": None,
           "tool_assembly": None, "pose_empties": [], "neighbours": [],
           **dict.fromkeys(CONE_ROLES)}
    if coll is None:
        return out
    for ob in coll.all_objects:
        role = ob.get(KEY_ROLE)
        if role == "pose":
            out["pose_empties"].append(ob)
        elif role == "neighbour":
            out["neighbours"].append(ob)
        elif role in out:
            out[role] = ob
    return out


def has_paths(blade_name: str) -> bool:
    """Whether the blade has generated paths (an output collection with its stored JSON; Fit
    Cones alone makes a collection with the cone objects only)."""
    coll = find_output_collection(blade_name)
    return coll is not None and bool(coll.get(KEY_TEXT))


def stored_paths_json(blade_name: str) -> str | None:
    """The paths JSON kept for a blade's last result (exactly as written), or None."""
    coll = find_output_collection(blade_name)
    if coll is None:
        return None
    text = bpy.data.texts.get(coll.get(KEY_TEXT, ""))
    return from_text_lines(text.as_string()) if text is not None else None


# --- colours -----------------------------------------------------------------------------
def _bin_materials():
    """The COLOR_BINS ramp materials (created or reused by name)."""
    t = (np.arange(COLOR_BINS) + 0.5) / COLOR_BINS
    return [
        colored_material(f"Blisk CAM path {k:02d}", (*rgb, 1.0))
        for k, rgb in enumerate(_ramp(t))
    ]


def _remove_collection_tree(coll):
    """Delete a collection, its child collections and their objects (and the objects' data
    when nothing else uses it), in one ``batch_remove`` (removing objects one by one is
    quadratic in their number)."""
    colls = [coll, *coll.children_recursive]
    objects = {ob for c in colls for ob in c.objects}
    data = {ob.data for ob in objects if ob.data is not None}
    bpy.data.batch_remove(list(objects))
    orphans = [d for d in data if d.users == 0]
    if orphans:
        bpy.data.batch_remove(orphans)
    bpy.data.batch_remove(colls)


def _parent_collection(scene, blade):
    """The blade's first collection in this scene (its master collection otherwise)."""
    in_scene = list(scene.collection.children_recursive)
    for coll in blade.users_collection:
        if coll == scene.collection or coll in in_scene:
            return coll
    return scene.collection


def _link_under(parent, coll):
    if coll.name not in parent.children:
        parent.children.link(coll)


# --- curves ------------------------------------------------------------------------------
def _curve_object(name, point_sets, closed, f, bevel_mm):
    """A 3-D curve object of POLY splines through (k, 3) mm point sets."""
    cu = bpy.data.curves.new(name, "CURVE")
    cu.dimensions = "3D"
    cu.bevel_depth = max(float(bevel_mm), 0.0) / f
    cu.bevel_resolution = 2
    cu.use_fill_caps = True
    for pts, cyc in zip(point_sets, closed, strict=True):
        pts = np.asarray(pts, dtype=np.float64)
        if len(pts) == 0:
            continue
        sp = cu.splines.new("POLY")
        sp.points.add(len(pts) - 1)
        co = np.ones((len(pts), 4))
        co[:, :3] = pts / f
        sp.points.foreach_set("co", co.ravel())
        sp.use_cyclic_u = bool(cyc) and len(pts) > 2
    return bpy.data.objects.new(name, cu)


def _style_curves(ob, mode, cusp_tolerance):
    """Materials per spline from the stored per-spline s / cusp."""
    cu = ob.data
    s = np.asarray(cu.get(KEY_S, []), dtype=np.float64)
    cusp = np.asarray(cu.get(KEY_SPLINE_CUSP, []), dtype=np.float64)
    if len(cusp) != len(s):
        cusp = np.full(len(s), np.nan)
    cu.materials.clear()
    if mode == "SOLID":
        cu.materials.append(colored_material("Blisk CAM path solid", SOLID_RGBA))
    else:
        for mat in _bin_materials():
            cu.materials.append(mat)
    bins = spline_bins(mode, s, cusp, cusp_tolerance)
    if len(bins) == len(cu.splines) and len(bins):
        cu.splines.foreach_set("material_index", bins.astype(np.int32))


def restyle(scene, settings=None):
    """Apply the display settings (bevel, colour mode) to every output collection's path
    curves, without regenerating. Called when a display option changes."""
    settings = settings if settings is not None else getattr(scene, "blisk_cam", None)
    if settings is None:
        return
    f = mm_per_blender_unit(scene)
    for coll in bpy.data.collections:
        if KEY_BLADE not in coll:
            continue
        objs = output_objects(coll)
        for ob in (objs["cc"], objs["tip"]):
            if ob is None or ob.type != "CURVE":
                continue
            ob.data.bevel_depth = float(settings.curve_bevel) / f
            _style_curves(ob, settings.color_mode, float(coll.get(KEY_CUSP, settings.cusp)))
        if objs["links"] is not None and objs["links"].type == "CURVE":
            objs["links"].data.bevel_depth = 0.5 * float(settings.curve_bevel) / f


def curve_points_mm(ob, scene=None) -> list:
    """The spline points of a curve object in world mm: a list of (k, 3) arrays."""
    f = mm_per_blender_unit(scene)
    M = np.array(ob.matrix_world, dtype=np.float64)
    out = []
    for sp in ob.data.splines:
        co = np.empty(len(sp.points) * 4, dtype=np.float64)
        sp.points.foreach_get("co", co)
        p = co.reshape(-1, 4)[:, :3]
        out.append((p @ M[:3, :3].T + M[:3, 3]) * f)
    return out


def _links_object(name, program, f, bevel_mm):
    """The linking moves of the program (approach, retract, links on the surface and rapids
    through the air) as one curve object: a spline per run of non-cut moves, from the pose
    before the run; material 0 for feed moves, 1 for rapids. None without links."""
    tip = np.asarray(program.tip, dtype=np.float64)
    runs = [(c, a, z) for c, a, z in program.runs() if c != MOVE_CUT]
    if not runs:
        return None
    ob = _curve_object(name, [tip[max(a - 1, 0):z] for _, a, z in runs],
                       [False] * len(runs), f, 0.5 * bevel_mm)
    cu = ob.data
    cu.materials.append(colored_material("Blisk CAM link", (0.85, 0.85, 0.85, 1.0)))
    cu.materials.append(colored_material("Blisk CAM rapid", (0.9, 0.12, 0.1, 1.0)))
    idx = np.array([1 if c == MOVE_RAPID else 0 for c, _, _ in runs], dtype=np.int32)
    if len(cu.splines) == len(idx):
        cu.splines.foreach_set("material_index", idx)
    ob["blisk_cam_moves"] = [MOVE_TYPES[c] if 0 <= c < len(MOVE_TYPES) else str(c)
                             for c, _, _ in runs]
    return ob


def tool_radius(tool, default: float) -> float:
    """Cutter radius (mm) of a core cutter: ``radius``, else ``d / 2``, else ``default``."""
    r = getattr(tool, "radius", None)
    if r is None and getattr(tool, "d", None) is not None:
        r = 0.5 * float(tool.d)
    return float(r) if r is not None else float(default)


# --- poses -------------------------------------------------------------------------------
def _set_attribute(mesh, name, kind, values):
    attr = mesh.attributes.new(name, kind, "POINT")
    field = {"FLOAT_VECTOR": "vector", "FLOAT_COLOR": "color"}.get(kind, "value")
    dtype = np.int32 if kind == "INT" else np.float32
    attr.data.foreach_set(field, np.ascontiguousarray(values, dtype=dtype).ravel())
    return attr


def _points_node_group(radius_bu):
    """A Geometry Nodes group "Blisk CAM Mesh to Points" (mesh vertices → points of the
    given radius), or None when this Blender cannot build it."""
    name = "Blisk CAM Mesh to Points"
    ng = bpy.data.node_groups.get(name)
    if ng is None:
        ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
        ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        gi = ng.nodes.new("NodeGroupInput")
        go = ng.nodes.new("NodeGroupOutput")
        m2p = ng.nodes.new("GeometryNodeMeshToPoints")
        gi.location, m2p.location, go.location = (-300, 0), (0, 0), (300, 0)
        ng.links.new(gi.outputs[0], m2p.inputs["Mesh"])
        ng.links.new(m2p.outputs["Points"], go.inputs[0])
    m2p = next(n for n in ng.nodes if n.bl_idname == "GeometryNodeMeshToPoints")
    m2p.inputs["Radius"].default_value = float(radius_bu)
    return ng


def _point_cloud_object(name, path, f, radius_mm):
    """The mesh of every pose (vertex = tip) with its attributes."""
    n = path.n_poses

    def cat(key):
        if n == 0:
            return np.zeros((0, 3))
        return np.concatenate([np.asarray(getattr(c, key), dtype=np.float64) for c in path.curves])

    tips, axes, nrm, cc = cat("tip"), cat("axis"), cat("normal"), cat("cc")
    s_curve = np.array([c.s for c in path.curves], dtype=np.float64)
    levels = np.unique(s_curve)
    counts = [len(c) for c in path.curves]
    curve_id = np.repeat(np.arange(len(path.curves)), counts)
    s = s_curve[curve_id] if n else np.zeros(0)
    pass_id = np.searchsorted(levels, s)
    move, names = _move_codes(path)
    me = bpy.data.meshes.new(name)
    me.vertices.add(n)
    me.vertices.foreach_set("co", np.ascontiguousarray(tips / f, dtype=np.float32).ravel())
    _set_attribute(me, "axis", "FLOAT_VECTOR", axes)
    _set_attribute(me, "normal_cc", "FLOAT_VECTOR", nrm)
    _set_attribute(me, "cc", "FLOAT_VECTOR", cc / f)
    _set_attribute(me, "s", "FLOAT", s)
    _set_attribute(me, "pass", "INT", pass_id)
    _set_attribute(me, "curve", "INT", curve_id)
    _set_attribute(me, "move", "INT", move)
    _set_attribute(me, "status", "INT", _flags(path))
    collision = pose_collision_status(path)
    if collision is not None:
        _set_attribute(me, "collision_status", "INT", collision)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob["blisk_cam_move_types"] = names
    ob.hide_render = collision is None  # checked: the status colours render
    with contextlib.suppress(Exception):  # display only: a failure leaves a plain vertex cloud
        if collision is None:
            ng = _points_node_group(radius_mm / f)
        else:
            ng = _status_points_node_group(radius_mm / f)
        mod = ob.modifiers.new("Points", "NODES")
        mod.node_group = ng
    return ob


def _status_materials():
    """The three status materials (clear, corrected, unresolved; created or reused)."""
    return [colored_material(f"Blisk CAM collision {label}", rgba)
            for label, rgba in zip(STATUS_NAMES, STATUS_RGBA, strict=True)]


def _status_points_node_group(radius_bu):
    """A Geometry Nodes group "Blisk CAM Collision Points": mesh vertices → points of the
    given radius, one point cloud per ``collision_status`` value with its status material
    (green, orange, red), each made an instance (a point cloud holds a single material)."""
    name = "Blisk CAM Collision Points"
    ng = bpy.data.node_groups.get(name)
    if ng is None:
        ng = bpy.data.node_groups.new(name, "GeometryNodeTree")
        ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        gi = ng.nodes.new("NodeGroupInput")
        go = ng.nodes.new("NodeGroupOutput")
        m2p = ng.nodes.new("GeometryNodeMeshToPoints")
        attr = ng.nodes.new("GeometryNodeInputNamedAttribute")
        attr.data_type = "INT"
        attr.inputs["Name"].default_value = "collision_status"
        g2i = ng.nodes.new("GeometryNodeGeometryToInstance")
        gi.location, m2p.location, attr.location = (-600, 0), (-400, 0), (-600, -300)
        g2i.location, go.location = (300, 0), (500, 0)
        ng.links.new(gi.outputs[0], m2p.inputs["Mesh"])
        for k, mat in enumerate(_status_materials()):
            cmp = ng.nodes.new("FunctionNodeCompare")
            cmp.data_type, cmp.operation = "INT", "EQUAL"
            a = next(x for x in cmp.inputs if x.name == "A" and x.enabled)
            b = next(x for x in cmp.inputs if x.name == "B" and x.enabled)
            ng.links.new(attr.outputs["Attribute"], a)
            b.default_value = k
            sep = ng.nodes.new("GeometryNodeSeparateGeometry")
            sep.domain = "POINT"
            ng.links.new(m2p.outputs["Points"], sep.inputs["Geometry"])
            ng.links.new(cmp.outputs["Result"], sep.inputs["Selection"])
            sm = ng.nodes.new("GeometryNodeSetMaterial")
            sm.inputs["Material"].default_value = mat
            ng.links.new(sep.outputs["Selection"], sm.inputs["Geometry"])
            ng.links.new(sm.outputs["Geometry"], g2i.inputs["Geometry"])
            cmp.location, sep.location, sm.location = (-200, -200 * k), (0, -200 * k), \
                (150, -200 * k)
        ng.links.new(g2i.outputs[0], go.inputs[0])
    m2p = next(n for n in ng.nodes if n.bl_idname == "GeometryNodeMeshToPoints")
    m2p.inputs["Radius"].default_value = float(radius_bu)
    return ng


def _pose_frames(path, idx, f):
    """(M (k, 4, 4) world matrices in Blender units: tip at the origin, local Z = tool axis;
    status (k,) int collision status or None) of the poses ``idx`` (k,) of ``path``."""
    if len(idx) == 0:
        return np.zeros((0, 4, 4)), None
    tips = np.concatenate([c.tip for c in path.curves])[idx]
    axes = np.concatenate([c.axis for c in path.curves])[idx]
    status = pose_collision_status(path)
    status = None if status is None else status[idx]
    z = axes / np.maximum(np.linalg.norm(axes, axis=1), 1e-300)[:, None]
    ref = np.where(np.abs(z[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    x = ref - np.einsum("ij,ij->i", ref, z)[:, None] * z
    x /= np.linalg.norm(x, axis=1)[:, None]
    y = np.cross(z, x)
    M = np.zeros((len(idx), 4, 4))
    M[:, :3, 0], M[:, :3, 1], M[:, :3, 2], M[:, :3, 3] = x, y, z, tips / f
    M[:, 3, 3] = 1.0
    return M, status


def _pose_empties(coll, prefix, M, idx, status, f, size_mm):
    """Single-arrow Empties at the poses ``idx`` (frames ``M``, status ``status`` of
    :func:`_pose_frames`) in ``coll``, named ``"<prefix> pose k"``."""
    from mathutils import Matrix

    width = len(str(len(idx)))
    objs = []
    for k, m in enumerate(M):  # one object per shown pose: at most pose_count (capped)
        ob = bpy.data.objects.new(f"{prefix} pose {k:0{width}d}", None)
        ob[KEY_NAME] = f"{prefix} pose {k:0{width}d}"
        ob.empty_display_type = "SINGLE_ARROW"
        ob.empty_display_size = size_mm / f
        ob.matrix_world = Matrix(m.tolist())
        ob[KEY_ROLE] = "pose"
        ob["blisk_cam_pose_index"] = int(idx[k])
        if status is not None:  # the object colour shows in Solid view (Object colour)
            ob[KEY_STATUS] = int(status[k])
            ob.color = STATUS_RGBA[int(status[k])]
        coll.objects.link(ob)
        objs.append(ob)
    return objs


def _verify_object(bname, V, F, values, cusp, chord, f, coll):
    """The blade's verify colour-map copy "<bname> verify" in ``coll`` (role "verify")."""
    name = f"{bname} verify"
    ob = arrays_to_object(name, V, F, coll, mm_per_unit=f)
    ob[KEY_ROLE] = "verify"
    ob[KEY_NAME] = name
    me = ob.data
    rgba = verify_colors(values, cusp, chord)
    attr = me.color_attributes.new("verify", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", np.ascontiguousarray(rgba, dtype=np.float32).ravel())
    with contextlib.suppress(AttributeError, TypeError):
        me.color_attributes.active_color = attr
    with contextlib.suppress(AttributeError, TypeError):
        me.color_attributes.render_color_index = me.color_attributes.find("verify")
    _set_attribute(me, "material_left", "FLOAT", values)
    mat = bpy.data.materials.get("Blisk CAM verify") or bpy.data.materials.new("Blisk CAM verify")
    mat.diffuse_color = (0.6, 0.6, 0.6, 1.0)
    if mat.node_tree is None and bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    tree = mat.node_tree
    if tree is not None and not any(n.type == "ATTRIBUTE" for n in tree.nodes):
        bsdf = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is not None:
            node = tree.nodes.new("ShaderNodeAttribute")
            node.attribute_name = "verify"
            node.location = (bsdf.location.x - 300, bsdf.location.y)
            tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    me.materials.append(mat)
    ob.hide_render = True  # it coincides with the blade; for the viewport (Attribute colour)
    return ob


# --- cones -------------------------------------------------------------------------------
def _middle_generatrix(g1, g2, s: float = 0.5):
    """The generatrix at morph ratio ``s``: a Cone (LMC) or a Profile (LMRS)."""
    morph = morph_between(g1, g2)
    return morph.profile_at(s) if hasattr(morph, "profile_at") else morph.cone_at(s)


def _cone_objects(collection, prefix, axis, g1, g2, points, f):
    """The three cone objects (see the module docstring) in ``collection``; role → object."""
    theta = angular_range(points, axis)
    gens = {"cone1": g1, "cone2": g2, "cone_middle": _middle_generatrix(g1, g2)}
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    size = float(np.linalg.norm(np.ptp(p, axis=0))) if len(p) else 100.0
    wire = max(0.003 * size, 1e-3)
    objs = {}
    for role, label, rgba, fill in _CONE_LOOKS:
        name = f"{prefix} {label}"
        ob = cone_to_object(
            name, gens[role], axis, collection, theta=theta, segments=64, rows=6,
            color=rgba, wire=wire, fill=fill, mm_per_unit=f,
        )
        ob[KEY_ROLE] = role
        ob[KEY_NAME] = name
        objs[role] = ob
    return objs


def write_cone_objects(scene, blade, cone1, cone2, axis, points) -> dict:
    """Show cone 1, cone 2 and the middle generatrix (s = 0.5) in the blade's output
    collection (created when missing, e.g. right after Fit Cones), replacing the cone objects
    there; the paths, if any, are kept.

    Parameters
    ----------
    scene, blade : the scene and the blade object (not modified)
    cone1, cone2 : core ``Cone`` or ``Profile`` — hub and tip generatrices, mm
    axis : core ``Axis``
    points : (n, 3) float, mm — points whose angular range about the axis the cones cover
        (the blade's vertices, or the CC points)

    Returns
    -------
    dict — role (``cone1``, ``cone2``, ``cone_middle``) → object
    """
    f = mm_per_blender_unit(scene)
    bname = blade.name
    coll = find_output_collection(bname)
    if coll is None:
        coll = bpy.data.collections.new(collection_name(bname))
        coll[KEY_BLADE] = bname
        _link_under(_parent_collection(scene, blade), coll)
    old = [output_objects(coll)[role] for role in CONE_ROLES]
    old = [ob for ob in old if ob is not None]
    data = [ob.data for ob in old if ob.data is not None]
    if old:
        bpy.data.batch_remove(old)
        orphans = [d for d in data if d.users == 0]
        if orphans:
            bpy.data.batch_remove(orphans)
    objs = _cone_objects(coll, bname, axis, cone1, cone2, points, f)
    for ob in objs.values():
        ob.name = ob[KEY_NAME]
        ob.data.name = ob.name
    return objs


# --- write / clear -----------------------------------------------------------------------
def write_path_objects(
    scene,
    blade,
    path,
    settings=None,
    *,
    json_text: str | None = None,
    verify=None,
    blade_arrays=None,
    vertex_values=None,
    text: str | None = None,
    defer_text: bool = False,
) -> dict:
    """Show ``path`` (a core ``ToolPath``, mm) as objects in the blade's output collection,
    replacing the previous ones, and keep its paths JSON in a Text datablock.

    Parameters
    ----------
    scene : bpy.types.Scene
    blade : bpy.types.Object — the machined blade (not modified)
    path : core.toolpath.ToolPath
    settings : scene.blisk_cam (display options: pose_count, curve_bevel, color_mode,
        tool radius for the arrow size); default ``scene.blisk_cam``
    json_text : str, optional — the paths JSON (default :func:`paths_json_text` of ``path``)
    verify : core.verify.VerifyReport, optional — colours by measured cusp use its pairs
    blade_arrays : (V (n, 3) mm, F (m, 3)) — the blade mesh as read; with ``vertex_values``
        (n,) material left per *input* vertex (NaN outside) a verify colour-map copy is made
    text : str, optional — ``json_text``'s Text content made beforehand (:func:`text_lines`)
    defer_text : bool — no JSON now (``json_text``, ``text`` unused): :func:`store_paths_text`
        stores it later (the interactive Generate shows the paths before their JSON is made);
        until then the output holds no JSON (:func:`has_paths` is False)

    Returns
    -------
    dict — ``collection``, ``cc``, ``tip``, ``poses`` (objects), ``links`` (object or None:
    the program's linking moves), ``pose_empties`` (list), ``verify`` (object or None),
    ``cone1``, ``cone2``, ``cone_middle`` (the generatrices of the path and the one at
    s = 0.5), ``text`` (the Text datablock)
    """
    settings = settings if settings is not None else scene.blisk_cam
    if not path.curves:
        raise BliskCamError("the path has no curves: nothing to show")
    f = mm_per_blender_unit(scene)
    bname = blade.name
    name = collection_name(bname)
    if json_text is None and not defer_text:
        json_text = paths_json_text(path)

    old = find_output_collection(bname)  # replaced once the new result is complete
    new = bpy.data.collections.new(name + " (new)")
    try:
        objs, pending = _fill_output(new, bname, path, settings, f, verify, blade_arrays,
                                     vertex_values)
    except Exception:
        _remove_collection_tree(new)
        raise
    if text is None and not defer_text:
        text = to_text_lines(json_text)
    objs["text"] = _replace_output(scene, blade, old, new, pending[0], text)
    objs["pose_empties"] = _pose_empties(*pending)
    return objs


def _fill_output(new, bname, path, settings, f, verify, blade_arrays, vertex_values):
    """Fill the collection ``new`` with the objects of ``path`` for the blade named ``bname``
    (see :func:`write_path_objects`); returns the objects (dict, without the pose empties)
    and the arguments of :func:`_pose_empties` (the collection of the pose empties first)."""
    name = collection_name(bname)
    new[KEY_BLADE] = bname
    new[KEY_CUSP] = float(path.cusp)
    new[KEY_CHORD] = float(path.chord)
    if getattr(path, "collision", None):
        from ..core.toolpath.paths_io import jsonable

        new[KEY_COLLISION] = json.dumps(jsonable(path.collision), allow_nan=False)
    cusp = _curve_cusp(path, verify)
    objs = {"collection": new, "verify": None}
    for role, label, key in (("cc", "CC paths", "cc"), ("tip", "tool tips", "tip")):
        sets, closed, s, sc = spline_pieces(path, key, cusp)
        ob = _curve_object(f"{bname} {label}", sets, closed, f, settings.curve_bevel)
        ob.data[KEY_S] = s
        ob.data[KEY_SPLINE_CUSP] = [float(x) if np.isfinite(x) else -1.0 for x in sc]
        ob[KEY_ROLE] = role
        ob[KEY_NAME] = f"{bname} {label}"
        new.objects.link(ob)
        _style_curves(ob, settings.color_mode, float(path.cusp))
        objs[role] = ob
    objs["tip"].hide_render = True  # the CC curves render; tips are for the viewport
    objs["links"] = None
    program = getattr(path, "program", None)
    if program is not None and len(program):
        ob = _links_object(f"{bname} links", program, f, settings.curve_bevel)
        if ob is not None:
            ob[KEY_ROLE] = "links"
            ob[KEY_NAME] = f"{bname} links"
            ob.hide_render = True
            new.objects.link(ob)
            objs["links"] = ob
    radius = tool_radius(path.tool, settings.tool_radius)
    pc = _point_cloud_object(f"{bname} poses", path, f, max(0.05 * radius, 1e-3))
    pc[KEY_ROLE] = "poses"
    pc[KEY_NAME] = f"{bname} poses"
    new.objects.link(pc)
    objs["poses"] = pc
    poses_coll = bpy.data.collections.new(name + " poses (new)")
    new.children.link(poses_coll)
    idx = pose_indices(path.n_poses, min(int(settings.pose_count), MAX_POSE_EMPTIES))
    M, status = _pose_frames(path, idx, f)
    # the empties themselves are made once the old output is gone (write_path_objects):
    # with their final names, not renamed one by one afterwards (half the writing time)
    pending = (poses_coll, bname, M, idx, status, f, 2.0 * radius)
    cc_all = np.concatenate([np.asarray(c.cc, dtype=np.float64) for c in path.curves])
    try:
        objs.update(_cone_objects(new, bname, path.axis, path.cone1, path.cone2, cc_all, f))
    except BliskCamError:  # no morph between two generatrices (hub finishing: the hub's own)
        objs.update(dict.fromkeys(CONE_ROLES))
    if blade_arrays is not None and vertex_values is not None:
        V, F = blade_arrays
        objs["verify"] = _verify_object(bname, V, F, vertex_values, float(path.cusp),
                                        float(path.chord), f, new)
    return objs, pending


def _replace_output(scene, blade, old, new, poses_coll, lines):
    """The complete result ``new`` replaces ``old`` (removed): final names, linked beside the
    blade, the paths JSON (``lines``: :func:`to_text_lines`) in the Text datablock (the old
    one reused); returns the Text (None with ``lines`` None: the old Text's name is kept for
    :func:`store_paths_text`)."""
    name = collection_name(blade.name)
    old_text = bpy.data.texts.get(old.get(KEY_TEXT, "")) if old is not None else None
    if old is not None:
        _remove_collection_tree(old)
    new.name = name
    poses_coll.name = name + " poses"
    for ob in new.all_objects:  # drop the ".001" suffixes the old objects forced
        ob.name = ob.get(KEY_NAME, ob.name)
        if ob.data is not None:
            ob.data.name = ob.name
    _link_under(_parent_collection(scene, blade), new)
    if lines is None:
        new[KEY_TEXT_PENDING] = old_text.name if old_text is not None else ""
        return None
    return _store_text(new, lines, old_text, name + ".json")


def _store_text(coll, lines, old_text, name):
    """The paths JSON (``lines``) in the output ``coll``'s Text datablock (``old_text``, the
    previous result's, reused; else the one called ``name``, made if missing); the Text."""
    text = old_text or bpy.data.texts.get(name) or bpy.data.texts.new(name)
    text.from_string(lines)
    text.use_fake_user = True
    coll[KEY_TEXT] = text.name
    return text


def store_paths_text(blade_name: str, lines: str):
    """Store the paths JSON (``lines``: :func:`text_lines`' Text content) of the output
    :func:`write_path_objects` wrote with ``defer_text``; returns the Text, or None (nothing
    written) when that output is gone or holds its JSON already (cleared, regenerated)."""
    coll = find_output_collection(blade_name)
    if coll is None or KEY_TEXT_PENDING not in coll:
        return None
    old_text = bpy.data.texts.get(coll[KEY_TEXT_PENDING])
    del coll[KEY_TEXT_PENDING]
    return _store_text(coll, lines, old_text, collection_name(blade_name) + ".json")


def attach_verify(
    scene,
    blade,
    path,
    settings=None,
    *,
    json_text: str,
    verify,
    blade_arrays=None,
    vertex_values=None,
    text: str | None = None,
    tail: str | None = None,
) -> dict:
    """Add a verify run's figures to the output :func:`write_path_objects` wrote for ``path``
    without them (the interactive Generate shows the paths first, then verifies): afterwards
    the collection holds what ``write_path_objects(..., json_text=json_text, verify=verify,
    blade_arrays=..., vertex_values=...)`` would have written.

    * the per-spline measured cusp of the CC and tool-tip curves (from ``verify``'s pairs;
      the splines themselves do not depend on it) and their materials;
    * the Text datablock: ``json_text`` (the paths JSON with its ``"verify"`` verdict);
    * with ``blade_arrays`` and ``vertex_values`` the ``"<blade> verify"`` colour-map copy
      (replacing one already there).

    Parameters as for :func:`write_path_objects` (``text``: ``json_text``'s Text content made
    beforehand, :func:`text_lines`; ``tail``: when ``json_text`` is the stored JSON but for
    its last character, followed by ``tail`` — the verdict appended — only that character of
    the Text is replaced, by ``tail``, instead of the whole Text being rewritten). Raises
    BliskCamError when the blade has no output collection (cleared meanwhile). Returns dict
    — ``collection``, ``verify`` (object or None), ``text``.
    """
    lines = text
    if tail is not None and not json_text.endswith(tail):
        raise BliskCamError("internal: the verify JSON does not end with its tail")
    settings = settings if settings is not None else scene.blisk_cam
    bname = blade.name
    coll = find_output_collection(bname)
    if coll is None:
        raise BliskCamError(f"the paths of '{bname}' were removed before their verify "
                            "finished; generate again")
    f = mm_per_blender_unit(scene)
    objs = output_objects(coll)
    cusp = _curve_cusp(path, verify)
    for role, key in (("cc", "cc"), ("tip", "tip")):
        ob = objs[role]
        if ob is None or ob.type != "CURVE":
            continue
        _, _, _, sc = spline_pieces(path, key, cusp)
        ob.data[KEY_SPLINE_CUSP] = [float(x) if np.isfinite(x) else -1.0 for x in sc]
        _style_curves(ob, settings.color_mode, float(path.cusp))
    out = {"collection": coll, "verify": objs["verify"]}
    if blade_arrays is not None and vertex_values is not None:
        out["verify"] = _replace_verify_object(coll, objs["verify"], bname, path, blade_arrays,
                                               vertex_values, f)
    text = bpy.data.texts.get(coll.get(KEY_TEXT, ""))
    if text is None:
        text = bpy.data.texts.new(collection_name(bname) + ".json")
        text.use_fake_user = True
        coll[KEY_TEXT] = text.name
        tail = None
    if tail is None or not replace_last_character(text, tail):
        text.from_string(to_text_lines(json_text) if lines is None else lines)
    out["text"] = text
    return out


def _replace_verify_object(coll, old, bname, path, blade_arrays, vertex_values, f):
    """The verify colour map made anew in ``coll`` (``old`` removed), with its final name."""
    _remove_object(old)
    V, F = blade_arrays
    ob = _verify_object(bname, V, F, vertex_values, float(path.cusp), float(path.chord), f, coll)
    ob.name = ob[KEY_NAME]
    ob.data.name = ob.name
    return ob


def _remove_object(ob):
    """Delete ``ob`` (None: nothing) and its mesh when nothing else uses it."""
    if ob is None:
        return
    data = ob.data
    bpy.data.objects.remove(ob)
    if data is not None and data.users == 0:
        bpy.data.meshes.remove(data)


def show_verify_map(scene, blade, path, blade_arrays, vertex_values):
    """The verify colour map alone, before the other figures (arguments and object as
    :func:`attach_verify`'s, which keeps it when then given no ``blade_arrays``): the
    interactive Generate shows it as soon as the material left is measured."""
    coll = find_output_collection(blade.name)
    if coll is None:
        raise BliskCamError(f"the paths of '{blade.name}' were removed; generate again")
    return _replace_verify_object(coll, output_objects(coll)["verify"], blade.name, path,
                                  blade_arrays, vertex_values, mm_per_blender_unit(scene))


def remove_verify_map(blade_name: str):
    """Remove a blade's verify colour map (a verify dropped after :func:`show_verify_map`)."""
    _remove_object(output_objects(find_output_collection(blade_name))["verify"])


def clear_path_objects(blade_name: str) -> bool:
    """Remove a blade's output collection and its stored JSON. True if there was one."""
    coll = find_output_collection(blade_name)
    if coll is None:
        return False
    text = bpy.data.texts.get(coll.get(KEY_TEXT, ""))
    _remove_collection_tree(coll)
    if text is not None:
        bpy.data.texts.remove(text)
    return True
