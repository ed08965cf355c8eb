"""The boundary between Blender and the core: mesh files and objects ↔ numpy arrays.

Everything the core sees is ``V`` (n, 3) float64 in millimetres in the world frame and ``F``
(m, 3) int64 triangles (ARCHITECTURE.md). This module reads meshes through Blender's own
importers and the evaluated depsgraph, moves data in bulk with ``foreach_get`` /
``foreach_set`` (no per-vertex Python loops) and builds the display objects (meshes, cone
surfaces, the axis) back from arrays.

Units
-----
Mesh files (STL, OBJ, PLY) carry no unit; CAM meshes are in millimetres. The factor between
Blender units and millimetres is :func:`mm_per_blender_unit`:

* ``unit_settings.scale_length == 1`` (the default, untouched scene): **one Blender unit is
  one millimetre**. A mesh in mm imported with the default settings keeps its numbers, and
  they come out of :func:`object_to_arrays` unchanged.
* any other ``scale_length``: Blender's own meaning, ``BU × scale_length`` = metres, so
  ``mm = BU × scale_length × 1000``. Blender's "Millimeters" preset (0.001) therefore also
  gives 1 BU = 1 mm, "Centimeters" (0.01) 1 BU = 10 mm, inches (0.0254) 25.4 mm.

:func:`import_mesh_file` scales by ``1 / mm_per_blender_unit`` so that a file in mm lands at
its true size in any scene, and :func:`arrays_to_object` does the same for arrays in mm.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np

from ..core.errors import BliskCamError
from ..core.geometry.axis import Axis, revolve
from ..core.part.cones import Cone
from ..core.part.profiles import generatrix_rows

__all__ = [
    "InputError",
    "SUPPORTED_EXTENSIONS",
    "mm_per_blender_unit",
    "import_mesh_file",
    "object_to_arrays",
    "blade_and_rest",
    "arrays_to_object",
    "cone_to_object",
    "axis_to_object",
    "object_axis",
    "ensure_collection",
    "colored_material",
    "quiet_output",
]


class InputError(BliskCamError):
    """A mesh file or a Blender object cannot be used as input (missing, unreadable, empty,
    not a mesh, NaN coordinates)."""


#: file extension → importer operator in ``bpy.ops.wm`` (Blender ≥ 4.2, the C++ importers)
SUPPORTED_EXTENSIONS = {".stl": "stl_import", ".obj": "obj_import", ".ply": "ply_import"}

# Object types whose evaluated form is a mesh (to_mesh works).
_MESHLIKE = {"MESH", "CURVE", "SURFACE", "META", "FONT", "CURVES"}


# --- units -------------------------------------------------------------------------------
def mm_per_blender_unit(scene=None) -> float:
    """Millimetres per Blender unit in ``scene`` (default: the context scene).

    1.0 for the default scene (``scale_length`` = 1) and for Blender's millimetre preset
    (``scale_length`` = 0.001); ``scale_length × 1000`` otherwise. See the module docstring.
    """
    if scene is None:
        scene = bpy.context.scene
    scale = float(scene.unit_settings.scale_length) if scene is not None else 1.0
    if not math.isfinite(scale) or scale <= 0.0 or scale == 1.0:
        return 1.0
    # RNA keeps scale_length as a float32 (0.001 reads back as 0.00100000005, which made a
    # millimetre scene scale every coordinate by 1 + 4.7e-8): 7 significant digits recover
    # the value that was set
    return float(f"{scale:.7g}") * 1000.0


def _factor(mm_per_unit, scene=None) -> float:
    f = mm_per_blender_unit(scene) if mm_per_unit is None else float(mm_per_unit)
    if not (math.isfinite(f) and f > 0.0):
        raise InputError(f"mm per Blender unit must be a positive number, got {mm_per_unit!r}")
    return f


# --- quiet C-level output ----------------------------------------------------------------
@contextlib.contextmanager
def quiet_output(enabled=True):
    """Send what Blender's C code prints on file descriptors 1 and 2 to a temporary file.

    Blender's importers and renderer log timers, "Saved: ..." and EGL probing noise on the
    process' stdout/stderr, which the batch CLI must keep clean (one line on error). Yields a
    list that receives the captured text when the block ends. Set the environment variable
    ``BLISK_CAM_VERBOSE=1`` (or ``enabled=False``) to let everything through.
    """
    captured = []
    if not enabled or os.environ.get("BLISK_CAM_VERBOSE"):
        yield captured
        return
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    try:
        saved = (os.dup(1), os.dup(2))
    except OSError:  # no real descriptors (embedded interpreter): nothing to redirect
        yield captured
        return
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        try:
            os.dup2(tmp.fileno(), 1)
            os.dup2(tmp.fileno(), 2)
            yield captured
        finally:
            for stream in (sys.stdout, sys.stderr):
                with contextlib.suppress(Exception):
                    stream.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            tmp.seek(0)
            captured.append(tmp.read().decode("utf-8", "replace"))


def _blender_error_lines(text: str) -> str:
    """The lines of captured Blender output that report an error, joined on one line."""
    lines = [ln.strip() for ln in text.splitlines() if "error" in ln.lower()]
    # keep the most specific few (the importer's own words), without timers and paths noise
    return "; ".join(dict.fromkeys(lines[-3:]))


# --- reading -----------------------------------------------------------------------------
def _vertex_coordinates(mesh) -> np.ndarray:
    """(n, 3) float32 vertex coordinates of a mesh, in the mesh's own frame (bulk copy)."""
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def _non_finite_message(what: str, V) -> str | None:
    bad = ~np.all(np.isfinite(V), axis=1)
    k = int(np.count_nonzero(bad))
    if k == 0:
        return None
    first = int(np.flatnonzero(bad)[0])
    return (
        f"{what}: {k} vertex{'es' if k > 1 else ''} with NaN or infinite coordinates "
        f"(first: vertex {first}); fix or re-export the mesh"
    )


