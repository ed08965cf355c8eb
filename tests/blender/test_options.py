"""The Blender layer's loose ends of issue #5: the live-preview switch, the visible cone objects
in the output collection (cones and LMRS profiles), the core options exposed as properties,
panel rows and CLI flags (one mapping for both), and LMRS fitting (`--fit`, profile files).

Small meshes only: the demo blade at resolution 0.3 and NASA Rotor 67 (17k triangles) with
coarse tolerances.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest
from _layout import drawn

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import path_objects as output
from blisk_cam.blender.settings import path_request, settings_cones
from blisk_cam.cli import main as cli
from blisk_cam.cli import paths as cli_paths
from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.axis import Axis, meridional
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.cones import Cone, MorphingCones
from blisk_cam.core.part.fitting import fit_cones_to_mesh
from blisk_cam.core.part.profiles import MorphingProfiles, Profile
from blisk_cam.core.process.blade_finish import make_cutter
from tests.support.blades import blade_stl
from tests.support.mesh_files import sample_surface, stl_triangles, write_binary_stl

REPO = Path(__file__).resolve().parents[2]
ROTOR67 = blade_stl("rotor67")
TIMEOUT = 240


@pytest.fixture(scope="module")
def rotor67_arrays():
    T = stl_triangles(ROTOR67).astype(np.float64)
    V, inv = np.unique(T.reshape(-1, 3), axis=0, return_inverse=True)
    return V, inv.reshape(-1, 3).astype(np.int64)


def _mesh_vertices(ob):
    co = np.empty(len(ob.data.vertices) * 3)
    ob.data.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def _cone_objects(blade_name):
    objs = output.output_objects(output.find_output_collection(blade_name))
    return {k: objs[k] for k in output.CONE_ROLES}


def _assert_on_generatrix(ob, generatrix, axis, scale):
    """Every vertex of ``ob`` lies on the surface of revolution of ``generatrix`` (float32
    object coordinates: 1e-6 of the size), and the object renders."""
    r, z = meridional(_mesh_vertices(ob), axis)
    dist = np.abs(generatrix.signed_distance(r, z))
    assert dist.max() < 1e-6 * scale, (ob.name, dist.max())
    assert not ob.hide_render and not ob.hide_get()


def _run_cli(*args):
    env = {k: v for k, v in os.environ.items() if k not in ("BLISK_CAM_VERBOSE",
                                                            "BLISK_CAM_DEBUG")}
    return subprocess.run(
        ["timeout", "--kill-after=10", str(TIMEOUT), sys.executable, "-m", "blisk_cam", *args],
        cwd=REPO, env=env, capture_output=True, text=True, stdin=subprocess.DEVNULL,
        timeout=TIMEOUT + 30,
    )


def _one_error_line(proc, *words):
    assert proc.returncode not in (0, 124, 137), (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("blisk_cam: error: "), proc.stderr
    for w in words:
        assert w.lower() in lines[0].lower(), (w, lines[0])
    return lines[0]


# --- properties and panels -----------------------------------------------------------------
def _drawn(panel_cls, context):
    """The properties and operators a panel draws, in order (its labels left out)."""
    return [x for x in drawn(panel_cls, context) if not x.startswith("label: ")]


def test_live_preview_and_the_new_options_have_panel_rows(addon):
    from blisk_cam.panels import CLASSES

    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene.blisk_cam
    rna = s.bl_rna.properties["live_preview"]
    assert (rna.name, rna.default) == ("Live Preview", False)
    assert rna.description == "Slice a few LMC curves while dragging a cone handle"
    for name in ("lead_tip", "tilt_tip", "taper_angle", "radial_tilt", "max_axis_turn"):
        assert s.bl_rna.properties[name].subtype == "ANGLE", name
    drawn = {}
    for axis_mode in ("LOCAL", "RADIAL", "TOWARD_POINT"):
        s.axis_mode = axis_mode
        for cls in CLASSES:
            if issubclass(cls, bpy.types.Panel):  # the UILists draw their rows, not a panel
                drawn.setdefault(cls.__name__, []).extend(_drawn(cls, bpy.context))
    region = drawn["BLISKCAM_PT_region"]
    assert region.index("live_preview") == region.index("show_gizmos") + 1  # on its row
    every = {n for names in drawn.values() for n in names}
    for name in ("fit_generatrix", "blisk_cam.fit_cones", "taper_angle", "lead", "tilt",
                 "vary_lead_tilt", "lead_tip", "tilt_tip", "axis_mode", "radial_tilt",
                 "axis_point", "max_axis_turn", "fix_local_gouge", "link_mode", "climb",
                 "approach", "clearance_radius", "clearance_margin"):
        assert name in every, name


# --- the mapping settings → PathRequest, shared by the panel and the CLI ---------------------
def _request_from_cli(argv):
    """The CLI's request (float64, straight from the flags) and the same request after a
    round trip through the scene settings (what a .blend saved by the CLI regenerates): both
    must agree, option by option."""
    from blisk_cam.blender.settings import set_settings_from_request
    from blisk_cam.core.options import PATH_OPTION_GROUPS, fields
    from blisk_cam.core.process.blade_finish import PathRequest

    args = cli.build_parser().parse_args(
        ["paths", "--mesh", "x.stl", "--cusp", "0.05", "--chord", "0.02", "--out", "p.json",
         "--axis", "1", "2", "3", "0", "0", "1", *argv])
    cli_paths._check_paths_args(args)
    req_cli = PathRequest(args.axis_obj, None, None, **args.stages)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene.blisk_cam
    set_settings_from_request(s, req_cli, fit=args.fit)
    axis = Axis((1.0, 2.0, 3.0), (0.0, 0.0, 1.0))
    req = path_request(s, axis, None, None)
    for stage in PATH_OPTION_GROUPS:
        for name, _, _ in fields(stage):
            a, b = getattr(req, name), getattr(req_cli, name)
            if isinstance(a, float) and isinstance(b, float):
                assert a == pytest.approx(b, rel=1e-6, abs=1e-7), name
            elif isinstance(a, tuple) and isinstance(b, tuple):
                assert a == pytest.approx(b, abs=1e-6), name
            else:
                assert a == b, name
    return s, req


def test_cli_flags_map_into_the_path_request(addon):
    rad = math.radians
    s, req = _request_from_cli(
        ["--tool", "taper", "--tool-radius", "4", "--taper-angle", "5", "--lead", "4",
         "--lead-tip", "8", "--tilt", "1", "--tilt-tip", "-2", "--max-axis-turn", "3",
         "--milling", "conventional", "--approach", "3.5", "--clearance-radius", "260",
         "--clearance-margin", "7", "--no-fix-gouge", "--link", "spiral", "--fit", "profile"])
    assert s.taper_angle == pytest.approx(rad(5))  # radians in the properties
    assert (req.tool_type, req.tool_radius, req.corner_radius) == ("taper", 4.0, 0.0)
    assert req.taper_angle == pytest.approx(rad(5), abs=1e-7)
    # the paths JSON's "tool" object is the request's cutter
    tool = make_cutter(req).as_dict()
    assert tool["type"] == "taper" and tool["taper_angle"] == pytest.approx(rad(5), abs=1e-7)
    assert (req.lead, req.lead_tip) == pytest.approx((rad(4), rad(8)), abs=1e-7)
    assert (req.tilt, req.tilt_tip) == pytest.approx((rad(1), rad(-2)), abs=1e-7)
    assert req.max_axis_turn == pytest.approx(rad(3), abs=1e-7)
    assert (req.axis_mode, req.climb, req.fix_local_gouge, req.link) == (
        "local", False, False, "spiral")
    assert (req.approach, req.clearance_radius, req.clearance_margin) == (3.5, 260.0, 7.0)
    assert s.fit_generatrix == "PROFILE"
    # the defaults: no variation, no smoothing, climb, automatic clearance, gouges fixed
    s, req = _request_from_cli(["--tool", "ball", "--tool-radius", "6"])
    assert (req.lead_tip, req.tilt_tip, req.max_axis_turn, req.clearance_radius) == (
        None, None, None, None)
    assert req.climb and req.fix_local_gouge and req.taper_angle is None
    assert (req.approach, req.clearance_margin) == (2.0, 5.0)
    assert s.fit_generatrix == "AUTO" and req.axis_mode == "local"
    # tool-axis modes: radial tilt; toward the blisk axis (its line); from a point
    _, req = _request_from_cli(["--tool", "ball", "--tool-radius", "6", "--axis-mode",
                                "radial", "--lead", "2", "--radial-tilt", "10"])
    assert (req.axis_mode, req.tilt) == ("radial", 0.0)
    assert req.radial_tilt == pytest.approx(rad(10), abs=1e-7)
    _, req = _request_from_cli(["--tool", "ball", "--tool-radius", "6", "--axis-mode",
                                "toward-axis"])
    assert req.axis_mode == "toward_line"
    assert (req.axis_point, req.axis_direction) == ((1.0, 2.0, 3.0), (0.0, 0.0, 1.0))
    _, req = _request_from_cli(["--tool", "ball", "--tool-radius", "6", "--axis-mode",
                                "from-point", "--axis-point", "0", "0", "500"])
    assert (req.axis_mode, req.axis_point) == ("from_point", (0.0, 0.0, 500.0))


@pytest.mark.parametrize(
    ("args", "words", "status"),
    [
        (["--tool", "ball", "--taper-angle", "5"], ["--taper-angle", "taper"], 2),
        (["--tool", "taper", "--taper-angle", "75"], ["--taper-angle", "60"], 2),
        (["--tool", "ball", "--axis-mode", "toward-point"], ["--axis-point"], 2),
        (["--tool", "ball", "--axis-mode", "sideways"], ["--axis-mode", "sideways"], 2),
        (["--tool", "ball", "--radial-tilt", "5"], ["--radial-tilt", "radial"], 2),
        (["--tool", "ball", "--max-axis-turn", "-1"], ["--max-axis-turn", "≥ 0"], 2),
        (["--tool", "ball", "--fit", "spline"], ["--fit", "spline"], 2),
        (["--tool", "ball", "--milling", "down"], ["--milling", "down"], 2),
        (["--tool", "ball", "--approach", "x"], ["--approach", "x"], 2),
        (["--tool", "ball", "--cone1", "150", "0", "160", "40", "--cone1-profile", "p.csv"],
         ["--cone1-profile", "one"], 2),
        (["--tool", "ball", "--cone2-profile", "MISSING"], ["missing.csv", "not found"], 1),
        (["--tool", "ball", "--cone1-profile", "BAD"], ["bad.csv", "line 3", "r, z"], 1),
        (["--tool", "ball", "--lead", "95", "--cone1", "150", "-20", "160", "60",
          "--cone2", "260", "-20", "270", "60"], ["lead", "89"], 1),
    ],
)
def test_cli_bad_option_values_one_line(tmp_path, args, words, status):
    mesh = write_binary_stl(tmp_path / "ok.stl", *sample_surface())
    bad = tmp_path / "bad.csv"
    bad.write_text("# r, z in mm\n150, 0\n160; forty\n")
    args = [str(tmp_path / "missing.csv") if a == "MISSING" else str(bad) if a == "BAD" else a
            for a in args]
    proc = _run_cli("paths", "--mesh", str(mesh), "--tool-radius", "6", "--cusp", "0.1",
                    "--chord", "0.1", "--out", str(tmp_path / "p.json"), *args)
    line = _one_error_line(proc, *words)
    assert proc.returncode == status, line
    assert not (tmp_path / "p.json").exists()


def test_read_profile_csv_comments_and_separators(tmp_path):
    f = tmp_path / "hub.csv"
    f.write_text("# hub line of my blisk\n\n150.0, -20  # first\n152;0\n155.5\t20\n")
    prof = cli_paths.read_profile_csv(f)
    assert isinstance(prof, Profile)
    assert prof.as_list() == [[150.0, -20.0], [152.0, 0.0], [155.5, 20.0]]
    f.write_text("150, 0\n")
    with pytest.raises(BliskCamError, match="at least two"):
        cli_paths.read_profile_csv(f)


# --- the options reach the paths JSON ---------------------------------------------------------
def test_cli_flags_reach_the_json(demo, tmp_path):
    """Lead/tilt varying hub → tip, zig-zag, no gouge fix: measured on the written poses.
    (A ball: the pass spacing of a taper costs a minute here; its angle is checked below.)"""
    stl = write_binary_stl(tmp_path / "blade.stl", demo.blade_vertices, demo.blade_faces)
    out = tmp_path / "p.json"
    proc = _run_cli(
        "paths", "--mesh", str(stl), "--tool", "ball", "--tool-radius", "4",
        "--lead", "4", "--lead-tip", "8", "--tilt", "1", "--tilt-tip",
        "3", "--no-fix-gouge", "--link", "zigzag", "--milling", "conventional",
        "--cusp", "0.5", "--chord", "0.5", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    d = json.loads(out.read_text())
    assert d["tool"]["type"] == "ball" and d["tool"]["radius"] == 4.0
    assert d["stats"]["link"] == "zigzag"
    # angle between tool axis and surface normal = atan(√(tan² lead + tan² tilt)), the lead
    # and tilt varying linearly from the first curve (s = 0) to the last (s = 1)
    by_s = {}
    for c in d["curves"]:
        n, a = np.asarray(c["normal"]), np.asarray(c["axis"])
        by_s.setdefault(c["s"], []).append(np.degrees(np.arccos(np.clip(
            np.einsum("ij,ij->i", n, a), -1.0, 1.0))))
    for s, lead, tilt in ((0.0, 4.0, 1.0), (1.0, 8.0, 3.0)):
        want = math.degrees(math.atan(math.hypot(math.tan(math.radians(lead)),
                                                 math.tan(math.radians(tilt)))))
        got = np.concatenate(by_s[s])
        np.testing.assert_allclose(got, want, atol=1e-6)
    mid = sorted(by_s)[len(by_s) // 2]
    got = float(np.median(np.concatenate(by_s[mid])))
    want = math.degrees(math.atan(math.hypot(math.tan(math.radians(4 + 4 * mid)),
                                             math.tan(math.radians(1 + 2 * mid)))))
    assert got == pytest.approx(want, abs=1e-3)


# --- cone objects in the output collection ---------------------------------------------------
def test_fit_shows_the_cones_and_generate_keeps_them(addon, demo):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    blade = blender_io.arrays_to_object("Blade", demo.blade_vertices, demo.blade_faces)
    s = scene.blisk_cam
    s.blade, s.fit_generatrix = blade, "AUTO"
    s.cusp = s.chord = 0.5
    s.verify = False
    assert bpy.ops.blisk_cam.fit_cones() == {"FINISHED"}
    assert s.profile1 == "" and s.profile2 == ""  # the demo's hub and tip are cones
    g1, g2 = settings_cones(s)
    assert isinstance(g1, Cone) and isinstance(g2, Cone)
    scale = 250.0  # mm, the size of the blisk region
    cones = _cone_objects("Blade")
    mid = MorphingCones(g1, g2).cone_at(0.5)
    for role, g in (("cone1", g1), ("cone2", g2), ("cone_middle", mid)):
        _assert_on_generatrix(cones[role], g, Axis(), scale)
    # the middle cone lies between the two (morph ratio 0.5, measured)
    r, z = meridional(_mesh_vertices(cones["cone_middle"]), Axis())
    np.testing.assert_allclose(MorphingCones(g1, g2).ratio(r, z), 0.5, atol=1e-5)
    # only cones so far: nothing to export, clear removes them
    assert not output.has_paths("Blade")
    with pytest.raises(RuntimeError, match="No generated paths"):
        bpy.ops.blisk_cam.export_paths(filepath="/tmp/never.json")
    # generating replaces the collection; the path's cones are in it, nothing duplicated
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    cones = _cone_objects("Blade")
    assert all(ob is not None for ob in cones.values())
    _assert_on_generatrix(cones["cone2"], g2, Axis(), scale)
    names = [o.name for o in bpy.data.objects if "cone" in o.name]
    assert sorted(names) == ["Blade cone 1", "Blade cone 2", "Blade middle cone"]
    # the cones cover the machined region around the axis: every CC point's angle is inside
    cc = np.concatenate(output.curve_points_mm(output.output_objects(
        output.find_output_collection("Blade"))["cc"]))
    th0, th1 = output.angular_range(cc, Axis(), margin=0.0)
    V = _mesh_vertices(cones["cone1"])
    th = np.arctan2(V[:, 1], V[:, 0])
    assert th.min() < th0 and th.max() > th1
    assert bpy.ops.blisk_cam.clear_paths() == {"FINISHED"}
    assert output.find_output_collection("Blade") is None


def test_fit_auto_stores_a_profile_for_the_curved_rotor67_hub(addon, rotor67_arrays, tmp_path):
    V, F = rotor67_arrays
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    blade = blender_io.arrays_to_object("R67", V, F)
    s = scene.blisk_cam
    s.blade = blade
    s.fit_generatrix = "CONE"
    assert bpy.ops.blisk_cam.fit_cones() == {"FINISHED"}
    assert s.profile1 == "" and s.fit_residual1 > 1.0  # a straight hub cone misses by ≈ 2 mm
    s.fit_generatrix = "AUTO"
    assert bpy.ops.blisk_cam.fit_cones() == {"FINISHED"}
    assert s.profile1 and s.fit_residual1 < 0.05
    g1, g2 = settings_cones(s)
    assert isinstance(g1, Profile)
    # the stored profile is the core's fit, in full precision (not float32)
    want = fit_cones_to_mesh(TriMesh.from_arrays(V, F), Axis(), generatrix="auto")
    assert g1.as_list() == want.cone1.as_list()
    # the cone vector holds the profile's straight cone (gizmos, panel)
    np.testing.assert_allclose(tuple(s.cone1), g1.to_cone().as_list(), atol=1e-4)
    # the objects are the surfaces of revolution of the profiles and of the middle LMRS
    morph = MorphingProfiles(g1, g2)
    cones = _cone_objects("R67")
    for role, g in (("cone1", g1), ("cone2", g2), ("cone_middle", morph.profile_at(0.5))):
        _assert_on_generatrix(cones[role], g, Axis(), 300.0)
    r, z = meridional(_mesh_vertices(cones["cone_middle"]), Axis())
    np.testing.assert_allclose(morph.ratio(r, z), 0.5, atol=1e-5)
    # the request gets the profile; it survives a save and reload
    req = path_request(s, Axis(), g1, g2)
    assert isinstance(req.cone1, Profile)
    saved = tmp_path / "r67.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(saved))
    bpy.ops.wm.open_mainfile(filepath=str(saved))
    s = bpy.context.scene.blisk_cam
    assert settings_cones(s)[0].as_list() == g1.as_list()
    # editing the cone numbers (panel, gizmo) replaces the profile: never silently ignored
    s.cone1 = (180.0, -5.0, 190.0, 40.0)
    assert s.profile1 == "" and settings_cones(s)[0].as_list() == [180.0, -5.0, 190.0, 40.0]


def test_cli_fit_auto_on_rotor67_writes_profiles(rotor67_arrays, tmp_path):
    """--fit auto picks a profile for the curved hub; --cone2-profile gives the tip; the JSON
    carries both and every pass lies on its LMRS (morph ratio measured at the CC points)."""
    V, F = rotor67_arrays
    tip = fit_cones_to_mesh(TriMesh.from_arrays(V, F), Axis(), generatrix="profile").cone2
    csv = tmp_path / "tip.csv"
    csv.write_text("# Rotor 67 tip line, r, z in mm\n"
                   + "".join(f"{r!r}, {z!r}\n" for r, z in tip.points))
    out = tmp_path / "r67.json"
    proc = _run_cli("paths", "--mesh", str(ROTOR67), "--fit", "auto", "--cone2-profile",
                    str(csv), "--tool", "ball", "--tool-radius", "8", "--cusp", "0.2",
                    "--chord", "0.2", "--out", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "profile of" in proc.stdout
    d = json.loads(out.read_text())
    assert "profile1" in d and d["profile2"] == tip.as_list()
    g1, g2 = Profile.from_list(d["profile1"]), Profile.from_list(d["profile2"])
    assert len(g1.points) > 2
    morph = MorphingProfiles(g1, g2)
    for c in d["curves"]:
        r, z = meridional(np.asarray(c["cc"]), Axis())
        if c["s"] in (0.0, 1.0):  # the boundary loops: on the fitted profile within its fit
            g = g1 if c["s"] < 0.5 else g2
            assert np.abs(g.signed_distance(r, z)).max() < 0.025  # residuals 0.009, 0.020 mm
        else:
            np.testing.assert_allclose(morph.ratio(r, z), c["s"], atol=1e-6)
    # a fitted profile's end passes lie a hair inside the ragged boundary (issue 14: one piece
    # each), a few 1e-5 of the span
    assert 0.0 <= d["curves"][0]["s"] < 1e-3 and 1.0 - 1e-3 < d["curves"][-1]["s"] <= 1.0


def test_properties_and_panel_rows_are_generated_from_the_declarations(addon):
    """One declaration per option (core.options) → the property (name, label, default,
    bounds, angle subtype) and its panel row."""
    from blisk_cam.core.options import PATH_OPTION_GROUPS, fields
    from blisk_cam.panels import CLASSES

    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene.blisk_cam
    drawn = set()
    for cls in CLASSES:
        if issubclass(cls, bpy.types.Panel):
            drawn.update(_drawn(cls, bpy.context))
    for stage in PATH_OPTION_GROUPS:
        for name, spec, default in fields(stage):
            if not spec.blender:
                continue
            prop = spec.prop_name(name)
            rna = s.bl_rna.properties[prop]
            assert rna.name == spec.label and rna.description == spec.help, name
            assert prop in drawn, name
            if spec.choices is not None and not isinstance(default, bool):
                assert rna.default == spec.choice(default).blender_id, name
            elif rna.type == "FLOAT":
                want = spec.none_as if default is None else default
                assert rna.default == pytest.approx(want, rel=1e-6), name
                assert rna.subtype == ("ANGLE" if spec.unit == "deg" else "NONE"), name
                if spec.lo is not None:
                    assert rna.hard_min >= spec.lo - 1e-9, name
    # the diameter is stored; the radius is its half
    s.tool_diameter = 10.0
    assert s.tool_radius == pytest.approx(5.0)
    s.tool_radius = 3.0
    assert s.tool_diameter == pytest.approx(6.0)
