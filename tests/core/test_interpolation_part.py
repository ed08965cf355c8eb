"""Issue 28 row 11: constant-error interpolation keeps ``--max-error`` against the PART on a
blade it was not tuned on: a demo-generator blade with other parameters (chords, stagger,
camber, lean), Ø12 ball at radial tilt 88° on the A/C trunnion, densely planned (chord
0.002 mm), [dM] = 0.01 mm. Every cut block of the written LinuxCNC program is measured
independently of the interpolation's model: LinuxCNC's interpreter (rs274) gives the joint
motions, forward kinematics the tool, and the ball centre's distance to the mesh minus ρ is
the error (:mod:`tests.support.part_error`). Before (the error taken from the planned path
only): 53 of 442 blocks above 10 µm, max 10.88 µm. A scan-like blade (noise, jitter,
slivers), posted with its mesh (``part``), must keep the promise too (bench
``bench/bench_interpolation_unseen.py``, resolution 0.7, before: 174 of 464 above, max
13.4 µm)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.machine.description import load_machine
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.cones import Cone
from blisk_cam.core.post.blocks import SAFE, NcOptions
from blisk_cam.core.post.export import export_nc, nc_program
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.toolpath.types import MOVE_CUT
from tests.support.nc import RS274, parse_canon, run_rs274
from tests.support.part_error import block_errors

TOL = 0.01
#: the program's 4 decimals: 0.05 µm in X Y Z, 0.00005° in the rotaries (≤ 0.2 µm at 230 mm)
PRINT = 3e-4
D = math.radians
HELD_OUT = dict(chord_hub=45.0, chord_tip=42.0, stagger_hub=D(25), stagger_tip=D(45),
                camber_hub=D(35), camber_tip=D(20), lean=D(-4))


def _blade(**extra):
    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0, **HELD_OUT, **extra)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=3.0, chord=0.002, axis_mode="radial",
                      radial_tilt=D(88.0))
    return mesh, plan_paths(mesh, req).path


def _judge(err, last):
    """Every block within the bound; ≥ 90 % of the blocks that are not a pass's remainder
    (its last block) in 70–100 % of it."""
    above = err > TOL + PRINT
    assert not above.any(), (f"{above.sum()} of {len(err)} cut blocks above {1000 * TOL:g} µm "
                             f"against the part (max {1000 * err.max():.2f} µm)")
    r = err[~last] / TOL
    band = float(np.mean((r >= 0.7) & (r <= 1.0 + PRINT / TOL)))
    assert band >= 0.9, f"only {band:.1%} of the blocks in 70–100 % of the bound"


@pytest.mark.skipif(RS274 is None, reason="rs274 (LinuxCNC, linuxcnc-uspace) is not installed")
def test_constant_error_holds_against_the_part_through_rs274(tmp_path):
    mesh, path = _blade()
    machine = load_machine("ac-trunnion")
    opts = NcOptions(interpolation="constant-error", max_error=TOL)
    out = tmp_path / "p.ngc"
    export_nc(path, machine, "linuxcnc", opts, out)  # as `nc` posts it: no mesh at hand
    _, blocks = nc_program(path, machine, "linuxcnc", opts)
    rc, canon = run_rs274(out, tmp_path)
    assert rc == 0, canon[-500:]
    xyz, deg, _ = parse_canon(canon, machine.axis_names)
    # the interpreter's motions: the safe start, then per block one motion (a SAFE retract
    # two: retract, index), then the safe end
    safe = blocks.kind == SAFE
    assert len(xyz) == len(blocks) + safe.sum() + 2
    keep = np.concatenate([[False], np.repeat(~safe, np.where(safe, 2, 1)), [False]])
    xyz, deg = xyz[keep], deg[keep]
    cut = blocks.kind[blocks.poses] == MOVE_CUT
    assert np.abs(xyz - blocks.xyz[blocks.poses]).max() < 1e-4  # the same motions
    err, ends = block_errors(machine, 6.0, MeshDistance(mesh), xyz, deg, cut)
    assert len(err) > 100
    last = np.append(~cut[ends[:-1] + 1], True)
    _judge(err, last)


def test_constant_error_holds_against_a_scan_like_part(tmp_path):
    mesh, path = _blade(scan_like=True, scan_noise=0.002, seed=3)
    machine = load_machine("ac-trunnion")
    md = MeshDistance(mesh)
    opts = NcOptions(interpolation="constant-error", max_error=TOL)
    reps: list = []
    _, blocks = nc_program(path, machine, "linuxcnc", opts, reports=reps, part=md)
    assert reps[0].budget == "part mesh"
    pose = blocks.poses
    cut = blocks.kind[pose] == MOVE_CUT
    err, ends = block_errors(machine, 6.0, md, blocks.xyz[pose], np.degrees(blocks.angles[pose]),
                             cut)
    assert len(err) > 100
    last = np.append(~cut[ends[:-1] + 1], True)
    _judge(err, last)


def test_nc_part_mesh_flag(tmp_path, capsys):
    """``nc --part-mesh`` budgets against the blade mesh (the report says so); without it a
    path planned with a chord tolerance as large as the max error is refused (before: the
    search crept on in 0.001-dense-step blocks for minutes); a missing mesh is one line, exit
    1, before any work; the mesh is never an output."""
    import json

    from blisk_cam.cli.main import main as cli_main
    from blisk_cam.core.toolpath.paths_io import write_paths_json
    from tests.support.mesh_files import write_binary_stl

    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(203.0, -25.0, 214.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=3.0, chord=0.01, axis_mode="radial",
                      radial_tilt=D(75.0))
    js = tmp_path / "p.json"
    write_paths_json(plan_paths(mesh, req).path, js)
    base = ["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
            "--quiet", "--interpolation", "constant-error", "--max-error", "0.01"]
    rep = tmp_path / "r.json"
    out = tmp_path / "p.ngc"
    assert cli_main([*base, "--out", str(out), "--part-mesh", str(stl), "--report",
                     str(rep)]) == 0
    assert json.loads(rep.read_text())["interpolation"]["own_deviation_budget"] == "part mesh"
    assert "part's mesh is counted" in out.read_text()
    capsys.readouterr()
    # without the mesh the path's chord (0.01 mm) is budgeted whole: nothing left for blocks
    assert cli_main([*base, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "chord tolerance 0.01 mm" in err[0] and "--part-mesh" in err[0]
    assert cli_main([*base, "--out", str(out), "--part-mesh", str(tmp_path / "no.stl")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no.stl" in err[0]
    size = stl.stat().st_size
    assert cli_main([*base, "--out", str(stl), "--part-mesh", str(stl)]) != 0
    capsys.readouterr()
    assert stl.stat().st_size == size


def test_nc_budgets_against_the_mesh_the_paths_recorded(tmp_path, capsys):
    """Without ``--part-mesh``, ``nc`` measures constant-error against the mesh the paths JSON
    records (``paths`` writes its name and SHA-256 in ``stats``) while the file is unchanged;
    once its bytes change it warns, names the file and budgets the chord whole (here: refused,
    the chord equals the max error)."""
    import json

    from blisk_cam.cli.main import main as cli_main
    from blisk_cam.cli.nc import planned_mesh_stats
    from blisk_cam.core.toolpath.paths_io import write_paths_json
    from tests.support.mesh_files import write_binary_stl

    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    stl = write_binary_stl(tmp_path / "blade.stl", d.blade_vertices, d.blade_faces)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(203.0, -25.0, 214.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=3.0, chord=0.01, axis_mode="radial",
                      radial_tilt=D(75.0))
    path = plan_paths(mesh, req).path
    path.stats.update(planned_mesh_stats(stl))
    js = tmp_path / "p.json"
    write_paths_json(path, js)
    rep, out = tmp_path / "r.json", tmp_path / "p.ngc"
    base = ["nc", "--paths", str(js), "--machine", "ac-trunnion", "--post", "linuxcnc",
            "--quiet", "--interpolation", "constant-error", "--max-error", "0.01",
            "--out", str(out)]
    capsys.readouterr()
    assert cli_main([*base, "--report", str(rep)]) == 0
    assert json.loads(rep.read_text())["interpolation"]["own_deviation_budget"] == "part mesh"
    assert str(stl) in capsys.readouterr().err
    write_binary_stl(stl, d.blade_vertices + 1e-3, d.blade_faces)  # the user's file changed
    assert cli_main(base) == 1
    err = capsys.readouterr().err
    assert "has changed since the paths were planned" in err and str(stl) in err
    assert "chord tolerance 0.01 mm" in err
