"""blisk_cam.blender.objects and .render in the bpy wheel (4.5 and 5.2): mesh files through
Blender's importers, evaluated objects to arrays (modifiers, world matrix, units), arrays and
cones to objects, and headless previews (Workbench via EGL, Cycles CPU without GL)."""

import math

import bpy
import numpy as np
import pytest

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import render
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.part.cones import Cone
from tests.support.blades import blade_stl
from tests.support.mesh_files import (
    assert_same_triangles,
    sample_surface,
    stl_triangles,
    write_ascii_stl,
    write_binary_stl,
    write_obj,
    write_ply,
)

# --- import ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "kind",
    ["stl-binary", "stl-ascii", "obj", "ply-ascii", "ply-binary"],
)
def test_import_gives_the_source_triangles(tmp_path, kind):
    V, F = sample_surface()
    writer = {
        "stl-binary": lambda p: write_binary_stl(p, V, F),
        "stl-ascii": lambda p: write_ascii_stl(p, V, F),
        "obj": lambda p: write_obj(p, V, F),
        "ply-ascii": lambda p: write_ply(p, V, F),
        "ply-binary": lambda p: write_ply(p, V, F, binary=True),
    }[kind]
    path = writer(tmp_path / f"sample.{kind.split('-')[0]}")
    n_meshes = len(bpy.data.meshes)
    obj = blender_io.import_mesh_file(path)
    assert obj.type == "MESH" and obj.name == "sample"
    assert len(bpy.data.meshes) == n_meshes + 1
    V2, F2 = blender_io.object_to_arrays(obj)
    assert V2.dtype == np.float64 and V2.shape[1] == 3
    assert F2.dtype == np.int64 and F2.shape == F.shape
    # same oriented triangles, float32 precision (numbers in mm unchanged, no axis swap)
    assert_same_triangles(V2, F2, V[F], atol=1e-4)


def test_import_real_nasa_blade_unchanged():
    T = stl_triangles(blade_stl("rotor37"))
    obj = blender_io.import_mesh_file(blade_stl("rotor37"))
    V, F = blender_io.object_to_arrays(obj)
    assert len(F) == len(T) == 20196
    # welded: far fewer vertices than 3 per triangle
    assert len(V) < 0.6 * 3 * len(F)
    assert_same_triangles(V, F, T, atol=1e-9)
    r, z = meridional(V, Axis())
    assert 170 < r.min() < r.max() < 260 and -5 < z.min() < z.max() < 50  # mm


@pytest.mark.parametrize(
    ("name", "content", "words"),
    [
        ("missing.stl", None, "not found"),
        ("blade.step", b"ISO-10303-21;\n", "unsupported"),
        ("empty.stl", b"", "empty"),
        ("text.stl", b"this is not a mesh\njust text\n", "cannot read"),
        ("text.ply", b"this is not a mesh\n", "cannot read"),
        ("text.obj", b"hello\nworld\n", "no mesh"),
        ("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", "no faces"),
        ("nofacet.stl", b"solid x\nendsolid x\n", "no faces"),
        ("nan.stl", None, "NaN"),
        ("nan.obj", None, "NaN"),
        ("inf.obj", None, "NaN or infinite"),
        ("nan_binary.stl", None, "NaN"),
    ],
)
def test_import_rejects_bad_files(tmp_path, name, content, words):
    V, F = sample_surface(3, 3)
    path = tmp_path / name
    if name == "nan.stl":
        write_ascii_stl(path, V, F, bad="nan")
    elif name == "nan.obj":
        write_obj(path, V, F, bad="NaN")
    elif name == "inf.obj":
        write_obj(path, V, F, bad="-inf")
    elif name == "nan_binary.stl":
        Vn = V.copy()
        Vn[2, 1] = np.nan
        write_binary_stl(path, Vn, F)
    elif content is not None:
        path.write_bytes(content)
    n_objects = len(bpy.data.objects)
    with pytest.raises(blender_io.InputError, match=words) as info:
        blender_io.import_mesh_file(path)
    assert "\n" not in str(info.value)
    assert len(bpy.data.objects) == n_objects  # nothing left behind


# --- object → arrays ---------------------------------------------------------------------


def _cube():
    V = np.array(
        [[x, y, z] for x in (0.0, 1.0) for y in (0.0, 2.0) for z in (0.0, 3.0)], dtype=np.float64
    )
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    F = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    return V, F


