"""Per-blade paths of a whole-blisk scan and the Dask batch (blisk_cam/batch,
core/process/per_blade).

A scan-like blisk of 3 blades, each offset along its own normals by a different δ_k, one with
a notch tighter than the ball: the program has one section per good blade made from that
blade's own faces (its cutter centres stand one ball radius off *its* mesh and δ_k off the
nominal blade in its place), each blade's path passes the verify against its own blade, the
notched blade is reported by number and the others are written. The same jobs run on a
local Dask cluster whose only worker is killed by the last task give byte-identical
outputs (the wall times in a single command's JSON aside);
a re-run skips what is unchanged. Coarse on purpose (cusp 0.4 mm, Ø10 ball, 3 blades)."""

from __future__ import annotations

import math
import os
import shutil

import numpy as np
import pytest

from blisk_cam.batch.jobs import JobsError, load_jobs
from blisk_cam.batch.run import MANIFEST, run_batch
from blisk_cam.cli.main import main
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.model import theta_about
from blisk_cam.core.toolpath.paths_io import read_paths_json
from tests.support.blades import tube_blade
from tests.support.mesh_files import write_binary_stl
from tests.support.scan_blisk import worn_blisk

N = 3
BROKEN = 0
OFFSETS = np.array([0.04, 0.08, 0.16])
RADIUS = 5.0

JOBS = """
[defaults]
tool = "ball"
tool-diameter = 10
cusp = 0.4
chord = 0.2
lead = 10
# the test is about each blade's own geometry, not the avoidance: paper 004's per-pose
# rotation clears this scan's few colliding poses (the axis planner reports one motion
# between two clear poses on blades 1 and 2 as unresolved)
avoid-method = "rotate"

[[job]]
name = "scan"
command = "blades"
mesh = "scan.stl"
neighbours = 1
machine = "ac-trunnion"
post = "apt"

[[job]]
name = "tube"
command = "paths"
mesh = "tube.stl"

[[job]]
name = "study"
command = "sweep"
mesh = "tube.stl"
blade-count = 12
tool-diameter = 6
holder-length = [30, 90]
"""


def _files(folder):
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def scan(tmp_path_factory):
    """The scan, its jobs file and the reference run: the jobs one after another in this
    process (no Dask)."""
    d = tmp_path_factory.mktemp("batch")
    V, F, demo, blades = worn_blisk(N, 0.16, offsets=OFFSETS, broken=BROKEN)
    write_binary_stl(d / "scan.stl", V, F)
    TV, TF, _ = tube_blade(n_u=48, n_v=16)
    write_binary_stl(d / "tube.stl", TV, TF)
    (d / "JOBS.toml").write_text(JOBS)
    report = run_batch(d / "JOBS.toml", d / "serial", serial=True)
    return d, demo, blades, report


def _sector_of_built(blades):
    """Built blade b → the part model's blade number (its sector): by the mean angle."""
    ang = np.array([math.atan2(*np.sin(th).mean(keepdims=True), *np.cos(th).mean(
        keepdims=True)) for th in (theta_about(V, Axis())[1] for V, _ in blades)])
    return ang