_NONFINITE_TEXT = {
    # the lines whose numbers are positions; Blender's parsers silently read "nan" as 0
    ".stl": re.compile(rb"(?im)^[ \t]*vertex[ \t][^\n]*?\b(?:nan|inf(?:inity)?)\b"),
    ".obj": re.compile(rb"(?im)^[ \t]*v[ \t][^\n]*?\b(?:nan|inf(?:inity)?)\b"),
    ".ply": re.compile(rb"(?i)\b(?:nan|inf(?:inity)?)\b"),
}


def _scan_text_for_nonfinite(path: Path, ext: str) -> str | None:
    """For text files only: the first line with a NaN/inf position, or None.

    Blender's STL/OBJ parsers turn "nan" into 0 without a word, so the only way to notice a
    NaN in a text file is to look at the text. Binary files keep NaN bit patterns and are
    checked on the imported arrays instead.
    """
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(512)
    if ext == ".stl":
        if len(head) >= 84:
            n = int.from_bytes(head[80:84], "little")
            if size == 84 + 50 * n:
                return None  # binary STL
        if not head.lstrip().lower().startswith(b"solid"):
            return None
        data = path.read_bytes()
    elif ext == ".ply":
        if b"format ascii" not in head:
            return None
        data = path.read_bytes()
        end = data.find(b"end_header")
        data = data[end + len(b"end_header") :] if end >= 0 else b""
    else:
        data = path.read_bytes()
    m = _NONFINITE_TEXT[ext].search(data)
    if m is None:
        return None
    line_no = data.count(b"\n", 0, m.start()) + 1
    end = data.find(b"\n", m.start())
    text = data[m.start() : end if end >= 0 else len(data)].decode("utf-8", "replace").strip()
    where = f"line {line_no}" if ext != ".ply" else "in the vertex data"
    return f"NaN or infinite coordinate {where}: '{text[:60]}'"


def _stl_without_triangles(path: Path) -> bool:
    """A binary STL that declares 0 triangles, or an ASCII one with no ``facet``."""
    size = path.stat().st_size
    with path.open("rb") as fh:
        head = fh.read(84)
    if len(head) == 84 and size == 84 + 50 * int.from_bytes(head[80:84], "little"):
        return size == 84
    if head.lstrip().lower().startswith(b"solid") and size < (64 << 20):
        return re.search(rb"(?i)\bfacet\b", path.read_bytes()) is None
    return False