def test_object_to_arrays_applies_modifiers_world_matrix_and_units():
    from mathutils import Euler, Matrix, Vector

    V, F = _cube()
    obj = blender_io.arrays_to_object("cube", V, F)
    obj.location = (10.0, -20.0, 30.0)
    obj.rotation_euler = (0.3, -0.2, 1.1)
    obj.scale = (2.0, 1.0, 0.5)
    mod = obj.modifiers.new("copy", "ARRAY")
    mod.count = 2
    mod.use_relative_offset = False
    mod.use_constant_offset = True
    mod.constant_offset_displace = (5.0, 0.0, 0.0)
    mod.use_merge_vertices = False
    n_meshes = len(bpy.data.meshes)

    M = np.array(
        Matrix.LocRotScale(Vector(obj.location), Euler(obj.rotation_euler), Vector(obj.scale))
    )
    local = np.concatenate([V, V + [5.0, 0.0, 0.0]])
    F_local = np.concatenate([F, F + len(V)])
    world = local @ M[:3, :3].T + M[:3, 3]

    V2, F2 = blender_io.object_to_arrays(obj)
    assert len(F2) == 2 * len(F)
    assert_same_triangles(V2, F2, world[F_local], atol=1e-4)

    # unit scale: Blender's centimetre scene (1 BU = 10 mm) and millimetre preset (1 BU = 1 mm)
    units = bpy.context.scene.unit_settings
    units.scale_length = 0.01
    assert blender_io.mm_per_blender_unit() == pytest.approx(10.0)
    V3, _ = blender_io.object_to_arrays(obj)
    np.testing.assert_allclose(V3, 10.0 * V2, rtol=1e-6)
    units.scale_length = 0.001
    V4, _ = blender_io.object_to_arrays(obj)
    np.testing.assert_allclose(V4, V2, rtol=1e-6)

    # the user's object is untouched and the temporary mesh freed
    assert len(obj.data.vertices) == 8 and len(obj.data.polygons) == 12
    assert [m.name for m in obj.modifiers] == ["copy"]
    assert len(bpy.data.meshes) == n_meshes


def test_object_to_arrays_triangulates_quads_and_rejects_bad_objects():
    V, _ = _cube()
    quads = np.array([(0, 1, 3, 2), (4, 6, 7, 5)], dtype=np.int64)
    obj = blender_io.arrays_to_object("quads", V, quads)
    V2, F2 = blender_io.object_to_arrays(obj)
    assert F2.shape == (4, 3) and np.allclose(V2, V)

    empty = bpy.data.objects.new("empty", None)
    bpy.context.scene.collection.objects.link(empty)
    with pytest.raises(blender_io.InputError, match="not a mesh"):
        blender_io.object_to_arrays(empty)

    mesh = bpy.data.meshes.new("points")
    mesh.vertices.add(3)
    points = bpy.data.objects.new("points", mesh)
    bpy.context.scene.collection.objects.link(points)
    with pytest.raises(blender_io.InputError, match="no faces"):
        blender_io.object_to_arrays(points)

    bad = blender_io.arrays_to_object("nan", *sample_surface(3, 3))
    co = np.zeros(len(bad.data.vertices) * 3, dtype=np.float32)
    bad.data.vertices.foreach_get("co", co)
    co[4] = np.nan
    bad.data.vertices.foreach_set("co", co)
    bad.data.update()
    with pytest.raises(blender_io.InputError, match="NaN"):
        blender_io.object_to_arrays(bad)
    with pytest.raises(blender_io.InputError, match="NaN"):
        blender_io.arrays_to_object("nan2", np.array([[0, 0, np.nan]] * 3), [[0, 1, 2]])
    with pytest.raises(blender_io.InputError, match="outside"):
        blender_io.arrays_to_object("oob", np.zeros((3, 3)), [[0, 1, 3]])


def grid_mesh(n):
    """A wavy n × n vertex grid: 2 (n − 1)² triangles (V, F)."""
    x, y = np.meshgrid(np.arange(n, dtype=np.float64), np.arange(n, dtype=np.float64))
    V = np.stack([x.ravel(), y.ravel(), np.sin(0.1 * x.ravel())], axis=1)
    idx = np.arange(n * n).reshape(n, n)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return V, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def test_triangles_in_bulk_round_trip():
    """Object ↔ arrays in bulk keeps every triangle and the world matrix. No timing here
    (issue 28: a loaded machine fails a timed assertion); the million-triangle figure is
    printed by ``bench/bench_bulk_arrays.py``."""
    V, F = grid_mesh(201)  # 80 000 triangles
    obj = blender_io.arrays_to_object("big", V, F)
    obj.location = (1.0, 2.0, 3.0)
    V2, F2 = blender_io.object_to_arrays(obj)
    np.testing.assert_array_equal(F2, F)
    np.testing.assert_allclose(V2, V + [1.0, 2.0, 3.0], atol=1e-4)