def test_each_section_from_its_own_blade(scan):
    d, demo, blades, report = scan
    out = d / "serial" / "scan"
    rows = (out / "blades.csv").read_text().splitlines()[1:]
    status = {int(r.split(",")[0]): r.split(",")[1] for r in rows}
    assert len(status) == N and report.rows[0]["status"] == "partial"
    # blade number → built blade, by angle (the part model numbers from its own start)
    built_angle = _sector_of_built(blades)
    text = (out / "scan.apt").read_text()
    sections = {}
    for block in text.split("$$ blade ")[1:]:
        k = int(block.split(":", 1)[0])
        sections[k] = block
    failed = [k for k, s in status.items() if s == "failed"]
    assert len(failed) == 1 and sorted(sections) == sorted(set(status) - set(failed))
    assert f"NOT WRITTEN: blade {failed[0]}" in text
    nominal_V, nominal_F = demo.blade_vertices, demo.blade_faces
    for k, block in sections.items():
        path = read_paths_json(out / f"blade_{k}.json")
        assert path.verify["status"] == "PASS"
        cc = np.vstack([c.cc for c in path.curves])
        th = math.atan2(np.sin(theta_about(cc, Axis())[1]).mean(),
                        np.cos(theta_about(cc, Axis())[1]).mean())
        b = int(np.argmin(np.abs(np.angle(np.exp(1j * (built_angle - th))))))
        assert b != BROKEN
        own = MeshDistance(TriMesh.from_arrays(*blades[b]))
        turn = math.atan2(*np.sin([built_angle[b]]), *np.cos([built_angle[b]])) - math.atan2(
            np.sin(theta_about(nominal_V, Axis())[1]).mean(),
            np.cos(theta_about(nominal_V, Axis())[1]).mean())
        c, s = math.cos(turn), math.sin(turn)
        Rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
        nominal = MeshDistance(TriMesh.from_arrays(nominal_V @ Rz.T, nominal_F))
        # the section's cutting moves: ball centres one radius off this blade's own mesh
        goto = []
        cut = False
        for line in block.splitlines():
            if line.startswith("RAPID"):
                cut = False
            elif line.startswith("FEDRAT/"):
                cut = line.startswith("FEDRAT/1000")
            elif line.startswith("GOTO/"):
                v = [float(x) for x in line[5:].split(",")]
                if cut:
                    goto.append(v)
        g = np.array(goto)
        centre = g[:, :3] + RADIUS * g[:, 3:]
        d_own = own.query(centre).distance - RADIUS
        d_nom = nominal.query(centre).distance - RADIUS
        assert np.median(np.abs(d_own)) < 0.02, (k, np.median(d_own))
        assert abs(np.median(d_nom) - OFFSETS[b]) < 0.02, (k, b, np.median(d_nom))
        # and the path's contact points lie on the blade's own faces, δ_k off the nominal
        assert own.query(cc).distance.max() < 1e-4  # the scan is float32 STL
        assert abs(np.median(nominal.query(cc).distance) - OFFSETS[b]) < 0.02
    # the broken blade is the one reported
    broken_row = [r for r in rows if r.startswith(f"{failed[0]},")][0]
    assert "not planned" in broken_row and f"blade {failed[0]}" in broken_row


def test_dask_batch_equals_one_by_one_and_survives_a_killed_worker(scan, tmp_path,
                                                                   monkeypatch):
    pytest.importorskip("distributed")
    import cloudpickle
    from distributed import Client

    import tests.support.batch_crash as crash

    d, _, _, serial = scan
    mark = tmp_path / "crashed"
    monkeypatch.setenv("BLISK_BATCH_CRASH_MARK", str(mark))
    cloudpickle.register_pickle_by_value(crash)
    from blisk_cam.batch.run import local_cluster

    cluster = local_cluster(1)
    try:
        with Client(cluster) as client:
            jobs = [j for j in load_jobs(d / "JOBS.toml") if j.name != "study"]
            report = run_batch(jobs, tmp_path / "dask", client=client,
                               run_task=crash.crash_once)
    finally:
        cluster.close()
        cloudpickle.unregister_pickle_by_value(crash)
    assert mark.exists()  # the worker did die once
    rows = {r["job"]: r for r in report.rows}
    # every job done: the scheduler ran the killed task (and any waiting on that worker) again
    assert rows["tube"]["status"] == "ok" and rows["scan"]["tasks"] == N
    assert [r["status"] for r in report.rows] == [r["status"] for r in serial.rows[:2]]
    a, b = _files(d / "serial"), _files(tmp_path / "dask")
    a = {k: v for k, v in a.items() if not k.startswith("study/")}
    skip = {"summary.csv", "summary.md"}  # wall times
    assert sorted(set(a) - skip) == sorted(set(b) - skip)
    for name in sorted(set(a) - skip - {"tube/paths.json", MANIFEST}):
        assert a[name] == b[name], name
    for name in ("scan/scan.apt", "scan/blade_1.json", "scan/blades.csv"):
        assert name in b
    # the single command writes its wall times into its JSON: everything else is the same
    import json

    ja, jb = (json.loads(x[("tube/paths.json")]) for x in (a, b))
    for j in (ja, jb):
        for k in [k for k in j["stats"] if k.startswith("seconds")]:
            j["stats"].pop(k)
    assert ja == jb


