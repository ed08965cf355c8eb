"""The cone gizmos in the 3D viewport (issue #5 item 4; paper 001 Fig. 2).

A persistent gizmo group draws cone 1 (hub side), cone 2 (tip side) and the middle LMC
(s = 0.5) as wire cones, and offers four draggable handles on the generatrix end points P1, P2
(cone 1) and Q1, Q2 (cone 2). The handles move in the meridional half-plane through the
blade's centroid (:mod:`.cone_frame`): the mouse ray is intersected with that plane, so a
handle follows the pointer exactly; the result is projected into the half-plane (r ≥ 0) and
written to ``scene.blisk_cam.cone1`` / ``cone2`` in mm. Each drag is one undo step (Blender
5.x: the gizmo's ``use_undo``; 4.x: an undo push when the drag ends). Esc / right click
restores the value the drag started from.

With ``scene.blisk_cam.live_preview`` the group also draws a few LMC curves of the blade
(:mod:`.lmc_preview`, s = 0, 1/6, …, 1) for the cones being dragged: recomputed while a
handle is dragged, at most every :data:`PREVIEW_INTERVAL` seconds (or every "last compute
time", if longer), plus once after the drag; otherwise the cached curves are drawn while they
match the cones. The prepared blade mesh (and its meridional index, see :mod:`.lmc_preview`)
is cached until a depsgraph update touches the blade (object transform, geometry or its mesh)
or its vertex or face count changes; no preview while the blade is in edit mode.

What does not need a window is plain functions here, tested in
``tests/blender/test_gizmos.py``: :func:`handle_get` / :func:`handle_set` (the gizmos' target
get/set handlers), :func:`scene_plane`, :func:`scene_axis`, :func:`update_preview` and the
depsgraph handler. Drawing uses ``gpu`` (not available in background mode), imported lazily.
"""

from __future__ import annotations

import time

import bpy
import numpy as np
from bpy.app.handlers import persistent
from bpy.types import Gizmo, GizmoGroup

from ..blender.objects import mm_per_blender_unit, object_axis, object_to_arrays
from ..core.errors import BliskCamError
from ..core.geometry.axis import Axis
from . import cone_frame as cf
from .lmc_preview import LmcPreview, Throttle

__all__ = [
    "BLISKCAM_GGT_cones",
    "BLISKCAM_GT_cone_handle",
    "BLISKCAM_GT_cone_lines",
    "CLASSES",
    "PREVIEW",
    "PREVIEW_INTERVAL",
    "handle_get",
    "handle_set",
    "register",
    "scene_axis",
    "scene_plane",
    "unregister",
    "update_preview",
]

#: Seconds between two preview recomputations while a handle is dragged.
PREVIEW_INTERVAL = 0.1

#: RGBA colours: cone 1 (hub), cone 2 (tip), the middle cone, a cone pair that cannot morph.
COLOR_CONE1 = (0.25, 0.6, 1.0, 0.9)
COLOR_CONE2 = (1.0, 0.6, 0.2, 0.9)
COLOR_MIDDLE = (0.85, 0.85, 0.85, 0.55)
COLOR_INVALID = (1.0, 0.2, 0.2, 0.9)

#: The cache of the live preview (arrays and a mesh key; never a bpy object).
PREVIEW = LmcPreview()
_THROTTLE = Throttle(PREVIEW_INTERVAL)
#: "wanted": a handle moved (handle_set) and its preview has not been computed yet.
_STATE = {"wanted": False}


# --- scene → plane -----------------------------------------------------------------------
def _settings(scene):
    return getattr(scene, "blisk_cam", None) if scene is not None else None


def scene_axis(scene, *, mm_per_unit=None) -> Axis:
    """The blisk axis of the scene settings (mm): the axis Empty's local Z through its origin,
    or by default the blade's world Z through its origin. Raises BliskCamError without a blade.
    """
    settings = _settings(scene)
    if settings is None or settings.blade is None:
        raise cf.GizmoError("no blade is set: choose the blade mesh in the Blisk CAM Setup panel")
    f = mm_per_blender_unit(scene) if mm_per_unit is None else mm_per_unit
    return object_axis(settings.axis_object or settings.blade, mm_per_unit=f)