# --- arrays / cones / axis → objects -----------------------------------------------------


def test_cone_and_axis_objects():
    axis = Axis((1.0, 2.0, 3.0), (0.0, 0.6, 0.8))
    cone = Cone(150.0, -10.0, 165.0, 40.0)
    obj = blender_io.cone_to_object(
        "cone", cone, axis, theta=(-0.3, 0.4), segments=24, rows=3, extend=5.0
    )
    V, F = blender_io.object_to_arrays(obj)
    assert len(V) == 4 * 25 and len(F) == 2 * 3 * 24
    r, z = meridional(V, axis)
    assert np.max(np.abs(cone.signed_distance(r, z))) < 1e-3
    length = math.hypot(15.0, 50.0)
    t = (np.stack([r, z], 1) - cone.p1) @ ((cone.p2 - cone.p1) / length)
    assert t.min() == pytest.approx(-5.0, abs=1e-3)
    assert t.max() == pytest.approx(length + 5.0, abs=1e-3)

    full = blender_io.cone_to_object("ring", cone, axis, segments=32, wire=0.5, fill=False)
    assert full.modifiers[0].type == "WIREFRAME"
    assert len(full.data.vertices) == 2 * 32  # closed: no duplicated seam

    empty = blender_io.axis_to_object("axis", axis, kind="EMPTY", z_range=(0.0, 80.0))
    assert empty.type == "EMPTY"
    back = blender_io.object_axis(empty)
    np.testing.assert_allclose(back.o, axis.o, atol=1e-5)
    np.testing.assert_allclose(back.d, axis.d, atol=1e-6)
    rod = blender_io.axis_to_object("rod", axis, kind="ROD", z_range=(-10.0, 50.0), radius=1.0)
    Vr, _ = blender_io.object_to_arrays(rod)
    rr, zr = meridional(Vr, axis)
    assert rr.max() == pytest.approx(1.0, abs=1e-4)
    assert zr.min() == pytest.approx(-10.0, abs=1e-4)
    assert zr.max() == pytest.approx(50.0, abs=1e-4)


# --- render ------------------------------------------------------------------------------


def _preview_scene():
    V, F = sample_surface(12, 8)
    blade = blender_io.arrays_to_object("blade", V, F, color=(0.9, 0.6, 0.2, 1.0))
    cone = blender_io.cone_to_object(
        "cone", Cone(175.0, -5.0, 190.0, 50.0), Axis(), theta=(-0.2, 0.2), segments=16,
        color=(0.1, 0.5, 1.0, 0.4),
    )
    return [blade, cone]


def test_render_preview_is_not_blank_and_restores_settings(tmp_path):
    objs = _preview_scene()
    scene = bpy.context.scene
    engine_before = scene.render.engine
    res_before = (scene.render.resolution_x, scene.render.resolution_y)
    out = tmp_path / "sub" / "preview.png"
    result = render.render_preview(out, resolution=(320, 180), objects=objs)
    assert result.path == out.resolve() and out.is_file()
    assert result.engine == ("BLENDER_WORKBENCH" if render.gl_available() else "CYCLES")
    assert result.coverage > 0.05  # the objects fill a good part of the frame
    assert render.image_coverage(out) == pytest.approx(result.coverage)
    img = bpy.data.images.load(str(out))
    try:
        assert tuple(img.size) == (320, 180)
    finally:
        bpy.data.images.remove(img)
    # the scene is as it was: engine, resolution, no camera left behind
    assert scene.render.engine == engine_before
    assert (scene.render.resolution_x, scene.render.resolution_y) == res_before
    assert scene.camera is None and render.CAMERA_NAME not in bpy.data.objects
    assert not [o for o in bpy.data.objects if o.name.startswith("Blisk CAM Preview")]


def test_render_preview_cycles_fallback_without_gl(tmp_path, monkeypatch):
    monkeypatch.setenv("BLISK_CAM_NO_GL", "1")
    assert render.resolve_engine("AUTO") == "CYCLES"
    assert render.resolve_engine("WORKBENCH") == "CYCLES"  # would abort Blender without GL
    assert render.resolve_engine("EEVEE") == "CYCLES"
    objs = _preview_scene()
    result = render.render_preview(tmp_path / "c.png", resolution=(160, 90), objects=objs)
    assert result.engine == "CYCLES"
    assert result.coverage > 0.05
    assert not [o for o in bpy.data.objects if o.type == "LIGHT"]  # temporary suns removed


