"""blisk_cam.per_blade_paths and blisk_cam.load_blade_results: a scan-like whole blisk (3
blades each offset along its own normals by a different δ_k, blade 0 with a notch tighter
than the ball) planned blade by blade in Blender, and a batch run's folder loaded back.

Measured: every blade shown has its curve points on *its own* built blade's faces (distance
to that mesh ~0, to the other blades far), the built blades matched are distinct, the one
left without paths is the notched blade and it is reported by number; the scan object is not
modified; ESC keeps the previous result; Load Results of the folder ``batch --serial`` wrote
shows the same blades the same way. Coarse on purpose (Ø10 ball, cusp 0.4 mm, chord 0.2 mm,
3 blades), as tests/core/test_batch.py."""

import math

import bpy
import numpy as np
import pytest

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import path_objects as output
from blisk_cam.blender.per_blade_objects import blade_name, per_blade_summary
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from tests.support.mesh_files import write_binary_stl
from tests.support.scan_blisk import worn_blisk

N = 3
BROKEN = 0
OFFSETS = np.array([0.04, 0.08, 0.16])

JOBS = """
[defaults]
tool = "ball"
tool-diameter = 10
cusp = 0.4
chord = 0.2
lead = 10
avoid-method = "rotate"

[[job]]
name = "scan"
command = "blades"
mesh = "scan.stl"
neighbours = 1
"""


@pytest.fixture(scope="module")
def scan():
    """(V, F, built blades' distance queries) of the worn 3-blade blisk."""
    V, F, _demo, blades = worn_blisk(N, 0.16, offsets=OFFSETS, broken=BROKEN)
    return V, F, [MeshDistance(TriMesh.from_arrays(*b)) for b in blades]


def _scene(scan):
    """The scan as a mesh object (mm) and the settings of the per-blade run."""
    V, F, _ = scan
    ob = blender_io.arrays_to_object("scan", V, F)
    s = bpy.context.scene.blisk_cam
    s.per_blade_scan = ob
    s.tool_type, s.tool_diameter, s.cusp, s.chord = "BALL", 10.0, 0.4, 0.2
    s.lead = math.radians(10.0)
    # 2 neighbours per side (the default) on 3 blades: 1 is checked, and the report says so
    s.mode, s.avoid_method, s.neighbours, s.blade_count = "AVOID", "ROTATE", 2, 0
    return ob, s