def _blade_centroid_mm(obj, f) -> np.ndarray:
    """Centre of the blade's world bounding box (mm): 8 corners, no mesh read."""
    corners = np.array([tuple(c) for c in obj.bound_box], dtype=np.float64)  # (8, 3) local
    m = np.array(obj.matrix_world, dtype=np.float64)
    world = corners @ m[:3, :3].T + m[:3, 3]
    return world.mean(axis=0) * f


def scene_plane(scene) -> cf.MeridionalPlane:
    """The handles' half-plane: the scene's axis, the half-plane through the blade's centroid,
    the scene's unit scale."""
    f = mm_per_blender_unit(scene)
    axis = scene_axis(scene, mm_per_unit=f)
    theta = cf.half_plane_angle(axis, _blade_centroid_mm(_settings(scene).blade, f))
    return cf.MeridionalPlane(axis, theta, f)


# --- the target get/set handlers ----------------------------------------------------------
def handle_get(scene, name: str) -> tuple[float, float, float]:
    """World position (Blender units) of handle ``name`` (P1, P2, Q1, Q2) from the settings."""
    h = cf.handle(name)
    values = tuple(getattr(_settings(scene), h.prop))
    i, j = h.indices
    p = scene_plane(scene).to_world(values[i], values[j])
    return tuple(float(x) for x in p)


def handle_set(scene, name: str, value) -> bool:
    """Move handle ``name`` to the world position ``value`` (Blender units).

    The point is projected into the handles' half-plane (r ≥ 0) and written to the cone
    setting in mm. Returns False (and writes nothing) when the move would make the cone's two
    end points coincide (closer than :data:`cone_frame.MIN_GENERATRIX`).
    """
    h = cf.handle(name)
    settings = _settings(scene)
    r, z = scene_plane(scene).from_world(np.asarray(value, dtype=np.float64).reshape(3))
    new = cf.move_end_point(tuple(getattr(settings, h.prop)), h.end, r, z)
    if new is None:
        return False
    setattr(settings, h.prop, new)
    _STATE["wanted"] = True
    return True


def describe_handle(scene, name: str) -> str:
    """One line for the header while dragging: the handle's (r, z) and any cone problem."""
    h = cf.handle(name)
    settings = _settings(scene)
    v = tuple(getattr(settings, h.prop))
    i, j = h.indices
    text = f"Blisk CAM {name}: r {v[i]:.3f} mm, z {v[j]:.3f} mm"
    problem = cf.pair_problem(tuple(settings.cone1), tuple(settings.cone2))
    if problem:
        text += f"  —  {problem}"
    elif getattr(settings, "live_preview", False) and PREVIEW.result is not None:
        res = PREVIEW.result
        if res.error:
            text += f"  —  preview: {res.error}"
        else:
            ms = 1e3 * res.seconds_per_curve
            text += f"  —  preview {len(res.curves)} curves, {ms:.0f} ms/curve"
    return text


# --- live preview --------------------------------------------------------------------------
def _mesh_key(scene):
    """What the cached preview mesh is for: blade and mesh names (the depsgraph handler
    watches these), the unit scale, and the mesh's vertex and face counts — an edit that
    changes them is seen even where no depsgraph update ran."""
    blade = _settings(scene).blade
    me = blade.data
    data = me.name if me is not None else ""
    counts = (len(me.vertices), len(me.polygons)) if hasattr(me, "polygons") else (0, 0)
    return (blade.name, data, mm_per_blender_unit(scene), *counts)


