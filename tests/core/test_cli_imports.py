"""What ``python -m blisk_cam paths`` imports (issue 21: the CLI's startup at the prompt).

A ``paths`` run imports the modules of its own command only: not the other commands' (robot,
roughing, the stock, the hub, the verification without ``--verify``), and on the compiled
kernels not scipy.spatial nor scipy.sparse (~60 ms of a ~0.2 s startup: its trees are built,
and imported, only on the numpy backend or by the requests that need one; the mesh's face
components and windings are compiled). Each run is a new process whose
``sys.modules`` is listed at its exit.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_binary_stl

ROOT = Path(__file__).resolve().parents[2]

#: modules (prefixes) a ``paths`` run without --verify, --nc, collisions or Blender outputs
#: has no use for
NOT_FOR_PATHS = (
    "blisk_cam.cli.robot", "blisk_cam.cli.rough", "blisk_cam.cli.simulate",
    "blisk_cam.cli.process", "blisk_cam.cli.hub", "blisk_cam.cli.blender",
    "blisk_cam.core.robot", "blisk_cam.core.process.roughing", "blisk_cam.core.channel",
    "blisk_cam.core.stock", "blisk_cam.core.hub", "blisk_cam.core.verify",
    "blisk_cam.core.collision.scene", "blisk_cam.core.display", "blisk_cam.batch",
    "bpy", "dask",
)

#: run the CLI as ``python -m blisk_cam`` does, then list the modules it imported (stderr)
#: as it exits: at its ``os._exit`` (a command computed in the process) or the interpreter's
_LISTING = """
import atexit, os, runpy, sys
from blisk_cam.core.kernels.backend import backend_name

def listing():
    sys.stderr.write("MODULES " + " ".join(sorted(sys.modules)) + "\\n"
                     + "BACKEND " + backend_name() + "\\n")
    sys.stderr.flush()

def leave(code, _exit=os._exit):
    listing()
    _exit(code)

atexit.register(listing)
os._exit = leave
sys.argv = ["blisk_cam", *sys.argv[1:]]
runpy.run_module("blisk_cam", run_name="__main__", alter_sys=True)
"""


def _modules_of(args):
    """(exit status, the modules imported when the process exited, its kernels' name)."""
    proc = subprocess.run([sys.executable, "-c", _LISTING, *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    lines = proc.stderr.splitlines()
    modules = next(x for x in lines if x.startswith("MODULES ")).split()[1:]
    backend = next(x for x in lines if x.startswith("BACKEND ")).split(" ", 1)[1]
    return proc.returncode, set(modules), backend


def _unneeded(modules):
    return sorted(m for m in modules if m.startswith(NOT_FOR_PATHS))


@pytest.fixture(scope="module")
def blade(tmp_path_factory):
    d = make_demo_blisk(resolution=0.3)
    path = write_binary_stl(tmp_path_factory.mktemp("blade") / "blade.stl", d.blade_vertices,
                            d.blade_faces)
    return str(path), [str(x) for x in d.hub_cone.as_list()], \
        [str(x) for x in d.tip_cone.as_list()]


def test_a_paths_run_imports_only_its_own_command(blade, tmp_path):
    stl, cone1, cone2 = blade
    out = tmp_path / "paths.json"
    rc, modules, backend = _modules_of(
        ["paths", "--mesh", stl, "--cone1", *cone1, "--cone2", *cone2, "--tool-diameter", "12",
         "--cusp", "0.5", "--chord", "0.2", "--quiet", "--out", str(out)])
    assert rc == 0 and json.loads(out.read_text())["stats"]["passes"] > 0
    # the listing saw the run: the plan's modules are there
    assert {"blisk_cam.core.process.blade_finish", "blisk_cam.core.paths.passes",
            "blisk_cam.cli.paths", "numpy"} <= modules
    assert _unneeded(modules) == []
    if backend.startswith("compiled"):  # nor scipy.sparse: the mesh's orientation is compiled
        assert "scipy.spatial" not in modules and "scipy.sparse" not in modules
    else:  # the numpy kernels build scipy's k-d trees: the listing sees a lazy import
        assert "scipy.spatial" in modules


def test_paths_help_imports_no_other_command_nor_the_plan():
    rc, modules, _ = _modules_of(["paths", "--help"])
    assert rc == 0
    assert "blisk_cam.cli.paths" in modules
    assert _unneeded(modules) == []
    assert not modules & {"blisk_cam.core.process.blade_finish", "scipy.spatial",
                          "scipy.sparse"}


def test_the_listing_sees_another_commands_modules():
    """The check can fail: ``robot --help`` imports the robot's modules, and they are seen."""
    rc, modules, _ = _modules_of(["robot", "--help"])
    assert rc == 0
    assert "blisk_cam.cli.robot" in _unneeded(modules)


def test_a_paths_run_leaves_with_its_lines_written(blade, tmp_path):
    """``python -m blisk_cam paths`` ends at once after the command (``os._exit``, no
    interpreter shutdown): its lines on a pipe are all there, the JSON is whole, and a usage
    error still exits 2 with its one line."""
    stl, cone1, cone2 = blade
    out = tmp_path / "paths.json"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run(
        [sys.executable, "-m", "blisk_cam", "paths", "--mesh", stl, "--cone1", *cone1,
         "--cone2", *cone2, "--tool-diameter", "12", "--cusp", "0.5", "--chord", "0.2",
         "--out", str(out)], cwd=ROOT, capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[0].startswith(f"wrote {out}") and lines[-1].startswith("time: ")
    assert json.loads(out.read_text())["stats"]["passes"] > 0
    bad = subprocess.run([sys.executable, "-m", "blisk_cam", "paths", "--mesh", stl,
                          "--cusp", "x", "--out", str(out)], cwd=ROOT, capture_output=True,
                         text=True, timeout=300, env=env)
    assert bad.returncode == 2 and len(bad.stderr.splitlines()) == 1
    assert bad.stderr.startswith("blisk_cam: error: argument --cusp")


@pytest.mark.parametrize("args", [["--version"], ["--help"], ["pathz"]])
def test_the_top_level_imports_no_command(args):
    """``--version``, the top level's ``--help`` and an unknown command name only the
    commands: none of their modules is imported (building every command's arguments took
    ~0.14 s of CPU)."""
    rc, modules, _ = _modules_of(args)
    assert rc == (2 if args == ["pathz"] else 0)
    commands = {f"blisk_cam.cli.{c}" for c in ("paths", "nc", "robot", "simulate", "rough",
                                                "hub", "process", "blender")}
    assert "blisk_cam.cli.main" in modules
    assert not modules & commands