def test_rerun_skips_unchanged_jobs(scan, tmp_path):
    d, _, _, _ = scan
    out = tmp_path / "again"
    shutil.copytree(d / "serial", out)
    report = run_batch(d / "JOBS.toml", out, serial=True)
    assert [r["status"] for r in report.rows] == ["skipped"] * 3
    # a changed argument changes the job's hash; a damaged output makes the job run again
    text = (d / "JOBS.toml").read_text().replace("cusp = 0.4", "cusp = 0.35")
    (tmp_path / "JOBS.toml").write_text(text)
    for name in ("scan.stl", "tube.stl"):
        os.symlink(d / name, tmp_path / name)
    old = {j.name: j.hash for j in load_jobs(d / "JOBS.toml")}
    new = {j.name: j.hash for j in load_jobs(tmp_path / "JOBS.toml")}
    assert all(old[k] != new[k] for k in old)
    (out / "tube" / "paths.json").write_text("{}")
    report = run_batch(d / "JOBS.toml", out, serial=True)
    assert [r["status"] for r in report.rows] == ["skipped", "ok", "skipped"]


def test_sweep_table(scan):
    d, _, _, _ = scan
    rows = (d / "serial" / "study" / "sweep.csv").read_text().splitlines()
    head = rows[0].split(",")
    cells = [dict(zip(head, r.split(","), strict=False)) for r in rows[1:]]
    assert sorted((c["tool-diameter"], c["holder-length"]) for c in cells) == [
        ("6", "30"), ("6", "90")]
    for c in cells:
        assert (c["ok"] == "yes") == (c["colliding"] == "0")
    # the row of holder length 30 is the plan of that set-up: a Ø6 shank from the flute (18 mm)
    # to 30 mm, then a Ø25 holder for 40 mm, checked against the blade turned ±1, ±2 pitches
    from blisk_cam.core.collision.options import CollisionOptions
    from blisk_cam.core.geometry.mesh_io import read_mesh
    from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
    from blisk_cam.core.process.collision_stage import collision_stage

    opts = CollisionOptions(mode="check", blade_count=12,
                            holder=((18, 3), (30, 3), (30, 12.5), (70, 12.5)))
    req = PathRequest(Axis(), tool_type="ball", tool_diameter=6, cusp=0.4, chord=0.2,
                      lead=math.radians(10))
    plan = plan_paths(TriMesh.from_arrays(*read_mesh(d / "tube.stl")), req,
                      extra=(collision_stage(opts),))
    row = [c for c in cells if c["holder-length"] == "30"][0]
    assert int(row["colliding"]) == plan.collision.n_unresolved > 0


def test_batch_errors(tmp_path, capsys, monkeypatch):
    (tmp_path / "J.toml").write_text('[[job]]\nname = "a"\ncommand = "paths"\nmesh = "no.stl"\n')
    with pytest.raises(JobsError, match="job 'a': mesh .*no.stl not found"):
        load_jobs(tmp_path / "J.toml")
    (tmp_path / "K.toml").write_text('[[job]]\nname = "a"\ncommand = "rough"\n')
    assert main(["batch", str(tmp_path / "K.toml"), "--out", str(tmp_path / "o")]) == 1
    assert "command must be one of" in capsys.readouterr().err
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "distributed" else real(name, *a))
    assert main(["batch", str(tmp_path / "K.toml"), "--out", str(tmp_path / "o")]) == 1
    assert "pip install 'blisk-cam[batch]'" in capsys.readouterr().err