def update_preview(
    scene, *, throttled: bool = False, enabled: bool | None = None, compute: bool = True
):
    """The live-preview result for the scene's current cones (cached), or None.

    None when the preview is off, no blade is set, the blade is in edit mode (every edit would
    re-read the mesh), the cached result is for other cones and ``compute`` is False, or —
    with ``throttled`` — the last recomputation ended less than the throttle interval ago; in
    that case a one-shot timer redraws the 3D views when the interval is over, so the last
    position of a drag is always previewed. The interval is :data:`PREVIEW_INTERVAL` or the
    time the last recomputation took, whichever is longer (at most half of a drag is spent
    computing on a big blade). Errors (bad cones, a blade without faces) come back in
    ``result.error``, never as an exception. ``enabled`` overrides the ``live_preview``
    setting (None: read it; off where properties.py lacks it).
    """
    settings = _settings(scene)
    if settings is None or settings.blade is None:
        return None
    if enabled is None:
        enabled = bool(getattr(settings, "live_preview", False))
    if not enabled or settings.blade.mode == "EDIT":
        return None
    try:
        f = mm_per_blender_unit(scene)
        axis = scene_axis(scene, mm_per_unit=f)
    except BliskCamError:
        return None
    key = _mesh_key(scene)
    cone1, cone2 = tuple(settings.cone1), tuple(settings.cone2)
    if PREVIEW.is_current(key, axis, cone1, cone2):
        _STATE["wanted"] = False
        return PREVIEW.result
    if not compute:
        return None
    if throttled and _THROTTLE.remaining() > 0.0:
        _schedule_redraw(_THROTTLE.remaining())
        return None
    blade_name = settings.blade.name

    def load():
        blade = bpy.data.objects.get(blade_name)
        return object_to_arrays(blade, mm_per_unit=f)

    t0 = time.perf_counter()
    result = PREVIEW.compute(key, load, axis, cone1, cone2)
    _THROTTLE.interval = max(PREVIEW_INTERVAL, time.perf_counter() - t0)
    _THROTTLE.mark()  # the interval runs from the end of this computation
    _STATE["wanted"] = False
    return result


def _redraw_views():
    wm = getattr(bpy.context, "window_manager", None)
    for window in getattr(wm, "windows", ()):
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                area.tag_redraw()
    return None  # one shot


def _schedule_redraw(delay: float):
    if not bpy.app.timers.is_registered(_redraw_views):
        bpy.app.timers.register(_redraw_views, first_interval=max(float(delay), 0.0) + 1e-3)


@persistent
def _on_depsgraph_update(scene, depsgraph):
    """Drop the cached preview mesh when the blade (object or its mesh) was updated."""
    if PREVIEW.mesh_key is None:
        return
    obj_name, data_name = PREVIEW.mesh_key[0], PREVIEW.mesh_key[1]
    for update in depsgraph.updates:
        idd = getattr(update.id, "original", update.id)
        if isinstance(idd, bpy.types.Object) and idd.name == obj_name:
            if update.is_updated_geometry or update.is_updated_transform:
                PREVIEW.invalidate()
                return
        elif isinstance(idd, bpy.types.Mesh) and idd.name == data_name:
            PREVIEW.invalidate()
            return


@persistent
def _on_load_post(*_args):
    PREVIEW.invalidate()


# --- drawing (gpu, lazily imported: not available in background mode) --------------------
def _octahedron() -> np.ndarray:
    """(24, 3) float32 triangles of a unit octahedron (the handle shape)."""
    e = np.eye(3)
    tris = []
    for sx in (1, -1):
        for sy in (1, -1):
            for sz in (1, -1):
                a, b, c = sx * e[0], sy * e[1], sz * e[2]
                tris.extend([a, b, c] if sx * sy * sz > 0 else [a, c, b])
    return np.asarray(tris, dtype=np.float32)


