"""Render Preview after a collision check is report-grade (issue 28, row 15), measured on the
picture: the neighbour blades hide little of it, the tool assembly does not dominate it, the
blade shows between the path tubes, the legend names the collision statuses in their colours
with their counts, the scale label is readable (glyphs ≥ 12 px on a dark plate at 480 × 270).

One collision-checked scene (the demo blade, radial axis, a Ø32 holder that reaches the
neighbour: 2 unresolved poses), Workbench at 480 × 270; each figure compares the preview with
the same preview (same camera: it frames the blade) where one kind of object is hidden by the
test, so it measures what that kind of object covers, whatever its colour.
"""

import bpy
import numpy as np
import pytest
from _scenes import radial_demo_paths
from scipy import ndimage

from blisk_cam.blender import path_objects as output
from blisk_cam.blender import render
from blisk_cam.blender.objects import colored_material

RES = (480, 270)
BLADE_RGBA = (0.85, 0.25, 0.85, 1.0)  # magenta: no path, status, neighbour or tool colour


def _pixels(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = img.size
        px = np.empty(w * h * img.channels, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, -1)[::-1, :, :3]  # row 0 = top of the picture


def _changed(a, b, threshold=0.08):
    """Share of the pixels where two pictures differ (any channel by more than threshold)."""
    return float((np.abs(a - b).max(axis=2) > threshold).mean())


def _blade_pixels(rgb):
    """Pixels showing the (magenta) blade: red and blue well above green."""
    r, g, b = rgb[:, :, 0], rgb[:, :, 1], rgb[:, :, 2]
    return (r > g + 0.15) & (b > g + 0.15) & (np.abs(r - b) < 0.2)


def _preview(tmp_path, name, hide=(), resolution=RES):
    """The operator's preview (its defaults) with ``hide`` objects hidden for it."""
    was = [(ob, ob.hide_render) for ob in hide]
    for ob in hide:
        ob.hide_render = True
    try:
        out = tmp_path / f"{name}.png"
        assert bpy.ops.blisk_cam.render_preview(filepath=str(out), resolution=resolution,
                                                engine="WORKBENCH") == {"FINISHED"}
    finally:
        for ob, h in was:
            ob.hide_render = h
    return _pixels(out)


@pytest.fixture
def checked(addon, demo, tmp_path):
    if render.resolve_engine("WORKBENCH") != "BLENDER_WORKBENCH":
        pytest.skip("no OpenGL context here (the measures are taken on Workbench renders)")
    blade, s = radial_demo_paths(demo, tmp_path, generate=False)
    s.cusp = 0.15  # passes ≈ 7 px apart at 480 × 270: tubes can hide the blade
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    blade.data.materials.clear()
    blade.data.materials.append(colored_material("test magenta blade", BLADE_RGBA))
    s.blade_count, s.holder = 24, "36 6 60 6 60 16 120 16"
    assert bpy.ops.blisk_cam.check_collisions() == {"FINISHED"}
    objs = output.output_objects(output.find_output_collection(blade.name))
    assert len(objs["neighbours"]) == 4 and objs["tool_assembly"] is not None
    return blade, objs


def test_neighbours_holder_and_tubes_leave_the_blade_in_view(checked, tmp_path):
    blade, objs = checked
    full = _preview(tmp_path, "full")
    # the neighbour blades: 0.26 of the picture before (the near one in front of the
    # blade), 0.07 cut away (the far side of the channel, behind the blade, stays)
    no_neighbours = _preview(tmp_path, "no_neighbours", objs["neighbours"])
    neighbour_share = _changed(full, no_neighbours)
    assert neighbour_share < 0.12, neighbour_share
    # the Ø32 holder at the worst pose: 0.045 of the picture before, 0.008 as an outline
    no_holder = _preview(tmp_path, "no_holder", [objs["tool_assembly"]])
    holder_share = _changed(full, no_holder)
    assert holder_share < 0.02, holder_share
    # the blade between the tubes and the pose points (at 960 × 540, where the passes are
    # 15 px apart and a tube is not held at its smallest width): the share of the blade's
    # outline (its pixels closed over gaps up to 8 px) where it shows: 0.79 before, 0.89
    blade_px = _blade_pixels(_preview(tmp_path, "big", resolution=(960, 540)))
    region = ndimage.binary_fill_holes(ndimage.binary_closing(blade_px, np.ones((9, 9))))
    assert region.sum() > 0.05 * blade_px.size  # the blade is in the picture
    visible = blade_px.sum() / region.sum()
    assert visible >= 0.85, visible


def _scale_label(rgb):
    """(glyph height px, mean of the plate around the glyphs) of the scale bar's label: the
    light glyphs right of the bar (the longest run of light pixels in a row, bottom left)."""
    h, w = rgb.shape[:2]
    y0, x1 = int(0.65 * h), int(0.6 * w)
    light = rgb[y0:, :x1].min(axis=2) > 0.6  # the studio light renders white text ~0.7
    runs, _ = ndimage.label(light, structure=[[0, 0, 0], [1, 1, 1], [0, 0, 0]])
    sizes = np.bincount(runs.ravel())
    sizes[0] = 0
    bar = runs == int(np.argmax(sizes))
    if sizes.max() < 0.05 * w:  # no bar
        return 0, float("nan")
    bar_row = int(np.nonzero(bar)[0].mean())
    bar_end = int(np.nonzero(bar)[1].max())
    comps, _ = ndimage.label(light)
    boxes = ndimage.find_objects(comps)
    glyphs = [(sy, sx) for sy, sx in boxes
              if bar_end + 1 < sx.start < bar_end + 0.25 * w
              and 3 <= sy.stop - sy.start <= 0.2 * h
              and abs(0.5 * (sy.start + sy.stop) - bar_row) < 0.06 * h]
    if not glyphs:  # no white glyph right of the bar
        return 0, float("nan")
    top, bottom = min(g[0].start for g in glyphs), max(g[0].stop for g in glyphs)
    left, right = min(g[1].start for g in glyphs), max(g[1].stop for g in glyphs)
    box = rgb[y0 + top - 3: y0 + bottom + 3, left - 3: right + 3]
    behind = box[box.min(axis=2) <= 0.6]
    return bottom - top, float(behind.mean())


def test_legend_names_the_statuses_and_the_scale_label_is_readable(checked, tmp_path,
                                                                   monkeypatch):
    blade, objs = checked
    status = np.zeros(len(objs["poses"].data.vertices), dtype=np.int32)
    objs["poses"].data.attributes["collision_status"].data.foreach_get("value", status)
    counts = np.bincount(status, minlength=3)
    assert counts[2] > 0  # the big holder leaves unresolved poses
    seen = {}
    real = render._render_still

    def capture(scene, eng, path):  # the overlay objects as they are rendered
        for ob in scene.objects:
            if ob.name.startswith("Blisk CAM render"):
                mat = ob.data.materials[0] if ob.data.materials else None
                seen[ob.name] = (ob.type, getattr(ob.data, "body", None),
                                 np.array(ob.location),  # in the camera frame
                                 tuple(mat.diffuse_color) if mat is not None else None)
        real(scene, eng, path)

    monkeypatch.setattr(render, "_render_still", capture)
    rgb = _preview(tmp_path, "legend")
    texts = {n: v for n, v in seen.items() if v[0] == "FONT"}
    swatches = {n: v for n, v in seen.items() if v[0] == "MESH"}
    for name, rgba, n in zip(output.STATUS_NAMES, output.STATUS_RGBA, counts,
                             strict=True):
        label = [v for v in texts.values() if v[1] is not None
                 and v[1].split(" (")[0] == f"{name} {n}"]
        assert len(label) == 1, (name, sorted(v[1] for v in texts.values()))
        # the swatch just left of the label (camera frame: x right), on its row, in the
        # status colour
        pos = label[0][2]
        left = [v for v in swatches.values() if abs(v[2][1] - pos[1]) < 1e-9
                and v[2][0] < pos[0]]
        nearest = max(left, key=lambda v: v[2][0])
        assert nearest[3] == pytest.approx(rgba, abs=1e-6)
    # the scale label: 17 px glyphs on a black plate (before: no light bar or label at all,
    # a 5 px grey label over the grey neighbour)
    height, behind = _scale_label(rgb)
    assert height >= 12, height
    assert behind < 0.15, behind


def test_verify_colours_get_a_legend_when_the_verify_map_shows(addon, demo, tmp_path):
    from blisk_cam.operators.render_preview import _annotation

    blade, _ = radial_demo_paths(demo, tmp_path)  # coarse paths, no collision check
    _, legends = _annotation(bpy.context)
    assert not any(lg.title.startswith("material left") for lg in legends)
    # a verify map in the output collection (as Generate's verify writes it)
    me = bpy.data.meshes.new("verify")
    ver = bpy.data.objects.new(f"{blade.name} verify", me)
    ver[output.KEY_ROLE] = "verify"
    output.find_output_collection(blade.name).objects.link(ver)
    _, legends = _annotation(bpy.context)
    (lg,) = [lg for lg in legends if lg.title.startswith("material left")]
    colour = {label: np.array(rgba[:3]) for label, rgba in lg.entries}
    cusp, chord = bpy.context.scene.blisk_cam.cusp, bpy.context.scene.blisk_cam.chord
    # what the verify map's colours mean (core.display.verify_colors): green at no material
    # left, blue at the cusp, purple beyond tolerance, red for a gouge, grey not measured
    assert list(colour) == ["0 left", f"{cusp:g} mm left", "over tolerance",
                            f"gouge {chord:g} mm", "not measured"]
    green, blue, purple, red, grey = colour.values()
    assert green.argmax() == 1 and blue.argmax() == 2 and red.argmax() == 0
    assert purple[0] > purple[1] and purple[2] > purple[1]
    assert np.ptp(grey) < 1e-9
    ver.hide_render = True  # not in the picture: no legend for it
    _, legends = _annotation(bpy.context)
    assert not any(lg.title.startswith("material left") for lg in legends)