def test_render_preview_of_hidden_objects_is_reported_blank(tmp_path):
    objs = _preview_scene()
    for ob in objs:
        ob.hide_render = True
    with pytest.raises(render.RenderError, match="blank"):
        render.render_preview(tmp_path / "blank.png", resolution=(160, 90), objects=objs)


def test_render_preview_keep_camera_and_errors(tmp_path):
    with pytest.raises(render.RenderError, match="nothing to render"):
        render.render_preview(tmp_path / "none.png", objects=[])
    with pytest.raises(render.RenderError, match="unknown render engine"):
        render.resolve_engine("POVRAY")
    objs = _preview_scene()
    render.render_preview(tmp_path / "k.png", resolution=(160, 90), objects=objs, keep_camera=True)
    cam = bpy.context.scene.camera
    assert cam is not None and cam.name == render.CAMERA_NAME


def test_eevee_engine_name_is_valid_here():
    name = render.eevee_engine_name()
    expected = "BLENDER_EEVEE" if bpy.app.version >= (5, 0, 0) else "BLENDER_EEVEE_NEXT"
    assert name == expected
    bpy.context.scene.render.engine = name  # raises TypeError for an unknown engine
    assert bpy.context.scene.render.engine == name


def test_render_preview_leaves_the_users_world_alone(tmp_path):
    world = bpy.data.worlds.new("mine")
    world.color = (0.2, 0.3, 0.4)
    bpy.context.scene.world = world
    n_worlds = len(bpy.data.worlds)
    render.render_preview(tmp_path / "w.png", resolution=(160, 90), objects=_preview_scene())
    assert bpy.context.scene.world == world
    assert tuple(world.color) == pytest.approx((0.2, 0.3, 0.4))
    assert len(bpy.data.worlds) == n_worlds


def test_import_in_a_centimetre_scene_keeps_millimetres(tmp_path):
    V, F = sample_surface()
    path = write_binary_stl(tmp_path / "cm.stl", V, F)
    bpy.context.scene.unit_settings.scale_length = 0.01  # 1 BU = 10 mm
    obj = blender_io.import_mesh_file(path)
    # Blender's importers put global_scale on the object (the mesh keeps the file's numbers)
    assert tuple(obj.matrix_world.to_scale()) == pytest.approx((0.1, 0.1, 0.1), rel=1e-6)
    V2, F2 = blender_io.object_to_arrays(obj)
    assert_same_triangles(V2, F2, V[F], atol=1e-4)  # back in mm


# --- a picture for a report (issue 14, item 4) --------------------------------------------
def _pixels(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * img.channels, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, -1)[::-1, :, :3]  # row 0 = top of the picture


def _blade_share(rgb):
    """Share of the pixels showing the bare blade (light grey: the blade's colour here)."""
    return float(((rgb.max(axis=2) - rgb.min(axis=2) < 0.06) & (rgb.mean(axis=2) > 0.55)).mean())


@pytest.fixture
def report_scene(addon, demo):
    """The demo blade (light grey) with its paths generated by the operator (coarse)."""
    from blisk_cam.blender import path_objects as output

    scene = bpy.context.scene
    blade = blender_io.arrays_to_object("Blade", demo.blade_vertices, demo.blade_faces,
                                        color=(0.8, 0.8, 0.8, 1.0))
    s = scene.blisk_cam
    s.blade = blade
    s.cone1, s.cone2 = demo.hub_cone.as_list(), demo.tip_cone.as_list()
    s.cusp, s.chord, s.verify, s.pose_count = 0.3, 0.3, False, 10
    s.color_mode = "MORPH"
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    assert output.find_output_collection("Blade") is not None
    return scene, blade


