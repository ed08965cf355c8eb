"""The command line: ``python -m blisk_cam`` and ``scripts/blender_cli.py`` as subprocesses (exit
status, one line on stderr), the demo output, and the ``paths`` input pipeline in-process."""

import json
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from blisk_cam.blender import render
from blisk_cam.cli import main as cli
from blisk_cam.core.errors import BliskCamError
from tests.support.blades import blade_stl
from tests.support.mesh_files import (
    sample_surface,
    stl_triangles,
    write_ascii_stl,
    write_binary_stl,
    write_obj,
)

REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 240  # s per CLI process; a hang (e.g. bpy 4.5 at exit) fails instead of blocking
PATHS_OPTS = ["--tool", "ball", "--tool-radius", "6", "--cusp", "0.05", "--chord", "0.05"]


def run_cli(*args, script=False):
    """Run the CLI in a child process from the repository root; returns CompletedProcess."""
    if script:
        cmd = [sys.executable, str(REPO / "scripts" / "blender_cli.py"), "--", *args]
    else:
        cmd = [sys.executable, "-m", "blisk_cam", *args]
    env = dict(os.environ)
    env.pop("BLISK_CAM_VERBOSE", None)
    env.pop("BLISK_CAM_DEBUG", None)
    return subprocess.run(
        ["timeout", "--kill-after=10", str(TIMEOUT), *cmd],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        stdin=subprocess.DEVNULL,
        timeout=TIMEOUT + 30,
    )


def assert_one_error_line(proc, *words):
    assert proc.returncode not in (0, 124, 137), (proc.returncode, proc.stderr)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, f"expected one line on stderr, got:\n{proc.stderr}"
    line = lines[0]
    assert line.startswith("blisk_cam: error: "), line
    assert "Traceback" not in proc.stderr
    for w in words:
        assert w.lower() in line.lower(), f"{w!r} not in {line!r}"
    return line


# --- demo --------------------------------------------------------------------------------


