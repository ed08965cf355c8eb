"""The Operations panel (issue 24, Blender side): a job of two operations on the demo blisk
(semi-finishing with a Ø16 ball, hub finishing with a Ø6 ball in a slim holder) made with the
panel's operators, reordered and one disabled; Generate All runs the job's core: one collection
per enabled operation with its paths' curves (the curve points are the core path's), the
disabled one skipped, the stock shown is the one after the selected operation; Export Job
writes the job `process` reads back to the same operations; ESC keeps the previous results;
an operation naming a missing tool is refused naming the operation and the key."""

import bpy
import numpy as np
import pytest
from _layout import Layout, drawn

HOLDER = "12 2.5 100 2.5 100 8 160 8"


def _scene():
    s = bpy.context.scene.blisk_cam
    s.job_part_source, s.job_demo_resolution, s.job_material = "DEMO", 0.3, "Ti-6Al-4V"
    s.stock_blank, s.stock_allowance, s.stock_resolution = "ALLOWANCE", 0.6, 1.0
    s.machine, s.post = "ac-trunnion", "linuxcnc"
    for number, d, extra in ((3, 16.0, {"stick_out": 70.0}),
                             (5, 6.0, {"flute_length": 12.0, "holder": HOLDER})):
        assert bpy.ops.blisk_cam.tool_add() == {"FINISHED"}
        t = s.job_tools[-1]
        t.number, t.type, t.diameter, t.flutes = number, "ball", d, 2
        for k, v in extra.items():
            setattr(t, k, v)
    # the hub operation first, then the semi-finishing added after it: reordered below
    s.job_tool_index = 1
    assert bpy.ops.blisk_cam.operation_add(kind="hub_finish", name="hub") == {"FINISHED"}
    _set(s.operations[0], scallop="0.3", allowance="0.3")
    s.job_tool_index = 0
    assert bpy.ops.blisk_cam.operation_add(kind="semi_finish", name="semi") == {"FINISHED"}
    semi = s.operations[1]
    assert semi.tool == 3 and s.operations[0].tool == 5
    _set(semi, cone1="[170.0, -25.0, 185.0, 35.0]", cone2="[215.0, -25.0, 225.0, 35.0]",
         cusp="1.0", chord="0.5", axis_mode="radial", radial_tilt="75")
    s.operation_index = 1
    assert bpy.ops.blisk_cam.operation_move(direction="UP") == {"FINISHED"}
    assert [o.name for o in s.operations] == ["semi", "hub"] and s.operation_index == 0
    return s


def _set(op, **values):
    rows = {o.key: o for o in op.options}
    for k, v in values.items():
        rows[k].value = v


def _curve_points(ob):
    from blisk_cam.blender.path_objects import curve_points_mm

    return np.vstack(curve_points_mm(ob))


def _skin_volume(ob):
    V = np.array([v.co for v in ob.data.vertices], float)
    F = np.array([p.vertices[:] for p in ob.data.polygons])
    return abs(np.einsum("ij,ij->i", V[F[:, 0]], np.cross(V[F[:, 1]], V[F[:, 2]])).sum() / 6)


