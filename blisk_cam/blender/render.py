"""Still previews of the scene: auto-framed camera, readable lighting, headless-safe.

Engines
-------
* ``WORKBENCH`` (default when an OpenGL context can be had): studio lighting, material
  colours, cavity and outlines, FXAA; about 2 s for the demo at 1280 × 720 on 2 cores with
  Mesa's llvmpipe (+1.5 s for the first render of a process: context and shaders). Headless
  it needs EGL: ``libegl1 libegl-mesa0 libgl1-mesa-dri`` on Debian/Ubuntu.
* ``CYCLES`` on the CPU, 4 samples of direct light, no denoiser: the fallback when there is
  no GL context (≈ 7–11 s for the demo at 1280 × 720, grainy but readable).
* ``EEVEE``: accepted as an alias of the engine's name in this Blender
  (``BLENDER_EEVEE_NEXT`` in 4.2–4.5, ``BLENDER_EEVEE`` in 5.x, :func:`eevee_engine_name`).

Blender *aborts the whole process* (an epoxy assertion or a segmentation fault) when a GL
render starts without a usable context, so the failure cannot be caught in-process.
:func:`gl_available` therefore asks a short-lived child process to create an EGL OpenGL 4.3
core context (surfaceless Mesa platform first, then the default display) with ctypes, and
caches the answer. ``BLISK_CAM_NO_GL=1`` forces the fallback; ``BLISK_CAM_RENDER_ENGINE``
overrides ``engine="AUTO"``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import bpy
import numpy as np

from ..core.errors import BliskCamError
from . import render_styles
from .objects import quiet_output
from .render_overlay import Legend, header_share, overlay_objects

__all__ = [
    "RenderError",
    "PreviewResult",
    "Legend",
    "CONE_STYLES",
    "nice_length",
    "tool_label",
    "render_preview",
    "resolve_engine",
    "eevee_engine_name",
    "gl_available",
    "frame_camera",
    "match_viewports_to_camera",
    "image_coverage",
]

CAMERA_NAME = "Blisk CAM Preview Camera"
DEFAULT_VIEW = (1.0, -0.8, 0.55)  # from the target toward the camera, world frame


class RenderError(BliskCamError):
    """A preview could not be rendered (nothing to frame, engine failure, blank image)."""


@dataclass(frozen=True)
class PreviewResult:
    """What :func:`render_preview` did: the file, the engine used, wall time and the fraction
    of pixels that differ from the background (0 would be a blank picture)."""

    path: Path
    engine: str
    seconds: float
    coverage: float


#: how the cone objects (``blisk_cam_role`` cone1/cone2/cone_middle) show in a render:
#: "outline" — only their borders as thin lines (the region stays readable, the blade is not
#: hidden behind three dense wire grids), "hidden", or "full" (as in the viewport)
CONE_STYLES = ("outline", "hidden", "full")
_CONE_ROLES = ("cone1", "cone2", "cone_middle")


def nice_length(x: float) -> float:
    """The largest 1, 2 or 5 × 10^k not above ``x`` (> 0): a scale bar's length."""
    if not (x > 0 and np.isfinite(x)):
        raise RenderError(f"a scale bar needs a positive length, got {x!r}")
    k = np.floor(np.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10.0**k <= x * (1 + 1e-12):
            return float(m * 10.0**k)
    return float(10.0**k)


def tool_label(tool: dict) -> str:
    """"Ø12 ball", "Ø10 bull r2", "Ø8 flat", "Ø6 taper 3°" from a paths-JSON tool dict (the
    diameter is twice the radius, mm)."""
    kind = str(tool.get("type", "ball"))
    d = 2.0 * float(tool.get("radius", 0.0))
    text = f"Ø{d:g} {kind}"
    if kind == "bull" and tool.get("corner_radius"):
        text += f" r{float(tool['corner_radius']):g}"
    if kind == "taper" and tool.get("taper_angle") is not None:
        text += f" {np.degrees(float(tool['taper_angle'])):.3g}°"
    return text


# --- engines -----------------------------------------------------------------------------
def eevee_engine_name() -> str:
    """The identifier of EEVEE in this Blender: ``BLENDER_EEVEE_NEXT`` (4.2–4.5) or
    ``BLENDER_EEVEE`` (5.0+, and before 4.2)."""
    return "BLENDER_EEVEE_NEXT" if (4, 2, 0) <= bpy.app.version < (5, 0, 0) else "BLENDER_EEVEE"


_EGL_PROBE = r"""
import ctypes, sys
c = ctypes
try:
    egl = c.CDLL("libEGL.so.1")
except OSError:
    sys.exit(3)
vp, ip = c.c_void_p, c.POINTER(c.c_int)
egl.eglGetProcAddress.restype = vp
egl.eglGetProcAddress.argtypes = [c.c_char_p]
egl.eglGetDisplay.restype = vp
egl.eglGetDisplay.argtypes = [vp]
egl.eglInitialize.argtypes = [vp, ip, ip]
egl.eglBindAPI.argtypes = [c.c_uint]
egl.eglChooseConfig.argtypes = [vp, ip, c.POINTER(vp), c.c_int, ip]
egl.eglCreateContext.restype = vp
egl.eglCreateContext.argtypes = [vp, vp, vp, ip]
egl.eglMakeCurrent.argtypes = [vp, vp, vp, vp]
egl.eglDestroyContext.argtypes = [vp, vp]
egl.eglTerminate.argtypes = [vp]
displays = []
gpd = egl.eglGetProcAddress(b"eglGetPlatformDisplayEXT")
if gpd:
    f = c.CFUNCTYPE(vp, c.c_uint, vp, vp)(gpd)
    displays.append(f(0x31DD, None, None))  # EGL_PLATFORM_SURFACELESS_MESA
displays.append(egl.eglGetDisplay(None))
for dpy in displays:
    if not dpy:
        continue
    major, minor = c.c_int(), c.c_int()
    if not egl.eglInitialize(dpy, c.byref(major), c.byref(minor)):
        continue
    try:
        if not egl.eglBindAPI(0x30A2):  # EGL_OPENGL_API
            continue
        # RENDERABLE_TYPE = OPENGL_BIT, SURFACE_TYPE = PBUFFER_BIT
        attrs = (c.c_int * 5)(0x3040, 0x0008, 0x3033, 0x0001, 0x3038)
        cfg, n = vp(), c.c_int()
        if not egl.eglChooseConfig(dpy, attrs, c.byref(cfg), 1, c.byref(n)) or n.value < 1:
            continue
        # OpenGL 4.3 core, what Blender asks for
        cattrs = (c.c_int * 7)(0x3098, 4, 0x30FB, 3, 0x30FD, 1, 0x3038)
        ctx = egl.eglCreateContext(dpy, cfg, None, cattrs)
        if not ctx:
            continue
        ok = egl.eglMakeCurrent(dpy, None, None, ctx)
        egl.eglMakeCurrent(dpy, None, None, None)
        egl.eglDestroyContext(dpy, ctx)
        if ok:
            sys.exit(0)
    finally:
        egl.eglTerminate(dpy)
sys.exit(4)
"""

_gl_cache: dict[str, bool] = {}


def gl_available() -> bool:
    """Whether Blender can get an OpenGL context here (for Workbench/EEVEE renders).

    True for an interactive Blender (it already has a window context) and on macOS/Windows
    (no headless EGL question there); on Linux in background mode a child process tries to
    create an EGL OpenGL 4.3 core context. ``BLISK_CAM_NO_GL=1`` forces False. Cached.
    """
    if os.environ.get("BLISK_CAM_NO_GL", "") not in ("", "0"):
        return False
    if "gl" in _gl_cache:
        return _gl_cache["gl"]
    if not bpy.app.background or not sys.platform.startswith("linux"):
        ok = True
    else:
        try:
            proc = subprocess.run(
                [sys.executable, "-I", "-c", _EGL_PROBE],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                timeout=30,
                check=False,
            )
            ok = proc.returncode == 0
        except (OSError, subprocess.SubprocessError):
            ok = False
    _gl_cache["gl"] = ok
    return ok


def resolve_engine(engine: str = "AUTO") -> str:
    """The render engine identifier to use for ``engine``.

    ``AUTO`` → ``BLENDER_WORKBENCH`` with GL, else ``CYCLES``; ``WORKBENCH`` and ``EEVEE`` (any
    spelling) fall back to ``CYCLES`` without GL too, since starting them would abort Blender.
    """
    name = (engine or "AUTO").strip().upper()
    if name == "AUTO":
        name = os.environ.get("BLISK_CAM_RENDER_ENGINE", "AUTO").strip().upper() or "AUTO"
    if name in ("AUTO", "WORKBENCH", "BLENDER_WORKBENCH"):
        return "BLENDER_WORKBENCH" if gl_available() else "CYCLES"
    if name in ("EEVEE", "BLENDER_EEVEE", "BLENDER_EEVEE_NEXT"):
        return eevee_engine_name() if gl_available() else "CYCLES"
    if name == "CYCLES":
        return "CYCLES"
    raise RenderError(f"unknown render engine '{engine}'; use AUTO, WORKBENCH, EEVEE or CYCLES")


# --- framing -----------------------------------------------------------------------------
def _world_points(objects, depsgraph, max_points=20000):
    """World points to frame: up to ``max_points`` vertices of each evaluated mesh (a curved
    sector's bounding box is much larger than its picture), bounding-box corners otherwise."""
    pts = []
    for ob in objects:
        m = np.array(ob.matrix_world, dtype=np.float64)
        if ob.type == "EMPTY":
            pts.append(m[:3, 3][None, :])
            continue
        ev = ob.evaluated_get(depsgraph)
        local = None
        if ob.type == "MESH":
            mesh = ev.to_mesh()
            try:
                n = len(mesh.vertices) if mesh is not None else 0
                if n:
                    co = np.empty(n * 3, dtype=np.float32)
                    mesh.vertices.foreach_get("co", co)
                    local = co.reshape(-1, 3)[:: max(1, n // max_points)].astype(np.float64)
            finally:
                ev.to_mesh_clear()
        if local is None:
            local = np.array([tuple(c) for c in ev.bound_box], dtype=np.float64)
        pts.append(local @ m[:3, :3].T + m[:3, 3])
    if not pts:
        return np.zeros((0, 3))
    p = np.concatenate(pts)
    return p[np.all(np.isfinite(p), axis=1)]


def _look_rotation(back):
    """3×3 rotation whose columns are the camera's right, up and back (local X, Y, Z)."""
    back = back / np.linalg.norm(back)
    up = np.array([0.0, 0.0, 1.0])
    if abs(back @ up) > 0.99:
        up = np.array([0.0, 1.0, 0.0])
    right = np.cross(up, back)
    right /= np.linalg.norm(right)
    cam_up = np.cross(back, right)
    return np.stack([right, cam_up, back], axis=1)


def frame_camera(scene, objects, *, view=DEFAULT_VIEW, resolution=(1280, 720), margin=0.06,
                 top_reserve=0.0):
    """Create (or reuse) the preview camera, aimed along ``-view`` and placed so that
    ``objects`` (their evaluated vertices, subsampled; bounding boxes for non-meshes) fill
    the frame with ``margin`` (fraction) to spare. ``top_reserve`` (fraction of the height)
    is kept free at the top of the picture (a header), by a vertical lens shift.

    Returns the camera object (linked to the scene's master collection).
    """
    from mathutils import Matrix

    corners = _world_points(objects, bpy.context.evaluated_depsgraph_get())
    if len(corners) == 0:
        raise RenderError("nothing to frame: no visible object with a bounding box")
    center = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    rot = _look_rotation(np.asarray(view, dtype=np.float64))
    rel = (corners - center) @ rot  # (x right, y up, w toward the camera)

    cam = bpy.data.objects.get(CAMERA_NAME)
    if cam is None or cam.type != "CAMERA":
        cam = bpy.data.objects.new(CAMERA_NAME, bpy.data.cameras.new(CAMERA_NAME))
    if cam.name not in scene.collection.objects:
        scene.collection.objects.link(cam)
    data = cam.data
    data.type = "PERSP"
    data.sensor_fit = "AUTO"
    data.lens = 40.0
    w, h = resolution
    tan_big = (0.5 * data.sensor_width / data.lens) * (1.0 - margin)
    tan_x, tan_y = (tan_big, tan_big * h / w) if w >= h else (tan_big * w / h, tan_big)
    reserve = min(max(float(top_reserve), 0.0), 0.5)
    data.shift_x = 0.0
    # the window is shifted up by reserve × its height: the objects fit the lower part
    data.shift_y = reserve * tan_y / (2.0 * tan_big) if reserve else 0.0
    tan_y = tan_y * (1.0 - reserve)
    # back off along the view direction until every point is inside the frustum, then
    # slide sideways to centre the picture (a few rounds: each changes the perspective)
    extent = max(float(np.ptp(rel[:, 0])), float(np.ptp(rel[:, 1])), 1e-9)

    def fit(shift):
        x, y, w_ = rel[:, 0] - shift[0], rel[:, 1] - shift[1], rel[:, 2]
        d = float(np.max(np.maximum(w_ + np.abs(x) / tan_x, w_ + np.abs(y) / tan_y)))
        d = max(d, float(np.max(w_)) + 1e-3 * extent)
        return d, x / (d - w_), y / (d - w_)

    shift = np.zeros(2)
    for _ in range(4):
        dist, px, py = fit(shift)
        shift = shift + np.array([px.max() + px.min(), py.max() + py.min()]) * 0.5 * dist
    dist, _, _ = fit(shift)
    depth = dist - rel[:, 2]
    data.clip_start = max(float(depth.min()) * 0.5, float(depth.max()) * 1e-4)
    data.clip_end = float(depth.max()) * 2.0
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = center + rot[:, 0] * shift[0] + rot[:, 1] * shift[1] + dist * rot[:, 2]
    cam.matrix_world = Matrix(m.tolist())
    return cam


def match_viewports_to_camera(cam, target=None):
    """Point every 3D viewport of the file (all screens) through ``cam`` at ``target`` (an
    object; default the camera's frame centre), so a saved .blend opens on the subject.
    Widens the viewports' clip range to the camera's."""
    m = np.array(cam.matrix_world, dtype=np.float64)
    loc, back = m[:3, 3], m[:3, 2] / np.linalg.norm(m[:3, 2])
    if target is not None:
        dist = float(np.dot(loc - np.array(target.matrix_world.translation), back))
        corners = _world_points([target], bpy.context.evaluated_depsgraph_get(), 2000)
        if len(corners):
            dist = float(np.mean((loc - corners) @ back))
    else:
        dist = 0.5 * (cam.data.clip_start + cam.data.clip_end)
    dist = max(dist, 1e-3)
    quat = cam.matrix_world.to_quaternion()
    for screen in bpy.data.screens:
        for area in screen.areas:
            if area.type != "VIEW_3D":
                continue
            for space in area.spaces:
                if space.type != "VIEW_3D" or space.region_3d is None:
                    continue
                r3d = space.region_3d
                r3d.view_perspective = "PERSP"
                r3d.view_rotation = quat
                r3d.view_distance = dist
                r3d.view_location = tuple(loc - dist * back)
                space.clip_start = min(space.clip_start, cam.data.clip_start)
                space.clip_end = max(space.clip_end, cam.data.clip_end)


# --- render ------------------------------------------------------------------------------
class _Saved:
    """Remembers attributes before changing them, restores them in reverse order."""

    def __init__(self):
        self._items = []

    def set(self, owner, attr, value):
        try:
            old = getattr(owner, attr)
        except AttributeError:
            return
        if hasattr(old, "__len__") and not isinstance(old, (str, bytes, bpy.types.bpy_struct)):
            old = tuple(old)  # a copy of arrays/vectors, not a view of the property
        self._items.append((owner, attr, old))
        try:
            setattr(owner, attr, value)
        except (TypeError, AttributeError, ValueError):
            self._items.pop()

    def restore(self):
        while self._items:
            owner, attr, old = self._items.pop()
            try:
                setattr(owner, attr, old)
            except (TypeError, AttributeError, ValueError, ReferenceError):
                pass


#: Workbench anti-aliasing per quality. Every AA sample re-renders the frame, which costs
#: ≈ 0.6 s at 1280 × 720 on Mesa llvmpipe (2 cores): "8" takes ~5 s, FXAA ~1.5 s.
WORKBENCH_AA = {"fast": "FXAA", "high": "8"}


def _setup_workbench(scene, saved, quality="fast", overlay=False, outline=True):
    shading = scene.display.shading
    saved.set(shading, "light", "STUDIO")
    saved.set(shading, "color_type", "MATERIAL")
    saved.set(shading, "show_cavity", True)
    saved.set(shading, "cavity_type", "WORLD")
    # the dark object outline doubles the apparent width of a thin path tube
    saved.set(shading, "show_object_outline", outline)
    # no sheen with an overlay: it greys the camera-facing title band and text
    saved.set(shading, "show_specular_highlight", not overlay)
    saved.set(shading, "show_shadows", False)
    saved.set(shading, "show_backface_culling", False)
    saved.set(shading, "show_xray", False)
    saved.set(scene.display, "render_aa", WORKBENCH_AA.get(quality, "FXAA"))


def _setup_cycles(scene, saved, temporary, quality="fast"):
    cy = scene.cycles
    saved.set(cy, "device", "CPU")
    fast = quality == "fast"
    # Costs on 2 cores at 1280 × 720 (the demo): ≈ 1.3 s per sample with one bounce, and
    # OpenImageDenoise adds ≈ 10 s, so "fast" is 4 samples of direct light, no denoiser.
    saved.set(cy, "samples", 4 if fast else 64)
    saved.set(cy, "use_adaptive_sampling", not fast)
    saved.set(cy, "max_bounces", 1 if fast else 4)
    saved.set(cy, "diffuse_bounces", 1 if fast else 3)
    saved.set(cy, "glossy_bounces", 0 if fast else 2)
    saved.set(cy, "transmission_bounces", 0 if fast else 2)
    saved.set(cy, "volume_bounces", 0)
    saved.set(cy, "transparent_max_bounces", 8)
    saved.set(cy, "caustics_reflective", False)
    saved.set(cy, "caustics_refractive", False)
    saved.set(cy, "use_denoising", (not fast) and _cycles_denoiser_available())
    saved.set(scene.render, "use_persistent_data", False)
    # a key and a fill sun, added for this render only
    for name, energy, rot in (
        ("Blisk CAM Preview Key", 3.0, (0.75, 0.0, 0.6)),
        ("Blisk CAM Preview Fill", 1.0, (1.1, 0.0, 3.6)),
    ):
        light = bpy.data.lights.new(name, "SUN")
        light.energy = energy
        light.angle = 0.05  # nearly sharp: little noise at few samples
        ob = bpy.data.objects.new(name, light)
        ob.rotation_euler = rot
        scene.collection.objects.link(ob)
        temporary.append(ob)


def _preview_world(background):
    """A new world of one flat colour: ``world.color`` (Workbench, and Cycles/EEVEE in 4.x
    where a new world has no nodes) and the Background node of its node tree (Blender 5
    gives every world one)."""
    world = bpy.data.worlds.new("Blisk CAM Preview World")
    rgb = tuple(float(c) for c in background)[:3]
    world.color = rgb
    tree = world.node_tree
    if tree is not None:
        for node in tree.nodes:
            if node.type == "BACKGROUND":
                node.inputs["Color"].default_value = (*rgb, 1.0)
                node.inputs["Strength"].default_value = 1.0
    return world


def _cycles_denoiser_available() -> bool:
    try:
        import _cycles

        return bool(getattr(_cycles, "with_openimagedenoise", False))
    except ImportError:
        return False


def image_coverage(path, background=None, *, threshold=0.03) -> float:
    """Fraction of the pixels of an image file that differ from the background colour.

    ``background``: RGB in [0, 1] as stored in the file; default the most common of the four
    corner pixels. A pixel differs if any channel differs by more than ``threshold``.
    """
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        ch = img.channels
        px = np.empty(w * h * ch, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    if w == 0 or h == 0:
        return 0.0
    rgb = px.reshape(h, w, ch)[:, :, :3]
    if background is None:
        corners = np.array([rgb[0, 0], rgb[0, -1], rgb[-1, 0], rgb[-1, -1]])
        dists = np.abs(corners[:, None] - corners[None]).max(axis=2)
        background = corners[int(np.argmax((dists < threshold).sum(axis=1)))]
    diff = np.abs(rgb - np.asarray(background, dtype=np.float32)).max(axis=2) > threshold
    return float(diff.mean())


def _mesh_boundary_edges(ob):
    """(k, 2, 3) world coordinates of the boundary edges of a mesh object's base mesh (edges
    used by one face): the border of a cone patch."""
    me = ob.data
    n = len(me.loops)
    if n == 0:
        return np.zeros((0, 2, 3))
    lv = np.empty(n, dtype=np.int32)
    me.loops.foreach_get("vertex_index", lv)
    start = np.empty(len(me.polygons), dtype=np.int32)
    total = np.empty(len(me.polygons), dtype=np.int32)
    me.polygons.foreach_get("loop_start", start)
    me.polygons.foreach_get("loop_total", total)
    nxt = np.arange(n) + 1
    last = start + total - 1
    nxt[last] = start  # each polygon's last loop closes to its first
    e = np.sort(np.stack([lv, lv[nxt]], axis=1), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    border = keys[counts == 1]
    co = np.empty(len(me.vertices) * 3, dtype=np.float64)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    m = np.array(ob.matrix_world, dtype=np.float64)
    world = co @ m[:3, :3].T + m[:3, 3]
    return world[border]


def _style_cones(scene, style, saved, temporary, extent):
    """Apply a :data:`CONE_STYLES` style to the scene's cone objects for one render."""
    if style not in CONE_STYLES:
        raise RenderError(f"cone style must be one of {', '.join(CONE_STYLES)}, got {style!r}")
    if style == "full":
        return
    from .objects import colored_material

    for ob in list(scene.objects):
        role = ob.get("blisk_cam_role")
        if role not in _CONE_ROLES or ob.type != "MESH" or ob.hide_render:
            continue
        saved.set(ob, "hide_render", True)
        if style != "outline" or role == "cone_middle":
            continue
        seg = _mesh_boundary_edges(ob)
        if len(seg) == 0:
            continue
        cu = bpy.data.curves.new(f"{ob.name} outline", "CURVE")
        cu.dimensions = "3D"
        cu.bevel_depth = 0.0012 * extent
        cu.bevel_resolution = 1
        pts = np.ones((len(seg), 2, 4))
        pts[:, :, :3] = seg
        for p in pts:
            sp = cu.splines.new("POLY")
            sp.points.add(1)
            sp.points.foreach_set("co", p.ravel())
        rgba = (0.5, 0.5, 0.5, 1.0)
        if ob.data.materials and ob.data.materials[0] is not None:
            rgba = tuple(ob.data.materials[0].diffuse_color)[:3] + (1.0,)
        cu.materials.append(colored_material(f"Blisk CAM render {role} outline", rgba))
        line = bpy.data.objects.new(f"{ob.name} outline", cu)
        scene.collection.objects.link(line)
        temporary.append(line)


def default_objects(scene):
    return [
        ob
        for ob in scene.objects
        if ob.type in {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES", "POINTCLOUD"}
        and ob.visible_get()
        and not ob.hide_render
    ]


def _pixel_size(cam, pts, resolution):
    """(Blender units per pixel at the depth of the centre of ``pts``, that depth)."""
    m = np.array(cam.matrix_world, dtype=np.float64)
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0)) if len(pts) else m[:3, 3]
    depth = float((m[:3, 3] - centre) @ (m[:3, 2] / np.linalg.norm(m[:3, 2])))
    w, h = resolution
    data = cam.data
    tan_big = 0.5 * data.sensor_width / data.lens
    tan_x = tan_big if w >= h else tan_big * w / h
    return 2.0 * max(depth, 0.0) * tan_x / w, depth


def _annotations(scene, cam, pts, px, resolution, *, title, legend, scale_bar):
    """The overlay objects (title, legends, scale bar) of a preview framed by ``cam`` on the
    points ``pts``; ``px`` Blender units per pixel at their depth."""
    from .objects import mm_per_blender_unit

    scale = None
    if scale_bar and len(pts) and px > 0:
        mm_per_px = px * mm_per_blender_unit(scene)
        scale = (nice_length(0.2 * resolution[0] * mm_per_px), mm_per_px)
    return overlay_objects(scene, cam, resolution, title=title, legend=legend, scale=scale)


def _set_render_output(scene, saved, cam, eng, resolution, path):
    """Camera, engine, size and an 8-bit RGB PNG at exactly ``path``, colour management
    neutral (every value saved in ``saved`` for restoring)."""
    w, h = resolution
    r = scene.render
    saved.set(scene, "camera", cam)
    saved.set(r, "engine", eng)
    saved.set(r, "resolution_x", w)
    saved.set(r, "resolution_y", h)
    saved.set(r, "resolution_percentage", 100)
    saved.set(r, "filepath", str(path))
    saved.set(r, "use_file_extension", False)
    saved.set(r, "film_transparent", False)
    saved.set(r, "use_compositing", False)
    saved.set(r, "use_sequencer", False)
    saved.set(r.image_settings, "file_format", "PNG")
    saved.set(r.image_settings, "color_mode", "RGB")
    saved.set(r.image_settings, "color_depth", "8")
    saved.set(scene.view_settings, "view_transform", "Standard")
    saved.set(scene.view_settings, "look", "None")
    saved.set(scene.view_settings, "exposure", 0.0)
    saved.set(scene.view_settings, "gamma", 1.0)


def _render_still(scene, eng, path):
    """Render the scene to ``path``; :class:`RenderError` with Blender's first error line when
    no image is written."""
    path.unlink(missing_ok=True)  # so that a stale file cannot pass for this render
    with quiet_output() as out:
        try:
            result = bpy.ops.render.render(write_still=True, scene=scene.name)
            error = ""
        except RuntimeError as exc:
            result, error = None, str(exc)
    if result is None or "FINISHED" not in result or not path.exists():
        log = out[0] if out else ""
        detail = error.strip() or next(
            (ln for ln in log.splitlines() if "rror" in ln), "no image written"
        )
        raise RenderError(f"render with {eng} failed: {detail.splitlines()[0]}")


def _remove_temporary(temporary):
    """Remove the preview's own objects and worlds, with their data once unused."""
    for item in temporary:
        if isinstance(item, bpy.types.Object):
            data = item.data
            bpy.data.objects.remove(item, do_unlink=True)
            if isinstance(data, bpy.types.Light) and data.users == 0:
                bpy.data.lights.remove(data)
            elif isinstance(data, bpy.types.Curve) and data.users == 0:
                bpy.data.curves.remove(data)
            elif isinstance(data, bpy.types.Mesh) and data.users == 0:
                bpy.data.meshes.remove(data)
        elif isinstance(item, bpy.types.World) and item.users == 0:
            bpy.data.worlds.remove(item)


def _release_camera(scene, cam, *, keep, existed):
    """Leave the preview camera active (``keep``), or remove it unless it was there before."""
    if keep:
        scene.camera = cam
    elif not existed:
        data = cam.data
        bpy.data.objects.remove(cam, do_unlink=True)
        if data.users == 0:
            bpy.data.cameras.remove(data)


def render_preview(
    filepath,
    engine="AUTO",
    resolution=(1280, 720),
    objects=None,
    *,
    scene=None,
    view=DEFAULT_VIEW,
    background=(0.045, 0.05, 0.06),
    keep_camera=False,
    min_coverage=1e-3,
    quality="fast",
    cones="full",
    title=None,
    legend=None,
    scale_bar=False,
    neighbours="full",
    assembly="full",
    poses="full",
    paths=(),
):
    """Render a still PNG of the scene, framed on ``objects``.

    Parameters
    ----------
    filepath : str or Path — the PNG to write (exactly this path, parents created)
    engine : "AUTO" | "WORKBENCH" | "EEVEE" | "CYCLES" (or Blender identifiers)
    resolution : (width, height) pixels
    objects : iterable of Object, optional — what to frame (default: every visible
        renderable object of the scene). Everything visible is rendered either way.
    view : 3 floats — direction from the framed objects toward the camera (world frame)
    background : RGB (linear) — world colour used while rendering
    keep_camera : bool — leave the preview camera in the scene as the active camera (the
        render settings are restored either way)
    min_coverage : float — fraction of non-background pixels below which the picture counts
        as blank and :class:`RenderError` is raised
    quality : "fast" (Workbench FXAA, Cycles 8 samples) or "high" (8× AA, 64 samples)
    cones : one of :data:`CONE_STYLES` — the cone objects in this render ("full": as they are)
    title : str, optional — a line of text at the top left (blade, tool, tolerances)
    legend : :class:`Legend` or a list of them, optional — what the colours mean (the path
        ramp, the collision statuses, the verify map), one header row each under the title
    scale_bar : bool — a bar of a round length in mm (about a fifth of the width) with its
        label on a dark plate at the bottom left, true at the depth of the framed objects'
        centre, its text at least 12 px high
    neighbours : one of ``render_styles.NEIGHBOUR_STYLES`` — the neighbour blades: "cut"
        away where they would hide the framed objects (the rest kept, the cut part outlined)
    assembly : one of ``render_styles.ASSEMBLY_STYLES`` — the tool assembly at the worst
        pose: "outline" draws its silhouette and shoulder rings as thin light lines
    poses : one of ``render_styles.POSE_STYLES`` — "status": the checked pose points as
        small markers, larger for corrected and unresolved poses
    paths : curve objects (the path tubes) made thin against their pass spacing for this
        render (12 % of it, 1.5–6 px); they count as framed for the neighbour cut

    Returns
    -------
    PreviewResult
    """
    t0 = time.perf_counter()
    scene = scene or bpy.context.scene
    path = Path(filepath).expanduser().resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    objects = list(objects) if objects is not None else default_objects(scene)
    if not objects:
        raise RenderError("nothing to render: the scene has no visible object")
    eng = resolve_engine(engine)
    w, h = (int(v) for v in resolution)
    if w < 1 or h < 1:
        raise RenderError(f"resolution must be positive, got {resolution}")
    for what, value, allowed in (("neighbour", neighbours, render_styles.NEIGHBOUR_STYLES),
                                 ("assembly", assembly, render_styles.ASSEMBLY_STYLES),
                                 ("pose", poses, render_styles.POSE_STYLES)):
        if value not in allowed:
            raise RenderError(f"{what} style must be one of {', '.join(allowed)}, got {value!r}")

    saved = _Saved()
    temporary = []
    had_camera = bpy.data.objects.get(CAMERA_NAME) is not None
    cam = None
    try:
        annotated = bool(title or legend is not None or scale_bar)
        # room for the header and the scale bar when annotated
        cam = frame_camera(scene, objects, view=view, resolution=(w, h),
                           margin=0.06, top_reserve=header_share((w, h), title, legend))
        dg = bpy.context.evaluated_depsgraph_get()
        pts = _world_points(objects, dg, 2000)
        extent = float(np.ptp(pts, axis=0).max()) if len(pts) else 1.0
        px, _ = _pixel_size(cam, pts, (w, h))
        _style_cones(scene, cones, saved, temporary, extent)
        paths = [ob for ob in paths if ob is not None]
        render_styles.thin_path_tubes(paths, px, saved)
        subject = [ob for ob in objects + paths
                   if ob.get("blisk_cam_role") not in ("neighbour", "tool_assembly")]
        render_styles.style_neighbours(scene, cam, _world_points(subject, dg, 50000), px,
                                       neighbours, saved, temporary)
        render_styles.style_assembly(scene, cam, px, assembly, saved, temporary)
        render_styles.style_poses(scene, px, poses, saved, temporary)
        if annotated:
            temporary.extend(_annotations(scene, cam, pts, px, (w, h), title=title,
                                          legend=legend, scale_bar=scale_bar))
        _set_render_output(scene, saved, cam, eng, (w, h), path)
        # a plain-colour world of our own for the render; the scene's world is left alone
        world = _preview_world(background)
        temporary.append(world)
        saved.set(scene, "world", world)
        if eng == "CYCLES":
            with quiet_output():  # Cycles logs its GPU library probing (CUDA, HIP...)
                _setup_cycles(scene, saved, temporary, quality)
        elif eng == "BLENDER_WORKBENCH":
            _setup_workbench(scene, saved, quality, overlay=annotated, outline=not paths)
        _render_still(scene, eng, path)
    finally:
        saved.restore()
        _remove_temporary(temporary)
        if cam is not None:
            _release_camera(scene, cam, keep=keep_camera, existed=had_camera)

    coverage = image_coverage(path)
    if coverage < min_coverage:
        raise RenderError(
            f"the preview {path.name} is blank ({coverage:.2%} of the pixels differ from the "
            "background): are the objects hidden or outside the view?"
        )
    return PreviewResult(path, eng, time.perf_counter() - t0, coverage)