def test_demo_writes_blend_and_visible_preview(tmp_path):
    out = tmp_path / "demo out"
    proc = run_cli("demo", "--out", str(out), "--resolution", "640", "360",
                   "--mesh-resolution", "0.3", "--cusp", "0.2", "--chord", "0.2")
    assert proc.returncode == 0, proc.stderr
    assert "Traceback" not in proc.stderr
    blend, png, js = out / "demo.blend", out / "preview.png", out / "paths.json"
    assert blend.is_file() and png.is_file() and js.is_file()
    assert str(blend) in proc.stdout and str(png) in proc.stdout and str(js) in proc.stdout
    paths = json.loads(js.read_text())
    assert paths["tolerances"] == {"cusp": 0.2, "chord": 0.2} and len(paths["curves"]) > 5

    # the picture shows something: many pixels differ from the background, in several hues
    assert render.image_coverage(png) > 0.10
    img = bpy.data.images.load(str(png))
    try:
        assert tuple(img.size) == (640, 360)
        px = np.empty(640 * 360 * 4, dtype=np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    rgb = px.reshape(-1, 4)[:, :3]
    warm = np.mean(rgb[:, 0] > rgb[:, 2] + 0.15)  # the gold blade, the orange tip cone
    cool = np.mean(rgb[:, 2] > rgb[:, 0] + 0.15)  # the blue hub-cone grid
    assert warm > 0.01 and cool > 0.001, (warm, cool)

    # the .blend holds the scene: blades, hub, both cones, the axis, the camera, settings
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    names = set(bpy.data.objects.keys())
    for name in ("Blade", "Blade +1", "Blade -1", "Hub", "Blade cone 1", "Blade cone 2",
                 "Blisk Axis"):
        assert name in names, names
    # each cone once: the output collection's, not a second copy from the demo scene
    assert not {"Cone 1 (hub)", "Cone 2 (tip)"} & names
    assert len(bpy.data.objects["Blade"].data.polygons) > 1000
    assert bpy.data.objects["Blisk Axis"].type == "EMPTY"
    assert bpy.context.scene.camera is not None
    settings = bpy.context.scene.get("blisk_cam")  # ID properties while unregistered (4.x)
    if settings is not None:
        assert settings["blade"] == bpy.data.objects["Blade"]
    # the paths made by the operators are in the blade's output collection
    coll = bpy.data.collections["Blisk CAM – Blade"]
    curves = bpy.data.objects["Blade CC paths"]
    assert curves.name in coll.objects and len(curves.data.splines) == len(paths["curves"])


def test_demo_rejects_bad_options(tmp_path):
    assert_one_error_line(run_cli("demo"), "--out")
    assert_one_error_line(
        run_cli("demo", "--out", str(tmp_path), "--resolution", "640", "x"), "resolution"
    )
    file_out = tmp_path / "file"
    file_out.write_text("x")
    proc = run_cli("demo", "--out", str(file_out), "--no-preview")
    assert_one_error_line(proc, "not a directory")


# --- bad input: one line on stderr, non-zero status --------------------------------------


def _bad_mesh(tmp_path, kind):
    V, F = sample_surface(3, 3)
    path = tmp_path / {
        "missing": "missing.stl",
        "empty-obj": "empty.obj",
        "empty-stl": "empty.stl",
        "text-stl": "notes.stl",
        "nan-stl": "nan.stl",
        "nan-obj": "nan.obj",
        "nan-binary": "nanb.stl",
        "unsupported": "blade.txt",
    }[kind]
    if kind == "empty-obj":
        path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    elif kind == "empty-stl":
        path.write_text("solid empty\nendsolid empty\n")
    elif kind == "text-stl":
        path.write_text("These are my notes, not a mesh.\nSecond line.\n")
    elif kind == "nan-stl":
        write_ascii_stl(path, V, F, bad="nan")
    elif kind == "nan-obj":
        write_obj(path, V, F, bad="nan")
    elif kind == "nan-binary":
        Vn = V.copy()
        Vn[0, 2] = np.nan
        write_binary_stl(path, Vn, F)
    elif kind == "unsupported":
        path.write_text("1 2 3\n")
    return path


@pytest.mark.parametrize(
    ("kind", "words"),
    [
        ("missing", ["missing.stl", "not found"]),
        ("empty-obj", ["empty.obj", "no faces"]),
        ("empty-stl", ["empty.stl", "no faces"]),
        ("text-stl", ["notes.stl", "cannot read"]),
        ("nan-stl", ["nan.stl", "NaN"]),
        ("nan-obj", ["nan.obj", "NaN"]),
        ("nan-binary", ["nanb.stl", "NaN"]),
        ("unsupported", ["blade.txt", "unsupported"]),
    ],
)
def test_paths_bad_mesh_one_line(tmp_path, kind, words):
    mesh = _bad_mesh(tmp_path, kind)
    proc = run_cli("paths", "--mesh", str(mesh), *PATHS_OPTS, "--out", str(tmp_path / "p.json"))
    line = assert_one_error_line(proc, *words)
    assert proc.returncode == 1, line
    assert not (tmp_path / "p.json").exists()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--bogus"], ["unrecognized", "--bogus"]),
        (["--cusp", "abc"], ["--cusp", "abc"]),
        (["--tool-radius", "nan"], ["--tool-radius", "finite"]),
        (["--chord", "-1"], ["--chord", "≥ 0.0001"]),  # the one bound of core.options
        (["--tool", "drill"], ["--tool", "drill"]),
        (["--cone1", "1", "2", "3"], ["--cone1", "4"]),
        (["--cone1", "-5", "0", "10", "20"], ["--cone1", "r1"]),
        (["--axis", "0", "0", "0", "0", "0", "0"], ["--axis", "zero"]),
        (["--tool", "bull"], ["--corner-radius"]),
    ],
)
def test_paths_bad_options_one_line(tmp_path, args, words):
    mesh = write_binary_stl(tmp_path / "ok.stl", *sample_surface())
    base = ["paths", "--mesh", str(mesh), *PATHS_OPTS, "--out", str(tmp_path / "p.json")]
    proc = run_cli(*base, *args)
    assert_one_error_line(proc, *words)
    assert proc.returncode == 2