def import_mesh_file(path, *, collection=None, name=None):
    """Import an STL (binary or ASCII), OBJ or PLY file with Blender's own importer.

    The file is taken to be in millimetres and is scaled by ``1 / mm_per_blender_unit`` (1.0
    in the default scene, so the numbers are unchanged; Blender's importers put this factor
    on the object's scale, the mesh keeps the file's numbers). Axes are kept as in the file
    (no Y-up conversion, also for OBJ). Several objects in one file are joined into one.
    The importers run without their mesh validation (it silently turns NaN into 0); the
    coordinates are checked first, then ``Mesh.validate`` cleans the mesh.

    Parameters
    ----------
    path : str or Path
    collection : bpy.types.Collection, optional — where to put the object (default: the
        active collection)
    name : str, optional — object name (default: the file's stem)

    Returns
    -------
    bpy.types.Object — a mesh object with at least one face and finite coordinates.

    Raises
    ------
    InputError — missing file, unsupported extension, unreadable or non-mesh file, no
        faces, NaN/inf coordinates.
    """
    p = Path(path).expanduser()
    ext = _check_mesh_file(p)
    kind = ext[1:].upper()
    new = _run_importer(p, ext, kind)
    meshes = [ob for ob in new if ob.type == "MESH"]
    others = [ob for ob in new if ob.type != "MESH"]
    try:
        _check_imported(p.name, kind, meshes)
    except InputError:
        _remove_objects(new)
        raise
    _remove_objects(others)
    obj = _one_object(p, meshes, collection, name)
    if len(obj.data.polygons) == 0:  # validation removed every (degenerate) face
        _remove_objects([obj])
        raise InputError(f"{p.name}: the mesh has no usable faces (all degenerate)")
    return obj


def _check_mesh_file(p: Path) -> str:
    """The lower-case extension of the mesh file ``p``; :class:`InputError` before any import
    when it is missing, not a file, of another type, empty, with NaN/inf in its text, or an
    STL without triangles."""
    if not p.exists():
        raise InputError(f"mesh file not found: {p}")
    if not p.is_file():
        raise InputError(f"not a file: {p}")
    ext = p.suffix.lower()
    if ext not in SUPPORTED_EXTENSIONS:
        raise InputError(
            f"unsupported mesh file type '{p.suffix or '(none)'}' ({p.name}); "
            "use .stl, .obj or .ply"
        )
    if p.stat().st_size == 0:
        raise InputError(f"{p.name}: the file is empty")
    try:
        problem = _scan_text_for_nonfinite(p, ext)
    except OSError as exc:
        raise InputError(f"{p.name}: cannot read the file ({exc.strerror or exc})") from exc
    if problem:
        raise InputError(f"{p.name}: {problem}; fix or re-export the mesh")
    if ext == ".stl" and _stl_without_triangles(p):
        raise InputError(
            f"{p.name}: the mesh has no faces (an STL without triangles); "
            "a blade surface needs triangles"
        )
    return ext


def _run_importer(p: Path, ext: str, kind: str) -> list:
    """Blender's importer for ``ext`` on ``p`` (millimetres, axes as in the file, no
    validation); the objects it added. :class:`InputError` when it fails."""
    scene = bpy.context.scene
    scale = 1.0 / mm_per_blender_unit(scene)
    op = getattr(bpy.ops.wm, SUPPORTED_EXTENSIONS[ext])
    kwargs = {"filepath": str(p.resolve()), "global_scale": scale}
    # Import without validation: validation silently replaces NaN by 0. We check the
    # coordinates ourselves and validate afterwards.
    if ext == ".stl":
        kwargs.update(forward_axis="Y", up_axis="Z", use_scene_unit=False, use_mesh_validate=False)
    elif ext == ".obj":
        kwargs.update(
            forward_axis="Y",
            up_axis="Z",
            use_split_objects=False,
            use_split_groups=False,
            validate_meshes=False,
        )
    else:
        kwargs.update(forward_axis="Y", up_axis="Z", use_scene_unit=False)

    before = set(bpy.data.objects)
    with quiet_output() as out:
        try:
            result = op(**kwargs)
        except RuntimeError as exc:
            result = None
            error = str(exc).strip().replace("\n", " ")
        else:
            error = ""
    if result is None or "FINISHED" not in result:
        detail = error or _blender_error_lines(out[0] if out else "") or "the importer gave up"
        detail = detail.removeprefix("Error: ")
        raise InputError(f"{p.name}: cannot read the file as {kind} ({detail})")
    return [ob for ob in bpy.data.objects if ob not in before]