def test_operations_panel_generate_all_export_and_escape(addon, tmp_path):
    from blisk_cam.blender.operation_objects import operation_collections, stored_stocks
    from blisk_cam.blender.path_objects import output_objects
    from blisk_cam.blender.stock_objects import COLLECTION, stock_summary
    from blisk_cam.core.process.job import load_job
    from blisk_cam.operators import generate_all as mod
    from blisk_cam.operators.modal_job import ModalRunner
    from blisk_cam.panels.operations import BLISKCAM_PT_operations

    s = _scene()
    # every option row is one the kind declares
    from blisk_cam.core.process.operation_kinds import OPERATION_KINDS

    for o in s.operations:
        assert [r.key for r in o.options] == list(OPERATION_KINDS[o.kind].options)
    # Export Job: the TOML `process` reads, back to the same operations
    out = tmp_path / "job.toml"
    assert bpy.ops.blisk_cam.export_job(filepath=str(out)) == {"FINISHED"}
    job = load_job(out)
    assert [(o.name, o.kind.name, o.tool.number) for o in job.operations] == [
        ("semi", "semi_finish", 3), ("hub", "hub_finish", 5)]
    assert job.operations[0].options["cone1"] == [170.0, -25.0, 185.0, 35.0]
    assert job.operations[0].options["axis_mode"] == "radial"
    assert job.operations[1].options == {"scallop": 0.3, "allowance": 0.3}
    assert job.tools[5].holder == ((12.0, 2.5), (100.0, 2.5), (100.0, 8.0), (160.0, 8.0))
    text = out.read_text()
    assert "resolution = 0.3\n" in text  # the number typed, not its single-precision value
    with pytest.raises(RuntimeError, match="exists: tick Replace Existing"):
        bpy.ops.blisk_cam.export_job(filepath=str(out))
    assert out.read_text() == text  # never replaced without the user's word
    # Generate All (the modal code, stepped)
    ctx = bpy.context
    op = ModalRunner(mod.BLISKCAM_OT_generate_all, mod.OperationsJob(ctx))
    op.start(ctx)
    try:
        assert not bpy.ops.blisk_cam.generate_all.poll()
        while (r := op.step(ctx)) == {"RUNNING_MODAL"}:
            op._job._thread.join(0.2)
    finally:
        op._job.stop()
    assert r == {"FINISHED"}, op.reports
    run = op._job.run_result
    colls = operation_collections()
    assert set(colls) == {o.uid for o in s.operations}
    for o, orun in zip(s.operations, run.operations, strict=True):
        objs = output_objects(colls[o.uid])
        assert objs["cc"] is not None and objs["cc"].type == "CURVE"
        cc = _curve_points(objs["cc"])
        core_cc = np.vstack([c.cc for c in orun.path.curves])
        assert len(cc) == len(core_cc) and np.abs(cc - core_cc).max() < 1e-3
    for o, orun in zip(s.operations, run.operations, strict=True):  # figures per operation
        assert o.result.startswith(f"{len(orun.path.program)} rows, ")
        assert ("passed" if orun.simulation.summary["passed"] else "FAILED") in o.result
    assert any(x == f"label: {s.operations[0].result.split('; ')[0]}"
               for x in drawn(BLISKCAM_PT_operations))
    # the stock after the selected operation, then after the other one
    stocks = stored_stocks(ctx.scene)
    assert s.operation_index == 0
    sk = bpy.data.collections[COLLECTION]
    skin = next(o for o in sk.objects if "stock" in o.name)
    v1 = _skin_volume(skin)
    assert len(skin.data.vertices) == len(stocks[s.operations[0].uid]["skin_V"])
    shown = stock_summary(ctx.scene)
    assert shown["operation"] == "semi"
    assert shown["volume_remaining_mm3"] == run.operations[0].simulation.summary[
        "volume_remaining_mm3"]
    s.operation_index = 1  # selecting shows the stock after it
    skin = next(o for o in sk.objects if "stock" in o.name)
    shown = stock_summary(ctx.scene)
    assert shown["operation"] == "hub"
    assert shown["volume_remaining_mm3"] == run.operations[1].simulation.summary[
        "volume_remaining_mm3"]
    assert shown["volume_remaining_mm3"] != run.operations[0].simulation.summary[
        "volume_remaining_mm3"]
    assert len(skin.data.vertices) == len(stocks[s.operations[1].uid]["skin_V"])
    v2 = _skin_volume(skin)
    assert run.operations[1].stock_out["volume_mm3"] < run.operations[1].stock_in["volume_mm3"]
    assert v2 < v1  # the hub finishing removed material: a smaller remaining stock
    # disable the semi-finishing: the next run skips it (no collection)
    s.operations[0].enabled = False
    op2 = ModalRunner(mod.BLISKCAM_OT_generate_all, mod.OperationsJob(ctx))
    op2.start(ctx)
    # ESC while the hub operation runs: nothing of the new run, the previous results kept
    names = sorted(c.name for c in operation_collections().values())
    stock_before = stock_summary(ctx.scene)
    try:
        assert op2.step(ctx) == {"RUNNING_MODAL"}  # the thread started
        while "operation 2" not in op2._job.message and op2._job.running:
            op2._job._thread.join(0.05)
        assert op2._job.running, op2._job.message
        assert op2.step(ctx, "ESC") == {"CANCELLED"}
    finally:  # a thread left running hangs the process at exit
        op2._job.stop()
    assert op2._job.cancel.is_set() and not op2._job.running and not mod._RUNNING
    assert "previous results are kept" in op2.reports[-1][1]
    assert sorted(c.name for c in operation_collections().values()) == names
    assert stock_summary(ctx.scene) == stock_before
    assert bpy.ops.blisk_cam.generate_all() == {"FINISHED"}
    colls = operation_collections()
    assert set(colls) == {s.operations[1].uid}
    assert s.operations[0].result == "disabled: not run"
    assert output_objects(colls[s.operations[1].uid])["cc"] is not None


