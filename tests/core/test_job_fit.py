"""Issue 24: the fillet radius measured on the part (not given), and tools that do not fit —
a fillet ball not smaller than the measured fillet, a hub, fillet or roughing tool that does not
fit the gap between the blades — refused before any operation runs, naming the file, the
operation, the key and the tool; nothing written."""

from __future__ import annotations

import re

import pytest

import blisk_cam.core.process.job as job_module
from blisk_cam.cli.main import main
from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.hub.fillet import measure_fillet
from blisk_cam.core.hub.surface import HubSurface
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.part.model import part_from_demo
from blisk_cam.core.process.job import iter_run_job, load_job
from tests.support.jobs import demo_job_head


def _measure(**kw):
    part = part_from_demo(make_demo_blisk(resolution=0.3, **kw))
    return measure_fillet(TriMesh.from_arrays(part.blade_vertices, part.blade_faces),
                          HubSurface(part.hub_profile, part.axis))


@pytest.mark.parametrize("radius", [8.0, 12.0])
def test_the_fillet_radius_is_measured_on_the_demo_blade(radius):
    """The demo's fillet is a flare of radius ρ_f tangent to hub and wall (sheared where the
    wall leans): the band it makes is ρ_f high (to the 1 mm bin) and its median concave
    radius lies within 12 % of ρ_f, its tightest below it; no fillet, nothing measured."""
    m = _measure(fillet_radius=radius)
    assert m is not None
    assert abs(m.height - radius) <= 1.0
    assert m.radius == pytest.approx(radius, rel=0.12)
    assert m.tightest < m.radius
    assert _measure(fillet=False) is None


JOB = f"""{demo_job_head(resolution=1.0)}
[[tool]]
number = 5
type = "ball"
diameter = 6
flutes = 2
flute_length = 12
holder = "12 2.5 100 2.5 100 8 160 8"

[[tool]]
number = 8
type = "TYPE"
diameter = DIAMETER
CORNER
flutes = 2
flute_length = 60
holder = "60 22 100 22 100 30 160 30"

[[operation]]
name = "hub"
kind = "hub_finish"
tool = 5
stepover = 5

[[operation]]
name = "too big"
kind = "KIND"
tool = 8
OPTIONS
"""


def _job(tmp_path, kind, diameter, typ="ball", corner="", options=""):
    f = tmp_path / "fit.toml"
    f.write_text(JOB.replace("KIND", kind).replace("DIAMETER", str(diameter))
                 .replace("TYPE", typ).replace("CORNER", corner).replace("OPTIONS", options))
    return f


def test_a_fillet_ball_not_smaller_than_the_measured_fillet_is_refused(tmp_path):
    measured = _measure()  # the demo's default 8 mm fillet
    f = _job(tmp_path, "fillet_finish", 18)  # radius 9 mm
    with pytest.raises(BliskCamError) as err:
        for _ in iter_run_job(load_job(f)):
            pass
    msg = str(err.value)
    assert msg.startswith("job fit.toml operation 2 ('too big') key 'tool': tool T8")
    assert "radius 9 mm" in msg
    got = float(re.search(r"fillet measured on the part: radius ([0-9.]+) mm", msg).group(1))
    assert got == pytest.approx(measured.radius, abs=0.01)


@pytest.mark.parametrize("kind, diameter, typ, corner, options, words", [
    ("hub_finish", 40, "ball", "", "stepover = 5",
     "does not fit the gap between the blades at the hub"),
    ("rough", 40, "bull", "corner_radius = 2", "stepover = 6\ndepth_per_cut = 6",
     "does not fit the channel at the hub"),
])
def test_a_tool_that_does_not_fit_the_gap_is_refused_before_any_work(
        tmp_path, monkeypatch, capsys, kind, diameter, typ, corner, options, words):
    """Hub finishing (and fillet finishing, by the same channel check) and roughing: the tool
    is checked against the gap once the blank is built, before operation 1 plans anything."""
    def no_work(*args, **kwargs):
        raise AssertionError("an operation ran before the job was checked")

    monkeypatch.setattr(job_module, "iter_run_operation", no_work)
    f = _job(tmp_path, kind, diameter, typ, corner, options)
    out = tmp_path / "out"
    assert main(["process", str(f), "--out", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "job fit.toml operation 2 ('too big') key 'tool': tool T8" in err
    assert words in err
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fit.toml"]


def test_the_fillet_operation_itself_refuses_a_ball_not_smaller_than_the_measured_fillet():
    """The `hub --operation fillet` command's core too: a given fillet radius larger than the
    ball does not let a ball pass that the part's own fillet is too tight for."""
    from blisk_cam.core.process.fillet_finish import FILLET_FINISH
    from blisk_cam.core.process.hub_finish import HubRequest
    from blisk_cam.core.process.operation import run_operation

    part = part_from_demo(make_demo_blisk(resolution=0.3))
    measured = _measure()
    with pytest.raises(BliskCamError, match=rf"radius 9 mm, the fillet measured on the part "
                                            rf"{measured.radius:.2f} mm"):
        run_operation(FILLET_FINISH, part, HubRequest(tool_diameter=18.0, fillet_radius=20.0))
