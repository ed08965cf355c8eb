"""The operation kinds of a job beyond blade finishing (issue 24): semi-finishing (blade
finishing leaving an allowance, paper 003 §5: 0.1 mm) and hub finishing, run as one job on the
demo blisk — checked from the outputs: the semi-finishing path leaves its allowance (recorded
in its paths JSON and measured: the ball centres lie radius + allowance from the blade), the hub
path is a hub-finishing path whose contacts lie on the hub, the stock simulation of the hub
operation (with the tool's own slim holder) finds no crash, one tool change per tool; then the
kinds' bad inputs, each naming the operation and the key."""

from __future__ import annotations

import json

import numpy as np
import pytest

from blisk_cam.cli.main import main
from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.job import iter_run_job, load_job
from blisk_cam.core.toolpath.paths_io import read_paths_json
from blisk_cam.core.toolpath.types import MOVE_CUT
from tests.support.jobs import demo_job_head

JOB = f"""{demo_job_head(resolution=1.0)}
[[tool]]
number = 3
type = "ball"
diameter = 16
flutes = 2
stick_out = 70

[[tool]]
number = 5
type = "ball"
diameter = 6
flutes = 2
flute_length = 12
holder = "12 2.5 100 2.5 100 8 160 8"

[[operation]]
name = "semi-finish"
kind = "semi_finish"
tool = 3
cone1 = [170.0, -25.0, 185.0, 35.0]
cone2 = [215.0, -25.0, 225.0, 35.0]
cusp = 1.0
chord = 0.5
axis_mode = "radial"
radial_tilt = 75

[[operation]]
name = "hub"
kind = "hub_finish"
tool = 5
scallop = 0.3
allowance = 0.3
"""


@pytest.fixture(scope="module")
def processed(tmp_path_factory):
    root = tmp_path_factory.mktemp("kinds")
    job = root / "kinds.toml"
    job.write_text(JOB)
    out = root / "out"
    rc = main(["process", str(job), "--out", str(out), "--quiet"])
    return rc, out


def test_semi_finishing_and_hub_finishing_in_one_job(processed):
    rc, out = processed
    assert (out / "summary.json").exists(), rc
    demo = make_demo_blisk(resolution=0.3)
    blade = MeshDistance(TriMesh.from_arrays(demo.blade_vertices, demo.blade_faces))

    semi = read_paths_json(out / "01-semi-finish.paths.json")
    assert semi.allowance == pytest.approx(0.1)
    cut = semi.program.move == MOVE_CUT
    centres = semi.program.tip[cut] + 8.0 * semi.program.axis[cut]
    d = blade.query(centres).distance
    assert np.median(d) == pytest.approx(8.1, abs=0.05)  # ball radius + the allowance
    assert d.min() >= 8.1 - 0.5 - 1e-6  # never closer than the chord into the allowance

    hub = read_paths_json(out / "02-hub.paths.json")
    assert hub.operation == "hub-finish"
    part = part_from_demo(demo)
    cc = np.vstack([c.cc for c in hub.curves])
    rel = cc - part.axis.o
    z = rel @ part.axis.d
    r = np.linalg.norm(rel - np.outer(z, part.axis.d), axis=1)
    assert np.abs(r - part.hub_r(z)).max() < 0.1  # on the revolved hub profile

    assert rc == 0  # every verdict passed (the semi-finishing's too)
    sim = json.loads((out / "02-hub.simulation.json").read_text())
    assert sim["crashes"] == [] and sim["passed"], sim["crashes"][:3]
    text = (out / "job.linuxcnc.ngc").read_text()
    assert [ln.split()[0] for ln in text.splitlines() if "M6" in ln.split()] == ["T3", "T5"] \
        or text.count("M6") == 2


def test_the_final_verdict_is_in_the_summary_and_the_setup_sheet(processed):
    """The job's final verdict (:mod:`blisk_cam.core.process.job_verdict`) on the last stock:
    in summary.json (passed, bounds, areas, zones) and the setup sheet; the bound where the hub
    finishing's contacts reach is its scallop + chord + the stock's resolution."""
    rc, out = processed
    summary = json.loads((out / "summary.json").read_text())
    fv = summary["final_verdict"]
    # semi-finishing's 0.1 mm is within the 1 mm stock's bound: nothing is left unmachined
    assert fv["passed"] and fv["status"] == "passed" and rc == 0
    assert fv["area_not_machined_mm2"] == 0.0
    assert fv["resolution_mm"] == 1.0
    hub = read_paths_json(out / "02-hub.paths.json")
    assert fv["bounds_mm"]["hub"] == pytest.approx(
        hub.stats["scallop_estimate_mm"] + hub.chord + 1.0)
    assert 0 < fv["area_unresolved_mm2"] < fv["area_surface_mm2"]
    assert fv["area_unreachable_mm2"] == pytest.approx(
        sum(z["area_mm2"] for z in fv["zones"] if z["status"] == "unreachable"), abs=0.05)
    sheet = (out / "setup_sheet.md").read_text()
    assert "## Final verdict" in sheet and "Final verdict: passed" in sheet


def _bad(tmp_path, old, new):
    assert old in JOB
    f = tmp_path / "bad.toml"
    f.write_text(JOB.replace(old, new, 1))
    return f


