"""Semi-finishing on the Blender side (issue 23, item 2): the allowance is a generated scene
property, drawn in the Tolerances panel, and reaches the path request from the panel and
from the command line's flag alike."""

import bpy
import pytest

from blisk_cam.core.options import ToleranceOptions, fields
from tests.blender.test_options import _drawn, _request_from_cli


def test_allowance_is_a_panel_row_and_reaches_the_request(addon):
    from blisk_cam.panels.setup import BLISKCAM_PT_tolerances

    bpy.ops.wm.read_factory_settings(use_empty=True)
    s = bpy.context.scene.blisk_cam
    spec = dict((n, sp) for n, sp, _ in fields(ToleranceOptions))["allowance"]
    rna = s.bl_rna.properties["allowance"]
    assert (rna.name, rna.default, rna.hard_min) == (spec.label, 0.0, 0.0)
    assert "allowance" in _drawn(BLISKCAM_PT_tolerances, bpy.context)
    s, req = _request_from_cli(["--allowance", "0.1"])
    assert s.allowance == pytest.approx(0.1) and req.allowance == pytest.approx(0.1)
    s, req = _request_from_cli([])
    assert req.allowance == 0.0