class _Layout:
    """Stands in for ``UILayout``: checks the properties drawn exist, records the labels and
    operators."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = self.use_property_decorate = False
        self.scale_y = 1.0

    def _child(self, *_a, **_kw):
        return _Layout(self.log)

    row = column = box = split = _child

    def label(self, text="", **_kw):
        self.log.append(text)

    def prop(self, data, name, **_kw):
        assert hasattr(data, name), name

    def operator(self, idname, **_kw):
        self.log.append(idname)


def _panel_lines():
    from blisk_cam.panels.per_blade import BLISKCAM_PT_per_blade

    log = []
    BLISKCAM_PT_per_blade.draw(type("P", (), {"layout": _Layout(log)})(), bpy.context)
    return log


def _check_blades(dist):
    """The shown blades: each one's CC curve points on one built blade's own faces (distinct
    blades, none the notched one); returns {blade number: built blade}."""
    summary = per_blade_summary()
    matched = {}
    for k in summary["shown"]:
        ob = bpy.data.objects[f"{blade_name(k)} CC paths"]
        assert ob.users_collection[0].name == output.collection_name(blade_name(k))
        pts = np.vstack(output.curve_points_mm(ob))
        d = np.array([q.query(pts).distance for q in dist])  # (3, n) mm
        b = int(np.argmin(np.median(d, axis=1)))
        assert d[b].max() < 1e-3, (k, d[b].max())  # on its own blade (float32 curve points)
        others = np.delete(d, b, axis=0)
        assert others.min() > 1.0, (k, others.min())  # nowhere near another blade
        matched[k] = b
    assert len(set(matched.values())) == len(matched)
    return matched, summary


def test_per_blade_modal_shows_each_blade_on_its_own_faces(addon, scan):
    from blisk_cam.operators import per_blade_paths as mod
    from blisk_cam.operators.modal_job import ModalRunner

    ob, s = _scene(scan)
    before = np.array([v.co[:] for v in ob.data.vertices])
    # ESC while the first blade is planned: cancelled, nothing written, the worker stops
    assert len(_panel_lines()) == 3  # the info line and the two operators: no result yet
    op = ModalRunner(mod.BLISKCAM_OT_per_blade_paths, mod.PerBladeJob(bpy.context))
    op.start(bpy.context)
    assert not bpy.ops.blisk_cam.per_blade_paths.poll()  # one run at a time
    assert op.step(bpy.context) == {"RUNNING_MODAL"}
    assert op.step(bpy.context, "ESC") == {"CANCELLED"}
    assert op._job.wait(60) and not op._job.done and not mod._RUNNING
    assert "previous result is kept" in op.reports[-1][1] and per_blade_summary() is None

    op = ModalRunner(mod.BLISKCAM_OT_per_blade_paths, mod.PerBladeJob(bpy.context))
    op.start(bpy.context)
    fractions, result = [], {"RUNNING_MODAL"}
    for _ in range(100000):
        result = op.step(bpy.context)
        fractions.append(op._job.fraction)
        if result != {"RUNNING_MODAL"}:
            break
        op._job.wait(0.05)
    assert result == {"FINISHED"}, op.reports
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    matched, summary = _check_blades(scan[2])
    assert summary["blade_count"] == N and len(summary["shown"]) == N - 1
    # the blade left without paths is the notched one, reported by its number
    (k_failed, reason), = summary["failed"]
    assert set(range(N)) - set(matched.values()) == {BROKEN}
    assert reason.startswith(f"blade {k_failed}:") and "not planned" in reason
    warnings = [t for kind, t in op.reports if kind == {"WARNING"}]
    assert any(t.startswith(f"blade {k_failed}:") for t in warnings)
    assert f"failed: blade(s) {k_failed}" in op.reports[-1][1]
    assert "3 blades allow 1 neighbour(s) per side, not 2: checked 1" in warnings
    # the panel: both operators, the count of blades with paths and the failed blade's reason
    lines = _panel_lines()
    assert {"blisk_cam.per_blade_paths", "blisk_cam.load_blade_results"} <= set(lines)
    assert f"scan: {N - 1} of {N} blades with paths" in lines and reason[:90] in lines
    # the scan is read, never modified
    np.testing.assert_array_equal(np.array([v.co[:] for v in ob.data.vertices]), before)


def test_load_results_of_a_batch_run(addon, scan, tmp_path):
    from blisk_cam.batch.run import run_batch

    V, F, dist = scan
    write_binary_stl(tmp_path / "scan.stl", V, F)
    (tmp_path / "JOBS.toml").write_text(JOBS)
    run_batch(tmp_path / "JOBS.toml", tmp_path / "out", serial=True)
    rows = (tmp_path / "out" / "scan" / "blades.csv").read_text().splitlines()[1:]
    status = {int(r.split(",")[0]): r.split(",")[1] for r in rows}
    s = bpy.context.scene.blisk_cam
    s.per_blade_folder = str(tmp_path / "out")  # the batch's --out: its one blades job found
    assert bpy.ops.blisk_cam.load_blade_results() == {"FINISHED"}
    matched, summary = _check_blades(dist)
    assert sorted(summary["shown"]) == sorted(k for k, v in status.items() if v == "ok")
    assert [k for k, _ in summary["failed"]] == [k for k, v in status.items() if v != "ok"]
    assert set(range(N)) - set(matched.values()) == {BROKEN}
    # the paths JSON of a loaded blade is kept as for a generated one (Export Paths works)
    k = summary["shown"][0]
    assert output.stored_paths_json(blade_name(k))
    # loading again replaces the result; a folder without a per-blade table is refused
    assert bpy.ops.blisk_cam.load_blade_results() == {"FINISHED"}
    assert len([c for c in bpy.data.collections if c.name.startswith("Blisk CAM – per")]) == 1
    with pytest.raises(RuntimeError, match="holds no blades.csv"):
        bpy.ops.blisk_cam.load_blade_results(directory=str(tmp_path))


def test_bad_input_is_refused_clearly(addon, demo):
    """No scan, not a mesh, a mesh that is not a whole blisk (one blade): refused with a
    reason the user can act on; nothing written."""
    run = bpy.ops.blisk_cam.per_blade_paths
    assert not run.poll()  # nothing active, no scan chosen
    empty = bpy.data.objects.new("empty", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    assert not run.poll()
    blade = blender_io.arrays_to_object("one blade", demo.blade_vertices, demo.blade_faces)
    bpy.context.scene.blisk_cam.per_blade_scan = blade
    assert run.poll()
    with pytest.raises(RuntimeError, match="not rotationally periodic"):
        run()
    assert per_blade_summary() is None