def _check_imported(filename: str, kind: str, meshes) -> None:
    """:class:`InputError` when the import gave no mesh, NaN/inf coordinates or no face."""
    if not meshes:
        raise InputError(
            f"{filename}: the file holds no mesh (nothing the {kind} importer reads)"
        )
    for ob in meshes:
        msg = _non_finite_message(filename, _vertex_coordinates(ob.data))
        if msg:
            raise InputError(msg)
    if sum(len(ob.data.polygons) for ob in meshes) == 0:
        raise InputError(
            f"{filename}: the mesh has no faces ({sum(len(ob.data.vertices) for ob in meshes)}"
            " vertices, 0 triangles); a blade surface needs triangles"
        )


def _one_object(p: Path, meshes, collection, name):
    """The imported mesh objects as one validated object, named ``name`` (default: the file's
    stem when joined) in ``collection`` (default: where the importer put it)."""
    if len(meshes) > 1:  # join in world frame (OBJ with several objects, kept as one mesh)
        parts = [object_to_arrays(ob, mm_per_unit=1.0) for ob in meshes if len(ob.data.polygons)]
        offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
        V = np.concatenate([v for v, _ in parts])
        F = np.concatenate([f + o for (_, f), o in zip(parts, offsets, strict=True)])
        coll = collection or meshes[0].users_collection[0]
        _remove_objects(meshes)
        return arrays_to_object(name or p.stem, V, F, coll, mm_per_unit=1.0)
    obj = meshes[0]
    with quiet_output():
        obj.data.validate(verbose=False, clean_customdata=False)
    if name:
        obj.name = name
        obj.data.name = name
    if collection is not None:
        for c in list(obj.users_collection):
            c.objects.unlink(obj)
        collection.objects.link(obj)
    return obj


def _remove_objects(objects):
    for ob in objects:
        data = ob.data
        bpy.data.objects.remove(ob, do_unlink=True)
        if data is not None and data.users == 0:
            with contextlib.suppress(Exception):
                if isinstance(data, bpy.types.Mesh):
                    bpy.data.meshes.remove(data)


def object_to_arrays(obj, depsgraph=None, *, mm_per_unit=None, with_selection=False):
    """The evaluated mesh of an object as arrays: world frame, millimetres, triangles.

    Modifiers, shape keys and the object's world matrix are applied; n-gons are triangulated
    by Blender's loop triangles. The user's object is not modified (a temporary mesh from
    ``to_mesh()`` is read and freed). All vertices of the evaluated mesh are returned, also
    loose ones no triangle uses.

    Parameters
    ----------
    obj : bpy.types.Object — a mesh (or curve/text/metaball/surface) object
    depsgraph : bpy.types.Depsgraph, optional — default ``bpy.context.evaluated_depsgraph_get()``
    mm_per_unit : float, optional — default :func:`mm_per_blender_unit` of the scene

    Returns
    -------
    V : (n, 3) float64, mm, world frame
    F : (m, 3) int64, indices into V

    Raises
    ------
    selected : (m,) bool — only with ``with_selection=True``: whether the face each triangle
        comes from is selected (the evaluated mesh's face selection, as Edit Mode left it)

    Raises
    ------
    InputError — not a mesh-like object, no faces after evaluation, NaN/inf coordinates.
    """
    if obj is None:
        raise InputError("no object given; choose the blade mesh object")
    if obj.type not in _MESHLIKE:
        raise InputError(f"object '{obj.name}' is a {obj.type.lower()}, not a mesh")
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    if obj.type == "MESH" and obj.mode == "EDIT":
        obj.update_from_editmode()  # only syncs the edit-mode data into the mesh
    f = _factor(mm_per_unit, depsgraph.scene if depsgraph is not None else None)

    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    try:
        if mesh is None:
            raise InputError(f"object '{obj.name}' has no mesh data")
        mesh.calc_loop_triangles()
        co = _vertex_coordinates(mesh)
        tri = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tri)
        M = np.array(ev.matrix_world, dtype=np.float64)
        if with_selection:
            poly_sel = np.zeros(len(mesh.polygons), dtype=bool)
            mesh.polygons.foreach_get("select", poly_sel)
            tri_poly = np.empty(len(mesh.loop_triangles), dtype=np.int32)
            mesh.loop_triangles.foreach_get("polygon_index", tri_poly)
            selected = poly_sel[tri_poly] if len(tri_poly) else np.zeros(0, dtype=bool)
    finally:
        ev.to_mesh_clear()

    if len(tri) == 0:
        raise InputError(
            f"object '{obj.name}' has no faces ({len(co)} vertices, 0 triangles); "
            "a blade surface needs triangles"
        )
    V = co.astype(np.float64) @ M[:3, :3].T
    V += M[:3, 3]
    if f != 1.0:
        V *= f
    msg = _non_finite_message(f"object '{obj.name}'", V)
    if msg:
        raise InputError(msg)
    if with_selection:
        return V, tri.reshape(-1, 3).astype(np.int64), selected
    return V, tri.reshape(-1, 3).astype(np.int64)


