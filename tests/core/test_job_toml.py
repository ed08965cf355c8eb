"""The job in memory (issue 24, for the Blender Operations panel): ``job_from_data`` checks
the tables of a job as ``load_job`` checks a file, and ``job_toml`` writes them as a file that
``load_job`` reads back to the same job; what a job file cannot hold is refused."""

import math
import tomllib

import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.process.job import JobError, job_from_data, load_job
from blisk_cam.core.process.job_toml import job_toml

DATA = {
    "part": {"source": "demo", "material": "Ti-6Al-4V", "demo": {"resolution": 0.3}},
    "stock": {"blank": "allowance:0.6", "resolution": 1.0},
    "machine": {"name": "ac-trunnion", "posts": ["linuxcnc"]},
    "tool": [{"number": 3, "type": "ball", "diameter": 16.0, "flutes": 2, "stick_out": 70.0},
             {"number": 5, "type": "ball", "diameter": 6.0, "flutes": 2,
              "flute_length": 12.0, "holder": "12 2.5 100 2.5 100 8 160 8",
              "name": 'slim "hub" ball\\n'}],
    "operation": [
        {"name": "semi", "kind": "semi_finish", "tool": 3,
         "cone1": [170.0, -25.0, 185.0, 35.0], "axis_mode": "radial", "radial_tilt": 75},
        {"name": "off", "kind": "hub_finish", "tool": 5, "enabled": False},
        {"name": "hub", "kind": "hub_finish", "tool": 5, "scallop": 0.3, "allowance": 0.3}],
}


def _ops(job):
    return [(o.index, o.name, o.kind.name, o.tool.number, o.options) for o in job.operations]


def test_job_toml_round_trips_through_load_job(tmp_path):
    text = job_toml(DATA, "a header\nof two lines")
    assert tomllib.loads(text) == DATA  # the tables themselves, exactly
    f = tmp_path / "job.toml"
    f.write_text(text)
    from_file, in_memory = load_job(f), job_from_data(DATA, tmp_path / "job.toml")
    assert _ops(from_file) == _ops(in_memory)
    assert [o[0] for o in _ops(in_memory)] == [1, 3]  # the disabled one skipped, numbered
    assert from_file.tools == in_memory.tools and from_file.blank == in_memory.blank


def test_job_from_data_errors_name_the_operation_and_the_key(tmp_path):
    bad = {**DATA, "operation": [dict(DATA["operation"][0]), {**DATA["operation"][2],
                                                               "tool": 9}]}
    with pytest.raises(JobError, match=r"job panel operation 2 \('hub'\) key 'tool': tool T9 "
                                       "is not in the tool table"):
        job_from_data(bad, tmp_path / "panel")
    with pytest.raises(JobError, match="expected the tables"):
        job_from_data([], tmp_path / "panel")
    for value in (math.nan, {1, 2}, None.__class__):
        with pytest.raises(BliskCamError, match="key 'x'"):
            job_toml({"part": {"x": value}})