def test_operations_bad_input(addon):
    from blisk_cam.panels.operations import BLISKCAM_PT_operations, BLISKCAM_PT_tool_table

    s = _scene()
    rows = drawn(BLISKCAM_PT_operations)  # the selected operation's kind, tool, options
    assert {"BLISKCAM_UL_operations", "kind", "tool", "value", "blisk_cam.generate_all",
            "blisk_cam.export_job", "blisk_cam.operation_move"} <= set(rows)
    assert rows.count("value") == len(s.operations[s.operation_index].options)
    assert {"BLISKCAM_UL_job_tools", "diameter", "flutes", "flute_length",
            "holder"} <= set(drawn(BLISKCAM_PT_tool_table))
    from blisk_cam.panels.operations import BLISKCAM_UL_job_tools, BLISKCAM_UL_operations

    log = []  # the list rows: enable toggle, position, name, kind and tool
    BLISKCAM_UL_operations.draw_item(None, bpy.context, Layout(log), s, s.operations[1], 0, s,
                                     "operation_index", 1, 0)
    assert log == ["enabled", "label: 2.", "name", "label: hub_finish T5"]
    log.clear()
    BLISKCAM_UL_job_tools.draw_item(None, bpy.context, Layout(log), s, s.job_tools[1], 0, s,
                                    "job_tool_index", 1, 0)
    assert log == ["label: T5  Ø6 ball, 2 flutes"]
    s.operations[1].tool = 9
    with pytest.raises(RuntimeError, match=r"operation 2 \('hub'\) key 'tool': tool T9 is not "
                                           "in the tool table"):
        bpy.ops.blisk_cam.generate_all()
    s.operations[1].tool = 5
    _set(s.operations[1], scallop="0.3 mm")
    with pytest.raises(RuntimeError, match=r"operation 2 \('hub'\) key 'scallop'"):
        bpy.ops.blisk_cam.generate_all()
    assert "Blisk CAM – Operations" not in bpy.data.collections  # nothing written


def test_a_kind_registered_later_appears_with_its_options(addon):
    """A kind registered after the add-on (as roughing will be) is offered and its declared
    options become the operation's rows, without a change to the panel."""
    from blisk_cam.core.process import operation_kinds as ok
    from blisk_cam.properties import kind_items

    kind = ok.OperationKind("zz_probe", "a probe kind", ok.prepare_hub_finish,
                            {"levels": (2, "levels"), "depth_step": (0.5, "mm")})
    ok.register_operation_kind(kind)
    try:
        assert "zz_probe" in [i[0] for i in kind_items(None, bpy.context)]
        assert bpy.ops.blisk_cam.operation_add(kind="zz_probe") == {"FINISHED"}
        op = bpy.context.scene.blisk_cam.operations[0]
        assert op.kind == "zz_probe" and [r.key for r in op.options] == ["levels", "depth_step"]
        op.options[0].value = "3"
        op.kind = "hub_finish"  # another kind: its own rows; the probe's values dropped
        assert [r.key for r in op.options] == list(ok.OPERATION_KINDS["hub_finish"].options)
    finally:
        del ok.OPERATION_KINDS["zz_probe"]
    assert "zz_probe" not in [i[0] for i in kind_items(None, bpy.context)]