def blade_and_rest(obj, depsgraph=None, *, mm_per_unit=None):
    """The blade of a mesh object and the rest of the same mesh: when some but not all of its
    faces are selected (Edit Mode selection, e.g. one blade of a whole blisk), the blade is
    the selected faces and the unselected ones are returned as an obstacle; otherwise the
    whole evaluated mesh is the blade. Read-only (the object and its mesh are not changed).

    Returns
    -------
    (V, F) — the blade, mm world frame
    rest : (V, F) or None — the other faces
    counts : (selected triangles, all triangles)
    """
    from ..core.collision.obstacles import split_faces

    V, F, sel = object_to_arrays(obj, depsgraph, mm_per_unit=mm_per_unit, with_selection=True)
    n_sel = int(sel.sum())
    if n_sel == 0 or n_sel == len(F):
        return (V, F), None, (len(F), len(F))
    blade, rest = split_faces(V, F, sel)
    return blade, rest, (n_sel, len(F))


# --- writing -----------------------------------------------------------------------------
def ensure_collection(name, parent=None):
    """The collection ``name`` (created and linked under ``parent`` or the scene if missing)."""
    coll = bpy.data.collections.get(name)
    if coll is None:
        coll = bpy.data.collections.new(name)
    parent = parent if parent is not None else bpy.context.scene.collection
    if coll.name not in parent.children:
        with contextlib.suppress(RuntimeError):  # already linked elsewhere in the tree
            parent.children.link(coll)
    return coll


def colored_material(name, rgba):
    """A material (created or reused by name) showing ``rgba`` in Workbench, EEVEE and Cycles.

    Sets the viewport colour (Workbench "Material" colour) and the Principled BSDF base colour
    and alpha; alpha < 1 makes it see-through in every engine.
    """
    rgba = tuple(float(c) for c in rgba) + (1.0,) * (4 - len(rgba))
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = rgba
    mat.roughness = 0.5
    if mat.node_tree is None and bpy.app.version < (5, 0, 0):
        mat.use_nodes = True  # Blender 5 always has a node tree (use_nodes is deprecated)
    if mat.node_tree is not None:
        bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
        if bsdf is not None:
            bsdf.inputs["Base Color"].default_value = rgba
            bsdf.inputs["Alpha"].default_value = rgba[3]
            bsdf.inputs["Roughness"].default_value = 0.5
    if rgba[3] < 1.0:
        if hasattr(mat, "surface_render_method"):  # EEVEE Next (4.2+)
            mat.surface_render_method = "BLENDED"
        elif hasattr(mat, "blend_method"):
            mat.blend_method = "BLEND"
        if hasattr(mat, "use_backface_culling"):
            mat.use_backface_culling = False
    return mat


def _style(obj, color, smooth, material_name=None):
    if color is not None:
        rgba = tuple(float(c) for c in color) + (1.0,) * (4 - len(color))
        obj.color = rgba
        mat = colored_material(material_name or f"Blisk CAM {obj.name}", rgba)
        obj.data.materials.clear()
        obj.data.materials.append(mat)
    if smooth:
        n = len(obj.data.polygons)
        obj.data.polygons.foreach_set("use_smooth", np.ones(n, dtype=bool))