@pytest.mark.parametrize("old, new, words", [
    ("scallop = 0.3", "scalop = 0.3",
     r"operation 2 \('hub'\): unknown key 'scalop'; did you mean 'scallop'"),
    # (the fillet takes 'scallop' too: its layers' spacing; the hub's ring is no fillet key)
    ('kind = "hub_finish"', 'kind = "fillet_finish"\nring_width = 2',
     r"operation 2 \('hub'\).*unknown key 'ring_width'"),
    ("scallop = 0.3", "scallop = 0.3\nlead = \"ten\"",
     r"operation 2 \('hub'\) key 'lead': expected a number"),
])
def test_bad_kind_options_name_the_operation_and_key(tmp_path, old, new, words):
    with pytest.raises(BliskCamError, match=words):
        job = load_job(_bad(tmp_path, old, new))
        next(iter(iter_run_job(job)))  # the up-front check runs before any long work
        gen = iter_run_job(job)
        for _ in range(3):
            next(gen)


def test_hub_finishing_needs_a_ball(tmp_path):
    text = JOB.replace('type = "ball"\ndiameter = 6', 'type = "flat"\ndiameter = 6', 1)
    f = tmp_path / "flat.toml"
    f.write_text(text)
    gen = iter_run_job(load_job(f))
    with pytest.raises(BliskCamError, match=r"operation 2 \('hub'\) key 'tool': hub and fillet "
                                            r"finishing need a ball; tool T5 is a flat"):
        for _ in range(3):
            next(gen)


ROUGH_JOB = """
[part]
source = "demo"
material = "Ti-6Al-4V"
[part.demo]
resolution = 0.5

[stock]
blank = "envelope:2"
resolution = 1.0

[machine]
name = "ac-trunnion"
posts = ["linuxcnc"]

[[tool]]
number = 1
type = "bull"
diameter = 10
corner_radius = 1
flutes = 4
flute_length = 30
holder = "30 5 120 5 120 16 180 16"

[[operation]]
name = "roughing"
kind = "rough"
tool = 1
stepover = 6
depth_per_cut = 8
"""


def test_roughing_is_a_job_operation_from_the_blank(tmp_path):
    """The rough kind runs from the job's blank and leaves its stock to the next operation:
    a paths JSON that says "rough", no crash and no gouge on the simulated stock (with the
    tool's own holder), most of the sector's material removed between blank and part."""
    job = tmp_path / "rough.toml"
    job.write_text(ROUGH_JOB)
    out = tmp_path / "out"
    # no finishing operation: the final verdict is incomplete (exit 6), nothing failed
    assert main(["process", str(job), "--out", str(out), "--quiet"]) == 6
    path = read_paths_json(out / "01-roughing.paths.json")
    assert path.operation == "rough"
    sim = json.loads((out / "01-roughing.simulation.json").read_text())
    assert sim["crashes"] == [] and sim["passed"]
    assert sim["deviation_mm"]["gouged_vertices"] == 0
    removed = sim["volume_removed_mm3"]["sector"]
    assert removed > 0.3 * sim["volume_initial_mm3"]["sector"]  # the channel is most of it
    assert "M6" in (out / "job.linuxcnc.ngc").read_text()


def test_roughing_options_are_checked_up_front(tmp_path):
    job = tmp_path / "bad.toml"
    job.write_text(ROUGH_JOB.replace("stepover = 6\n", ""))
    gen = iter_run_job(load_job(job))
    with pytest.raises(BliskCamError, match=r"operation 1 \('roughing'\): key 'stepover' is "
                                            r"missing"):
        for _ in range(3):
            next(gen)


def test_roughing_axis_option_is_checked_up_front(tmp_path):
    job = tmp_path / "bad.toml"
    job.write_text(ROUGH_JOB.replace("stepover = 6\n", 'stepover = 6\naxis = "sideways"\n'))
    gen = iter_run_job(load_job(job))
    with pytest.raises(BliskCamError, match=r"key 'axis': blades or radial, got 'sideways'"):
        for _ in range(3):
            next(gen)


def test_a_post_the_collision_gate_refuses_keeps_the_other_outputs(tmp_path):
    """A hub tool whose Ø32 holder starts 30 mm up collides with the blades: the program is
    not written (exit 4, as `paths`), but the operations' paths, stocks and reports are, and
    the setup sheet and the summary say which program was refused and why."""
    text = JOB.replace('holder = "12 2.5 100 2.5 100 8 160 8"',
                       'holder = "12 2.5 30 2.5 30 16 160 16"')
    text = text[:text.index("[[operation]]")] + text[text.index('name = "hub"') - 14:]
    job = tmp_path / "fat.toml"
    job.write_text(text)
    out = tmp_path / "out"
    assert main(["process", str(job), "--out", str(out), "--quiet"]) == 4
    names = {p.name for p in out.iterdir()}
    assert {"01-hub.paths.json", "01-hub.simulation.json", "setup_sheet.md"} <= names
    assert not [n for n in names if n.startswith("job.linuxcnc")]
    summary = json.loads((out / "summary.json").read_text())
    assert "unresolved collisions" in summary["programs_refused"]["linuxcnc"]
    assert "Program linuxcnc NOT written" in (out / "setup_sheet.md").read_text()


def test_the_shipped_template_is_a_valid_job_of_the_whole_process(capsys):
    """`process --template tung-tso` names a job file that reads without error and holds
    paper 003's stages in order; an unknown template lists the known ones."""
    from blisk_cam.core.process.job import job_template

    job = load_job(job_template("tung-tso"))
    assert [o.kind.name for o in job.operations] == [
        "rough", "semi_finish", "blade_finish", "hub_finish", "fillet_finish"]
    assert job.operations[0].options["allowance"] == 0.5
    assert job.operations[1].options["allowance"] == 0.1
    assert job.operations[3].options["ring_width"] > 0  # two hub regions
    assert main(["process", "--template", "tung-soo", "--out", "x"]) == 1
    assert "unknown job template 'tung-soo'; known: tung-tso" in capsys.readouterr().err