def test_report_preview_title_legend_cones_and_view(report_scene, tmp_path):
    scene, blade = report_scene
    n_objects = len(bpy.data.objects)
    old = tmp_path / "old.png"  # what the preview was: all three wire cones, fixed view
    assert bpy.ops.blisk_cam.render_preview(
        filepath=str(old), resolution=(640, 360), annotate=False, cones="FULL",
        view=(1.0, -0.8, 0.55)) == {"FINISHED"}
    new = tmp_path / "new.png"
    assert bpy.ops.blisk_cam.render_preview(filepath=str(new), resolution=(640, 360)) == {
        "FINISHED"}
    # nothing left behind (text, swatches, outlines, camera) and the cones are back
    assert len(bpy.data.objects) == n_objects
    assert not [c for c in bpy.data.curves if "outline" in c.name or "render" in c.name]
    assert all(not ob.hide_render for ob in bpy.data.objects
               if ob.get("blisk_cam_role") in ("cone1", "cone2", "cone_middle"))
    light = tmp_path / "light.png"  # the same view and framing, cones as outlines
    assert bpy.ops.blisk_cam.render_preview(
        filepath=str(light), resolution=(640, 360), annotate=False,
        view=(1.0, -0.8, 0.55)) == {"FINISHED"}
    a, b = _pixels(old), _pixels(new)
    # the bare blade shows more once the cones are outlines: measured 0.117 → 0.175 of the
    # picture on the demo blade (the dense wire grids and cone 2's fill covered it)
    share_old, share_light = _blade_share(a), _blade_share(_pixels(light))
    assert share_light > 1.3 * share_old, (share_old, share_light)
    # the header (top 17 %) holds the title and the legend, not the scene: bright title
    # text, and the legend's ramp from blue (left) to red (right) in one row
    head = b[: int(0.17 * 360)]
    # a black band (measured 78 % of the header's pixels) with light text on it (the studio
    # light renders the white text ~0.6 grey: 450 pixels above 0.5)
    assert (head.max(axis=2) < 0.03).mean() > 0.6
    assert (head.min(axis=2) > 0.45).sum() > 200
    bluish = (head[:, :, 2] > head[:, :, 0] + 0.15) & (head[:, :, 2] > 0.4)
    reddish = (head[:, :, 0] > head[:, :, 2] + 0.15) & (head[:, :, 0] > 0.4)
    assert bluish.sum() > 50 and reddish.sum() > 50
    assert np.nonzero(bluish)[1].mean() < np.nonzero(reddish)[1].mean()
    # the old picture had no such header: its top rows were scene or background
    assert (a[: int(0.17 * 360)].max(axis=2) < 0.03).mean() < 0.05
    # a light scale bar at the bottom left (measured 95 pixels above 0.5; none in the old)
    assert (b[int(0.9 * 360):, :320].min(axis=2) > 0.5).sum() > 50


def test_report_preview_hidden_cones_and_labels(report_scene, tmp_path):
    out = tmp_path / "hidden.png"
    assert bpy.ops.blisk_cam.render_preview(filepath=str(out), resolution=(320, 180),
                                            cones="HIDDEN", annotate=False) == {"FINISHED"}
    assert render.image_coverage(out) > 0.02
    with pytest.raises(render.RenderError, match="cone style"):
        render.render_preview(tmp_path / "x.png", resolution=(64, 36), cones="dense")
    assert render.tool_label({"type": "ball", "radius": 6.0}) == "Ø12 ball"
    assert render.tool_label({"type": "bull", "radius": 5.0, "corner_radius": 2.0}) == "Ø10 bull r2"
    assert [render.nice_length(x) for x in (0.7, 1.0, 23.0, 49.9, 51.0)] == [0.5, 1.0, 20.0,
                                                                            20.0, 50.0]
    with pytest.raises(render.RenderError):
        render.nice_length(0.0)


def test_spiral_is_cut_into_one_spline_per_colour_bin():
    from blisk_cam.blender import path_objects as output
    from blisk_cam.core.toolpath.types import BallTool, PassCurve, ToolPath

    k = 241
    t = np.linspace(0.0, 1.0, k)
    cc = np.stack([200.0 * np.cos(6 * t), 200.0 * np.sin(6 * t), 40.0 * t], axis=1)
    n = np.tile([0.0, 0.0, 1.0], (k, 1))
    spiral = PassCurve(s=0.0, closed=False, cc=cc, normal=n, tip=cc, axis=n, ratio=t)
    ring = PassCurve(s=0.5, closed=True, cc=cc[:50], normal=n[:50], tip=cc[:50], axis=n[:50])
    path = ToolPath(axis=Axis(), cone1=Cone(100, 0, 100, 10), cone2=Cone(300, 0, 300, 10),
                    tool=BallTool(6.0), cusp=0.1, chord=0.1, curves=[spiral, ring])
    sets, closed, s, cusp = output.spline_pieces(path, "cc", [0.01, 0.02])
    nb = output.COLOR_BINS
    assert len(sets) == nb + 1 and closed == [False] * nb + [True]
    # the pieces run through every bin of the ratio, in order, and join end to start
    bins = output.spline_bins("MORPH", s[:nb], cusp[:nb], 0.1)
    assert list(bins) == list(range(nb))
    for a, b in zip(sets[: nb - 1], sets[1:nb], strict=True):
        assert np.array_equal(a[-1], b[0])
    assert np.array_equal(np.concatenate([p[:-1] for p in sets[: nb - 1]] + [sets[nb - 1]]), cc)
    assert cusp == [0.01] * nb + [0.02] and s[nb] == 0.5
    assert np.array_equal(sets[nb], cc[:50])  # a pass with one ratio is one spline, as before
