"""blisk_cam.simulate_stock and the Stock panel (issue 22, Blender side): a few passes of the
demo blade's paths run on "part + allowance" at a coarse resolution give, on the coloured part,
the deviation the core simulation gives for the same inputs; the colours follow the
tolerance; the remaining stock is an object; a second run replaces the objects and ESC keeps
the previous result; bad input is refused with a clear message."""

import bpy
import numpy as np
import pytest
from _layout import drawn
from _scenes import radial_demo_paths

from blisk_cam.blender import objects as blender_io

RES = 0.6  # mm: coarse, cheap


def _drawn_panel():
    from blisk_cam.panels.stock import BLISKCAM_PT_stock

    return drawn(BLISKCAM_PT_stock)


def _setup(demo, tmp_path):
    """The demo blade with a few passes near the hub (cone 2 = cone 1 moved 3 mm out)."""
    blade, s = radial_demo_paths(demo, tmp_path, cone2=(173.0, -25.0, 188.0, 35.0))
    c = demo.hub_cone
    hub = tmp_path / "hub.csv"
    hub.write_text(f"{c.r1}, {c.z1}\n{c.r2}, {c.z2}\n")
    s.blade_count = demo.blade_count
    s.stock_part_source, s.stock_hub_profile = "BLADE_HUB", str(hub)
    s.stock_blank, s.stock_allowance, s.stock_resolution = "ALLOWANCE", 0.2, RES
    return blade, s, hub


def _core(blade, hub, s):
    """The core simulation of the same inputs (the panel's figures: float32), called
    directly."""
    from blisk_cam.core.part.model import part_from_blade, read_rz_csv
    from blisk_cam.core.runtime import run_to_end
    from blisk_cam.core.stock.blank import stock_from_allowance
    from blisk_cam.core.stock.simulation import iter_simulate
    from blisk_cam.operators.common import stored_path

    path = stored_path(blade.name)
    V, F = blender_io.object_to_arrays(blade, bpy.context.evaluated_depsgraph_get())
    part = part_from_blade(V, F, read_rz_csv(hub), int(s.blade_count), path.axis)
    stock = stock_from_allowance(part, float(s.stock_allowance), float(s.stock_resolution))
    return run_to_end(iter_simulate(part, stock, [path]))


def _attr(ob, name, width=1):
    a = ob.data.attributes[name]
    out = np.empty(len(a.data) * width, np.float32)
    a.data.foreach_get("color" if width == 4 else "value", out)
    return out.reshape(-1, width) if width > 1 else out


def _simulate():
    """Run the operator; (result, error text or None): a crash is an ERROR report, which
    bpy.ops raises."""
    try:
        return bpy.ops.blisk_cam.simulate_stock(), None
    except RuntimeError as exc:
        return {"FINISHED"}, str(exc)


def test_simulate_stock_equals_core_colours_and_escape(addon, demo, tmp_path):
    from blisk_cam.blender.stock_objects import COLLECTION, DEVIATION_RGBA, stock_summary
    from blisk_cam.core.stock.deviation import stock_skin
    from blisk_cam.operators import simulate_stock as mod
    from blisk_cam.operators.modal_job import ModalRunner

    blade, s, hub = _setup(demo, tmp_path)
    assert "label: Not simulated yet" in _drawn_panel()
    before = blender_io.object_to_arrays(blade)[0].copy()
    result, error = _simulate()
    sim = _core(blade, hub, s)
    assert result == {"FINISHED"}
    if sim.summary["crashes"]:  # a crash is an error naming its row
        assert error is not None and f"row {sim.summary['crashes'][0]['row']}" in error
    else:
        assert error is None
    coll = bpy.data.collections[COLLECTION]
    part = next(o for o in coll.objects if "part" in o.name)
    stock = next(o for o in coll.objects if "stock" in o.name)
    dev = _attr(part, "deviation")
    assert len(dev) == len(sim.deviation)
    ok = np.isfinite(sim.deviation)
    assert ok.sum() > 100 and np.array_equal(np.isfinite(dev), ok)
    assert np.allclose(dev[ok], sim.deviation[ok], atol=1e-6)  # float32 of the same figure
    tol = sim.summary["deviation_mm"]["gouge_tolerance"]
    col = _attr(part, "deviation_color", 4)
    d = sim.deviation
    # coloured where the verdict judges the vertex; grey where it does not (the deviation
    # attribute above still holds the reading)
    judged = ok & sim.judged
    assert judged.sum() > 100 and not (sim.judged & ~ok).any()
    for mask, key in ((judged & (d < -tol), "gouge"), (judged & (np.abs(d) <= tol), "within"),
                      (judged & (d > tol), "left"), (~judged, "unmeasured")):
        assert np.allclose(col[mask], DEVIATION_RGBA[key]), key
    assert (judged & (d > tol)).any() and (judged & (np.abs(d) <= tol)).any()  # red, green
    Vs, Fs = stock_skin(sim.stock)
    assert len(stock.data.vertices) == len(Vs) and len(stock.data.polygons) == len(Fs)
    summary = stock_summary(bpy.context.scene)
    for key in ("volume_removed_mm3", "volume_remaining_mm3", "deviation_mm", "crashes"):
        assert summary[key] == sim.summary[key], key  # JSON keeps the float
    assert summary["volume_removed_mm3"]["sector"] > 0
    drawn = _drawn_panel()
    assert {"stock_hub_profile", "blade_count", "stock_allowance", "stock_resolution",
            "blisk_cam.simulate_stock"} <= set(drawn)
    assert any(x.startswith(f"label: removed {summary['volume_removed_mm3']['sector']:.1f}")
               for x in drawn)
    assert any(x.startswith("label: Blue: gouge") for x in drawn)
    assert any(x.startswith("label: Grey: not judged") for x in drawn)
    # the user's blade is untouched
    assert np.array_equal(blender_io.object_to_arrays(blade)[0], before)
    # ESC cancels a second run: the previous objects and summary are kept
    names = sorted(o.name for o in coll.objects)
    s.stock_allowance = 0.5
    ctx = bpy.context
    op = ModalRunner(mod.BLISKCAM_OT_simulate_stock, mod.StockJob(ctx))
    op.start(ctx)
    assert ctx.scene.name in mod._RUNNING and not bpy.ops.blisk_cam.simulate_stock.poll()
    assert op.step(ctx, "MOUSEMOVE") == {"PASS_THROUGH"}
    assert op.step(ctx, "ESC") == {"CANCELLED"}
    assert op._job.cancel.is_set() and not op._job.running and not mod._RUNNING
    assert "previous result is kept" in op.reports[-1][1]
    assert sorted(o.name for o in coll.objects) == names
    assert stock_summary(ctx.scene) == summary
    assert np.array_equal(_attr(part, "deviation"), dev, equal_nan=True)
    # the blank as the envelope + 1 mm: the rapids and links go through metal, a crash is an
    # ERROR naming the row; the new run replaces the objects
    s.stock_blank, s.stock_margin, s.stock_resolution = "ENVELOPE", 1.0, 1.0
    result, error = _simulate()
    summary = stock_summary(ctx.scene)
    assert summary["crashes"] and error is not None
    assert f"row {summary['crashes'][0]['row']} " in error
    assert sorted(o.name for o in coll.objects) == names
    assert any(x.startswith("label: 1 crash") or "crash(es): first at row" in x
               for x in _drawn_panel())