def arrays_to_object(
    name, V, F, collection=None, *, mm_per_unit=None, color=None, smooth=False,
    material_name=None,
):
    """A new mesh object from arrays in mm (world frame); the object has the identity matrix.

    Parameters
    ----------
    name : str
    V : (n, 3) float, mm
    F : (m, 3) int, indices into V (or (m, 4) for quads)
    collection : bpy.types.Collection, optional — default the scene's master collection
    mm_per_unit : float, optional — default :func:`mm_per_blender_unit` of the scene
    color : (r, g, b[, a]) floats in [0, 1], optional — object colour and a material
    smooth : bool — smooth shading
    material_name : str, optional — name of the colour's material (created or reused;
        default ``"Blisk CAM <object name>"``)

    Returns
    -------
    bpy.types.Object
    """
    V = np.asarray(V, dtype=np.float64)
    F = np.asarray(F)
    if V.ndim != 2 or V.shape[1] != 3:
        raise InputError(f"{name}: vertices must be an (n, 3) array, got shape {V.shape}")
    if F.size == 0:
        F = F.reshape(0, 3)
    if F.ndim != 2 or F.shape[1] not in (3, 4) or not np.issubdtype(F.dtype, np.integer):
        raise InputError(
            f"{name}: faces must be an (m, 3) (or (m, 4) quads) integer array, "
            f"got {F.dtype} {F.shape}"
        )
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        raise InputError(f"{name}: face indices outside 0..{len(V) - 1}")
    msg = _non_finite_message(name, V)
    if msg:
        raise InputError(msg)
    f = _factor(mm_per_unit)

    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(V))
    mesh.vertices.foreach_set("co", np.ascontiguousarray(V / f, dtype=np.float32).ravel())
    m, k = F.shape
    mesh.loops.add(k * m)
    mesh.loops.foreach_set("vertex_index", np.ascontiguousarray(F, dtype=np.int32).ravel())
    mesh.polygons.add(m)
    mesh.polygons.foreach_set("loop_start", np.arange(0, k * m, k, dtype=np.int32))
    mesh.update(calc_edges=True)

    obj = bpy.data.objects.new(name, mesh)
    (collection if collection is not None else bpy.context.scene.collection).objects.link(obj)
    _style(obj, color, smooth, material_name)
    return obj


def cone_to_object(
    name,
    cone,
    axis: Axis,
    collection=None,
    *,
    theta=(0.0, 2.0 * math.pi),
    segments=128,
    rows=1,
    extend=0.0,
    color=(0.2, 0.55, 0.95, 0.35),
    wire=None,
    wire_color=None,
    fill=True,
    mm_per_unit=None,
    material_name=None,
):
    """A light mesh of a cone surface: the generatrix P1 → P2 revolved about the axis — or, for
    a ``core.part.profiles.Profile``, the surface of revolution of its polyline (a hub or tip that
    is not a cone, paper 001 §4.2).

    Parameters
    ----------
    cone : Cone — (r1, z1) → (r2, z2) in mm in the meridional half-plane; or Profile — the
        polyline [(r, z), ...] in mm
    axis : Axis
    theta : (θ0, θ1) radians — angular range, measured from world X projected normal to the
        axis (``atan2(y, x)`` for the axis +Z). A full turn gives a closed band.
    segments : int — number of angular steps
    rows : int — number of steps along the generatrix (a straight line: 1 is exact; more
        only matter for the wire grid); a profile has at least one row per segment
    extend : float, mm — lengthen the generatrix by this much at both ends (r clamped ≥ 0)
    color : RGBA, default a see-through blue
    wire : float, mm, optional — also show the grid lines as tubes of this thickness (a
        Wireframe modifier, so the mesh itself stays the plain surface)
    wire_color : RGBA, optional — colour of the wire (default ``color`` made opaque)
    fill : bool — show the surface itself; ``False`` with ``wire`` shows the grid only (e.g.
        for a cone that coincides with a hub surface, where a fill would z-fight)
    material_name : str, optional — base name of the materials (default from ``name``)

    Returns
    -------
    bpy.types.Object — (rows' + 1) × (segments [+1]) vertices, rows' × segments quads; every
    vertex on the (extended) generatrix revolved.
    """
    if not isinstance(cone, Cone) and not hasattr(cone, "vertices"):
        raise InputError(f"{name}: expected a Cone or a Profile, got {type(cone).__name__}")
    rows = max(int(rows), 1)
    V, F = revolve(generatrix_rows(cone, rows, float(extend)), axis, theta, segments)
    base = material_name or f"Blisk CAM {name}"
    obj = arrays_to_object(
        name, V, F, collection, mm_per_unit=mm_per_unit, color=color, smooth=True,
        material_name=base if material_name else None,
    )
    if wire:
        f = _factor(mm_per_unit)
        rgba = tuple(wire_color) if wire_color is not None else tuple(color[:3]) + (1.0,)
        wire_name = f"{base} wire" if material_name else f"Blisk CAM {obj.name} wire"
        obj.data.materials.append(colored_material(wire_name, rgba))
        mod = obj.modifiers.new("Wire", "WIREFRAME")
        mod.thickness = float(wire) / f
        mod.use_replace = not fill
        mod.use_even_offset = False
        mod.offset = 0.0  # centred on the surface
        mod.material_offset = 1  # the wire uses the second material
    elif not fill:
        raise InputError(f"{name}: a cone shown with neither fill nor wire would be invisible")
    return obj