class BLISKCAM_GT_cone_handle(Gizmo):
    """A handle that moves in the plane of its ``matrix_basis`` (local XY, normal = local Z).

    Target property ``offset``: the world position in Blender units (float[3]); the gizmo
    group binds it to :func:`handle_get` / :func:`handle_set`.
    """

    bl_idname = "BLISKCAM_GT_cone_handle"
    bl_target_properties = ({"id": "offset", "type": "FLOAT", "array_length": 3},)

    __slots__ = ("shape", "handle_name", "init_value", "init_hit", "in_plane")

    def setup(self):
        if not hasattr(self, "shape"):
            self.shape = self.new_custom_shape("TRIS", _octahedron().tolist())
        self.handle_name = getattr(self, "handle_name", "")
        if hasattr(self, "use_undo"):  # Blender 5.x: the gizmo system pushes the undo step
            self.use_undo = True

    def draw(self, context):
        self.draw_custom_shape(self.shape)

    def draw_select(self, context, select_id):
        self.draw_custom_shape(self.shape, select_id=select_id)

    # --- interaction ---------------------------------------------------------------------
    def _mouse_point(self, context, event, in_plane):
        """World point (BU) under the mouse: on the handle's plane, or (fallback, a view
        edge-on to the plane) on the view plane through the start point."""
        from bpy_extras import view3d_utils

        region, rv3d = context.region, context.region_data
        xy = (event.mouse_region_x, event.mouse_region_y)
        if in_plane:
            o = np.array(view3d_utils.region_2d_to_origin_3d(region, rv3d, xy))
            u = np.array(view3d_utils.region_2d_to_vector_3d(region, rv3d, xy))
            m = np.array(self.matrix_basis, dtype=np.float64)
            return cf.ray_plane_intersection(
                o, u, m[:3, 3], m[:3, 2], min_cos=0.05, forward_only=rv3d.is_perspective
            )
        p = view3d_utils.region_2d_to_location_3d(region, rv3d, xy, tuple(self.init_value))
        return np.array(p)

    def invoke(self, context, event):
        self.init_value = np.array(self.target_get_value("offset"), dtype=np.float64)
        self.in_plane = True
        self.init_hit = self._mouse_point(context, event, True)
        if self.init_hit is None:  # looking along the plane: move in the view plane instead
            self.in_plane = False
            self.init_hit = self._mouse_point(context, event, False)
        return {"RUNNING_MODAL"}

    def modal(self, context, event, tweak):
        hit = self._mouse_point(context, event, self.in_plane)
        if hit is None:
            return {"RUNNING_MODAL"}
        delta = hit - self.init_hit
        if "PRECISE" in tweak:
            delta *= 0.1
        self.target_set_value("offset", tuple(float(x) for x in self.init_value + delta))
        if context.area is not None:
            context.area.header_text_set(describe_handle(context.scene, self.handle_name))
            context.area.tag_redraw()
        return {"RUNNING_MODAL"}

    def exit(self, context, cancel):
        if context.area is not None:
            context.area.header_text_set(None)
        if cancel:
            self.target_set_value("offset", tuple(float(x) for x in self.init_value))
        elif not hasattr(self, "use_undo"):  # Blender 4.x: one undo step per drag
            try:
                bpy.ops.ed.undo_push(message=f"Move Blisk CAM cone handle {self.handle_name}")
            except RuntimeError:
                pass


def build_line_batches(sets):
    """GPU batches of line sets ``[(points (2k, 3) BU, rgba, width px), ...]`` for
    :func:`draw_line_batches`: ``[(batch, rgba, width), ...]`` (empty sets left out). Needs a
    GPU context (a window, or ``gpu.init()`` in background mode on Blender 5.x)."""
    import gpu
    from gpu_extras.batch import batch_for_shader

    shader = gpu.shader.from_builtin("POLYLINE_UNIFORM_COLOR")
    return [
        (batch_for_shader(shader, "LINES", {"pos": np.asarray(pts, dtype=np.float32)}), rgba, w)
        for pts, rgba, w in sets
        if len(pts)
    ]