def test_no_command_and_unknown_command():
    assert_one_error_line(run_cli(), "no command")
    assert_one_error_line(run_cli("frobnicate"), "frobnicate")


def test_blender_cli_script_passes_arguments_and_status(tmp_path):
    proc = run_cli(
        "paths", "--mesh", str(tmp_path / "none.stl"), *PATHS_OPTS, "--out", "p.json",
        script=True,
    )
    assert_one_error_line(proc, "none.stl", "not found")
    assert proc.returncode == 1
    proc = run_cli("demo", "--out", str(tmp_path), "--oops", script=True)
    assert_one_error_line(proc, "--oops")
    assert proc.returncode == 2


# --- paths: the input side, in-process ---------------------------------------------------


def test_paths_reads_the_mesh_into_the_core_request(tmp_path, monkeypatch):
    """``paths`` reads the mesh (core ``mesh_io``, float64) and builds the core request from
    the flags, with no Blender scene in between (planning stubbed: no path is computed)."""
    mesh = blade_stl("rotor37")
    T = stl_triangles(mesh)
    seen = {}

    def fake_iter_plan_paths(trimesh, req, **_stages):  # the CLI iterates for its progress
        seen.update(V=trimesh.V, F=trimesh.F, req=req)
        raise BliskCamError("stubbed: no path")
        yield

    import blisk_cam.core.process.blade_finish as pipeline

    monkeypatch.setattr(pipeline, "iter_plan_paths", fake_iter_plan_paths)
    status = cli.main(
        ["paths", "--mesh", str(mesh), "--cone1", "177.5", "-1.7", "188", "45",
         "--cone2", "252.5", "4.3", "243.7", "36.2", "--axis", "0", "0", "0", "0", "0", "2",
         "--tool", "BULL", "--tool-radius", "6", "--corner-radius", "2", "--cusp", "0.05",
         "--chord", "0.02", "--lead", "3", "--tilt", "-1.5", "--link", "zigzag",
         "--out", str(tmp_path / "paths.json")]
    )
    assert status == 1 and not (tmp_path / "paths.json").exists()
    V, F, req = seen["V"], seen["F"], seen["req"]
    assert V.dtype == np.float64 and F.dtype == np.int64 and len(F) == len(T)
    np.testing.assert_allclose(np.sort(V[F].reshape(-1, 3), axis=0),
                               np.sort(T.reshape(-1, 3), axis=0), atol=1e-9)
    assert req.tool_type == "bull" and req.corner_radius == 2.0 and req.link == "zigzag"
    assert req.cone1.as_list() == [177.5, -1.7, 188.0, 45.0]  # typed decimals, not float32
    assert req.axis.direction == (0.0, 0.0, 1.0) and req.axis.origin == (0.0, 0.0, 0.0)
    assert req.lead == np.radians(3.0) and req.tilt == np.radians(-1.5)  # float64, exact
    assert (req.cusp, req.chord, req.tool_radius, req.tool_diameter) == (0.05, 0.02, 6.0, 12.0)
    from blisk_cam import is_registered

    assert not is_registered()  # no Blender scene was needed


def test_paths_bad_cones_one_line(tmp_path):
    """Cones that miss the blade: the operator's error report becomes the one line, status 1."""
    mesh = write_binary_stl(tmp_path / "ok.stl", *sample_surface())
    proc = run_cli("paths", "--mesh", str(mesh), *PATHS_OPTS, "--out", str(tmp_path / "p.json"),
                   "--cone1", "400", "0", "410", "40", "--cone2", "450", "0", "460", "40")
    line = assert_one_error_line(proc, "cone")
    assert proc.returncode == 1, line
    assert "Operator" not in line and "poll()" not in line
    assert not (tmp_path / "p.json").exists()