def axis_to_object(
    name,
    axis: Axis,
    collection=None,
    *,
    kind="EMPTY",
    z_range=(0.0, 100.0),
    radius=0.5,
    color=(0.9, 0.2, 0.15, 1.0),
    mm_per_unit=None,
):
    """An object showing the blisk axis.

    ``kind="EMPTY"``: a single-arrow Empty at the axis origin whose local +Z is the axis
    direction, display size ``z_range[1] - z_range[0]`` (the object the ``axis_object``
    setting expects; :func:`object_axis` reads it back). ``kind="ROD"``: a thin 12-sided
    cylinder mesh from ``z_range[0]`` to ``z_range[1]`` mm along the axis, which renders.
    """
    f = _factor(mm_per_unit)
    e1, e2, d = axis.angular_frame()
    z0, z1 = float(z_range[0]), float(z_range[1])
    if kind == "EMPTY":
        from mathutils import Matrix

        obj = bpy.data.objects.new(name, None)
        obj.empty_display_type = "SINGLE_ARROW"
        obj.empty_display_size = max(abs(z1 - z0), 1e-6) / f
        rot = np.stack([e1, e2, d], axis=1)  # columns: local X, Y, Z in world
        m = np.eye(4)
        m[:3, :3] = rot
        m[:3, 3] = axis.o / f
        obj.matrix_world = Matrix(m.tolist())
        (collection if collection is not None else bpy.context.scene.collection).objects.link(obj)
        if color is not None:
            obj.color = tuple(color) + (1.0,) * (4 - len(color))
        return obj
    if kind != "ROD":
        raise InputError(f"axis object kind must be 'EMPTY' or 'ROD', got {kind!r}")
    n = 12
    th = 2.0 * math.pi * np.arange(n) / n
    ring = radius * (np.cos(th)[:, None] * e1 + np.sin(th)[:, None] * e2)
    o = axis.o
    V = np.concatenate([o + z0 * d + ring, o + z1 * d + ring, [o + z0 * d, o + z1 * d]])
    i = np.arange(n)
    j = (i + 1) % n
    F = np.concatenate(
        [
            np.stack([i, j, n + j], 1),
            np.stack([i, n + j, n + i], 1),
            np.stack([np.full(n, 2 * n), j, i], 1),  # bottom cap
            np.stack([np.full(n, 2 * n + 1), n + i, n + j], 1),  # top cap
        ]
    )
    return arrays_to_object(name, V, F.astype(np.int64), collection, mm_per_unit=f, color=color)


def object_axis(obj, *, mm_per_unit=None) -> Axis:
    """The axis an object defines: its world origin (mm) and its world local-Z direction."""
    f = _factor(mm_per_unit)
    m = np.array(obj.matrix_world, dtype=np.float64)
    d = m[:3, 2]
    if np.linalg.norm(d) < 1e-12:
        raise InputError(f"object '{obj.name}' has a zero scale along its Z: no axis direction")
    return Axis(tuple(m[:3, 3] * f), tuple(d))