def draw_line_batches(batches):
    """Draw :func:`build_line_batches` output with the current GPU matrices (world space in a
    3D view), alpha-blended, each set with its colour and line width in pixels."""
    if not batches:
        return
    import gpu

    shader = gpu.shader.from_builtin("POLYLINE_UNIFORM_COLOR")
    gpu.state.blend_set("ALPHA")
    shader.bind()
    shader.uniform_float("viewportSize", gpu.state.viewport_get()[2:])
    for batch, rgba, width in batches:
        shader.uniform_float("lineWidth", float(width))
        shader.uniform_float("color", tuple(rgba))
        batch.draw(shader)
    gpu.state.blend_set("NONE")


class BLISKCAM_GT_cone_lines(Gizmo):
    """Not selectable: draws line sets (the cones and the preview curves) in world space.

    ``line_sets`` is ``(key, [(points (2k, 3) BU, rgba, width px), ...])``; the GPU batches
    are rebuilt only when ``key`` changes.
    """

    bl_idname = "BLISKCAM_GT_cone_lines"

    __slots__ = ("line_sets", "_batches", "_batches_key")

    def setup(self):
        self.line_sets = (None, [])
        self._batches = []
        self._batches_key = None

    def draw(self, context):
        key, sets = self.line_sets
        if key != self._batches_key or key is None:
            self._batches = build_line_batches(sets)
            self._batches_key = key
        draw_line_batches(self._batches)


def _mix(a, b, s):
    return tuple((1.0 - s) * x + s * y for x, y in zip(a, b, strict=True))


def scene_line_sets(scene, *, dragging: bool = False, preview: bool | None = None):
    """``(key, [(points (2k, 3) BU, rgba, width), ...])`` of the cones (and the preview
    curves when the live preview is on, or ``preview`` says so) for the scene; an empty list
    when nothing is set. Cone 1 and cone 2 come first, then the middle cone (s = 0.5) when
    the pair can morph (a pair that cannot is drawn in :data:`COLOR_INVALID`), then one set
    per preview level s coloured from cone 1's to cone 2's colour.

    The preview is recomputed only while a handle is ``dragging`` (throttled) or when a
    handle moved since the last computation (the trailing update after a drag); otherwise
    the cached curves are drawn if they still match the cones, nothing if they do not."""
    settings = _settings(scene)
    try:
        plane = scene_plane(scene)
    except BliskCamError:
        return (None, [])
    c1, c2 = tuple(settings.cone1), tuple(settings.cone2)
    problem = cf.pair_problem(c1, c2)
    sets = []
    for values, rgba in ((c1, COLOR_CONE1), (c2, COLOR_CONE2)):
        if cf.is_cone_set(values):
            color = COLOR_INVALID if problem else rgba
            sets.append((cf.cone_wire_lines(plane, values), color, 1.5))
    if problem is None:
        sets.append((cf.cone_wire_lines(plane, cf.middle_cone(c1, c2, 0.5)), COLOR_MIDDLE, 1.0))
    want = bool(getattr(settings, "live_preview", False)) if preview is None else preview
    result = None
    if problem is None and want:
        if dragging:
            result = update_preview(scene, throttled=True, enabled=True)
            last = PREVIEW.result
            if result is None and last is not None and last.key[0] == _mesh_key(scene):
                result = last  # between two throttled updates: keep the last curves
        else:
            result = update_preview(scene, enabled=True, compute=_STATE["wanted"])
    preview_key = None
    if result is not None and not result.error:
        f = plane.mm_per_unit
        by_s = {}
        for c in result.curves:
            by_s.setdefault(c.s, []).append(cf.polyline_lines(c.points, c.closed, f))
        for s, parts in sorted(by_s.items()):
            color = _mix(COLOR_CONE1, COLOR_CONE2, s)[:3] + (1.0,)
            sets.append((np.concatenate(parts), color, 2.0))
        preview_key = id(result)
    key = (plane.theta, plane.mm_per_unit, tuple(plane.axis.as_list()), c1, c2, preview_key)
    return (key, sets)


