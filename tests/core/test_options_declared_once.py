"""Options declared once (core.options): the declaration checks values, and the CLI flags
and the request are generated from it."""

import math

import pytest

from blisk_cam.cli import main as cli
from blisk_cam.cli import paths as cli_paths
from blisk_cam.core.errors import BliskCamError, LinkError, OptionError, OrientationError, ToolError
from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.options import (
    PATH_OPTION_GROUPS,
    CutterOptions,
    LinkingOptions,
    Spec,
    check_value,
    describe_tool,
    fields,
)
from blisk_cam.core.process.blade_finish import PathRequest


def _all_options():
    return [(stage, name, spec, default) for stage in PATH_OPTION_GROUPS
            for name, spec, default in fields(stage)]


def test_every_option_is_described_and_its_default_is_valid():
    names = set()
    for stage, name, spec, default in _all_options():
        assert spec.label and spec.help.strip(), name
        assert name not in names, f"{name} declared twice"
        names.add(name)
        check_value(name, spec, default)  # the default satisfies its own bounds
        assert stage.title
    assert {"tool_type", "tool_diameter", "cusp", "chord", "lead", "link", "approach"} <= names


def test_every_flag_is_generated_and_maps_back_in_core_units():
    parser = cli.build_parser()
    sub = parser._subparsers._group_actions[0].choices["paths"]
    flags = {s for a in sub._actions for s in a.option_strings}
    for _, name, spec, _ in _all_options():
        if spec.cli_flag(name):
            assert spec.cli_flag(name) in flags, name
    args = parser.parse_args(["paths", "--mesh", "m.stl", "--out", "o.json", "--lead", "10",
                              "--tool", "bull", "--tool-diameter", "12", "--corner-radius",
                              "2", "--link", "zigzag", "--milling", "conventional",
                              "--no-fix-gouge", "--clearance-radius", "300"])
    cli_paths._check_paths_args(args)
    req = PathRequest(Axis(), **args.stages)
    assert req.lead == math.radians(10.0)  # degrees typed, radians in core, exactly
    assert (req.tool_type, req.tool_radius, req.corner_radius) == ("bull", 6.0, 2.0)
    assert (req.link, req.climb, req.fix_local_gouge, req.clearance_radius) == (
        "zigzag", False, False, 300.0)
    assert req.cutter.describe() == "Ø12 R2 bull nose"


@pytest.mark.parametrize(
    ("kw", "error", "words"),
    [
        (dict(cusp=0.0), BliskCamError, ["cusp", "≥ 0.0001"]),
        (dict(tool_type="drill"), ToolError, ["tool", "drill", "ball"]),
        (dict(tool_diameter=-3.0), ToolError, ["diameter", "> 0"]),
        (dict(taper_angle=math.radians(60), tool_type="taper"), ToolError, ["taper", "< 60°"]),
        (dict(max_axis_turn=math.radians(95)), OrientationError, ["max axis turn", "89°"]),
        (dict(link="circles"), LinkError, ["link mode", "circles"]),
        (dict(approach=0.0), LinkError, ["approach", "> 0"]),
        (dict(clearance_margin=float("nan")), LinkError, ["clearance margin", "not a number"]),
    ],
)
def test_bounds_are_checked_once_with_the_stage_error(kw, error, words):
    with pytest.raises(error) as info:
        PathRequest(Axis(), **kw)
    text = str(info.value).lower()
    for w in words:
        assert w.lower() in text, (w, text)


def test_request_routes_flat_options_and_refuses_unknown_ones():
    req = PathRequest(Axis(), tool_radius=4.0, lead=0.1, approach=3.0)
    assert (req.tool_diameter, req.cutter.tool_radius, req.orientation.lead) == (8.0, 4.0, 0.1)
    assert req.linking == LinkingOptions(approach=3.0)
    with pytest.raises(TypeError, match="unknown option 'leed'"):
        PathRequest(Axis(), leed=0.1)
    with pytest.raises(TypeError):
        PathRequest(Axis(), tool_radius=3.0, tool_diameter=6.0)


def test_cutter_options_keep_only_what_the_cutter_uses():
    assert CutterOptions(tool_type="ball", corner_radius=2.0).corner_radius == 0.0
    assert CutterOptions(tool_type="bull").corner_radius == 2.0
    assert CutterOptions(tool_type="flat").taper_angle is None
    assert CutterOptions(tool_type="taper").taper_angle == pytest.approx(math.radians(3.0))


def test_tools_are_named_by_diameter():
    assert describe_tool("ball", 12.0) == "Ø12 ball"
    assert describe_tool("bull", 12.0, 2.0) == "Ø12 R2 bull nose"
    assert describe_tool("flat", 10.0) == "Ø10 flat"
    assert describe_tool("taper", 6.0, 0.0, math.radians(5.0)) == "Ø6 taper 5°"


def test_spec_bounds_in_user_units():
    spec = Spec("Lead", "x", unit="deg", lo=0.0, hi=math.radians(45.0), hi_open=True)
    assert spec.bounds_text() == "≥ 0° and < 45°"
    with pytest.raises(OptionError, match="50° is out of range"):
        check_value("lead", spec, math.radians(50.0))