def test_simulate_stock_bad_input(addon, demo, tmp_path):
    blade, s, hub = _setup(demo, tmp_path)
    s.blade_count = 0
    with pytest.raises(RuntimeError, match="Blade Count is not set"):
        bpy.ops.blisk_cam.simulate_stock()
    s.blade_count = 24
    s.stock_hub_profile = str(tmp_path / "missing.csv")
    with pytest.raises(RuntimeError, match="hub profile file .*missing.csv not found"):
        bpy.ops.blisk_cam.simulate_stock()
    s.stock_hub_profile = str(hub)
    s.stock_part_source = "MESH"
    bpy.context.view_layer.objects.active = None
    with pytest.raises(RuntimeError, match="No whole-blisk mesh"):
        bpy.ops.blisk_cam.simulate_stock()
    s.stock_part_source, s.stock_blank = "BLADE_HUB", "PROFILE"
    with pytest.raises(RuntimeError, match="No blank profile file"):
        bpy.ops.blisk_cam.simulate_stock()
    assert bpy.ops.blisk_cam.clear_paths() == {"FINISHED"}
    with pytest.raises(RuntimeError, match="No generated paths"):
        bpy.ops.blisk_cam.simulate_stock()
    assert "Blisk CAM – Stock" not in bpy.data.collections  # nothing written


def test_simulate_stock_on_a_whole_blisk_mesh(addon, demo, tmp_path):
    """Part = a whole-blisk mesh object (the demo blade × 24 on a hub ring), split by the
    core: the deviation is measured on the split part's blade 0 and hub sector; the mesh
    object is untouched; a wrong blade count is refused with the symmetry found."""
    import math

    from blisk_cam.blender.stock_objects import COLLECTION
    from blisk_cam.core.geometry.axis import Axis, revolve
    from blisk_cam.core.geometry.vectors import rotate_about
    from blisk_cam.core.part.model import split_blisk_mesh

    blade, s, _ = _setup(demo, tmp_path)
    c = demo.hub_cone  # the demo blade patterned 24 times on a revolved hub ring
    p1, p2 = np.array([c.r1, c.z1]), np.array([c.r2, c.z2])
    HV, HQ = revolve(np.linspace(p1 - 0.3 * (p2 - p1), p2 + 0.3 * (p2 - p1), 12), Axis(),
                     segments=360)
    parts = [(HV, np.concatenate([HQ[:, [0, 1, 2]], HQ[:, [0, 2, 3]]]))] + [
        (rotate_about(demo.blade_vertices, np.array([0.0, 0.0, 1.0]), k * 2 * math.pi / 24,
                      form="coordinate"), demo.blade_faces) for k in range(24)]
    offs = np.cumsum([0] + [len(V) for V, _ in parts[:-1]])
    V = np.concatenate([V for V, _ in parts])
    F = np.concatenate([F + o for (_, F), o in zip(parts, offs, strict=True)])
    ob = blender_io.arrays_to_object("Whole blisk", V, F)
    Vb = blender_io.object_to_arrays(ob)
    s.stock_part_source, s.stock_part, s.stock_resolution = "MESH", ob, 1.0
    s.blade_count = 20
    with pytest.raises(RuntimeError, match="24-fold symmetry but the blade count given is 20"):
        bpy.ops.blisk_cam.simulate_stock()
    s.blade_count = 24
    result, error = _simulate()
    assert result == {"FINISHED"}
    part = split_blisk_mesh(*Vb, 24).part
    coll = bpy.data.collections[COLLECTION]
    dev_ob = next(o for o in coll.objects if "part" in o.name)
    assert len(dev_ob.data.vertices) == len(part.part_mesh()[0])
    assert np.isfinite(_attr(dev_ob, "deviation")).sum() > 100
    after = blender_io.object_to_arrays(ob)
    assert np.array_equal(after[0], Vb[0]) and np.array_equal(after[1], Vb[1])