class BLISKCAM_GGT_cones(GizmoGroup):
    """Cone 1, cone 2 and the middle cone, with handles on P1, P2, Q1, Q2."""

    bl_idname = "BLISKCAM_GGT_cones"
    bl_label = "Blisk CAM Cones"
    bl_space_type = "VIEW_3D"
    bl_region_type = "WINDOW"
    bl_options = {"3D", "PERSISTENT"}

    @classmethod
    def poll(cls, context):
        settings = _settings(context.scene)
        if settings is None or settings.blade is None:
            return False
        if not getattr(settings, "show_gizmos", True):
            return False
        return cf.is_cone_set(tuple(settings.cone1)) or cf.is_cone_set(tuple(settings.cone2))

    def setup(self, context):
        lines = self.gizmos.new(BLISKCAM_GT_cone_lines.bl_idname)
        lines.hide_select = True
        lines.use_draw_modal = True
        lines.use_draw_scale = False
        self.lines = lines
        self.handles = {}
        for h in cf.HANDLES:
            gz = self.gizmos.new(BLISKCAM_GT_cone_handle.bl_idname)
            gz.handle_name = h.name
            gz.target_set_handler(
                "offset",
                get=lambda name=h.name: _gizmo_get(name),
                set=lambda value, name=h.name: _gizmo_set(name, value),
            )
            rgba = COLOR_CONE1 if h.prop == "cone1" else COLOR_CONE2
            gz.color = rgba[:3]
            gz.alpha = 0.9
            gz.color_highlight = (1.0, 1.0, 1.0)
            gz.alpha_highlight = 1.0
            gz.scale_basis = 0.12
            gz.use_draw_modal = True
            self.handles[h.name] = gz

    def draw_prepare(self, context):
        scene = context.scene
        settings = _settings(scene)
        try:
            plane = scene_plane(scene)
        except BliskCamError:
            for gz in self.handles.values():
                gz.hide = True
            self.lines.line_sets = (None, [])
            return
        from mathutils import Matrix

        values = {"cone1": tuple(settings.cone1), "cone2": tuple(settings.cone2)}
        dragging = False
        for h in cf.HANDLES:
            gz = self.handles[h.name]
            v = values[h.prop]
            gz.hide = not cf.is_cone_set(v)
            i, j = h.indices
            gz.matrix_basis = Matrix(plane.handle_matrix(v[i], v[j]).tolist())
            dragging = dragging or gz.is_modal
        self.lines.line_sets = scene_line_sets(scene, dragging=dragging)


def _gizmo_get(name):
    """Target getter of a handle gizmo: never raises inside Blender's draw loop."""
    try:
        return handle_get(bpy.context.scene, name)
    except BliskCamError:  # e.g. an axis Empty scaled to zero: the group hides the handles
        return (0.0, 0.0, 0.0)


def _gizmo_set(name, value):
    """Target setter of a handle gizmo (see :func:`handle_set`)."""
    try:
        handle_set(bpy.context.scene, name, value)
    except BliskCamError:
        pass  # the setting keeps its last valid value; the header names cone problems


CLASSES = [BLISKCAM_GT_cone_handle, BLISKCAM_GT_cone_lines, BLISKCAM_GGT_cones]


def register():
    """Add the depsgraph / load handlers (the classes are registered from ``CLASSES``)."""
    for lst, fn in (
        (bpy.app.handlers.depsgraph_update_post, _on_depsgraph_update),
        (bpy.app.handlers.load_post, _on_load_post),
    ):
        if fn not in lst:
            lst.append(fn)


def unregister():
    """Remove the handlers and the pending redraw timer; forget the preview cache."""
    for lst, fn in (
        (bpy.app.handlers.depsgraph_update_post, _on_depsgraph_update),
        (bpy.app.handlers.load_post, _on_load_post),
    ):
        while fn in lst:
            lst.remove(fn)
    if bpy.app.timers.is_registered(_redraw_views):
        bpy.app.timers.unregister(_redraw_views)
    PREVIEW.invalidate()
    _THROTTLE.reset()
    _THROTTLE.interval = PREVIEW_INTERVAL
    _STATE["wanted"] = False
