"""Issue 14, item 6: a scene that does not show millimetres is detected, and
``blisk_cam.set_scene_mm`` switches it in one click without changing what the add-on reads."""

import bpy
import numpy as np
import pytest

from blisk_cam.blender import objects as blender_io
from blisk_cam.blender import units
from tests.support.mesh_files import sample_surface, write_binary_stl


def _setup(system, scale, unit):
    u = bpy.context.scene.unit_settings
    u.system = system
    u.scale_length = scale
    if system != "NONE":
        u.length_unit = unit
    return bpy.context.scene


def test_default_scene_is_flagged_with_what_the_user_sees():
    scene = bpy.context.scene
    assert units.scene_units(scene) == {"system": "METRIC", "scale_length": 1.0,
                                        "length_unit": "METERS"}
    assert not units.is_scene_mm(scene)
    msg = units.scene_units_problem(scene)
    assert "metres" in msg and "81.9 m" in msg and "1 Blender unit as 1 mm" in msg
    assert "Set Scene to Millimetres" in msg


@pytest.mark.parametrize(
    "system, scale, unit, factor, word",
    [
        ("METRIC", 0.01, "CENTIMETERS", 10.0, "centimetres"),
        ("IMPERIAL", 0.0254, "INCHES", 25.4, "inches"),
        ("NONE", 1.0, None, 1.0, "without units"),
        ("METRIC", 0.001, "METERS", 1.0, "metres"),  # mm scale, but shown in metres
    ],
)
def test_other_unit_setups_are_flagged(system, scale, unit, factor, word):
    scene = _setup(system, scale, unit)
    assert not units.is_scene_mm(scene)
    assert blender_io.mm_per_blender_unit(scene) == pytest.approx(factor)
    msg = units.scene_units_problem(scene)
    assert msg is not None and word in msg
    if factor != 1.0:
        assert f"{factor:g} mm" in msg


def test_millimetre_scene_is_not_flagged():
    scene = _setup("METRIC", 0.001, "MILLIMETERS")
    assert units.is_scene_mm(scene) and units.scene_units_problem(scene) is None


def test_operator_sets_mm_and_keeps_the_mesh_in_mm(addon, tmp_path):
    """A Rotor-37-sized part (82 mm) imported into the default scene: after one click the
    scene shows millimetres and the add-on still reads the same numbers in mm."""
    V, F = sample_surface()
    V = V * (81.9 / np.ptp(V[:, 0]))
    obj = blender_io.import_mesh_file(write_binary_stl(tmp_path / "part.stl", V, F))
    before, _ = blender_io.object_to_arrays(obj)
    assert np.ptp(before[:, 0]) == pytest.approx(81.9, rel=1e-5)
    assert bpy.ops.blisk_cam.set_scene_mm.poll()
    assert bpy.ops.blisk_cam.set_scene_mm() == {"FINISHED"}
    scene = bpy.context.scene
    assert units.scene_units(scene) == {"system": "METRIC", "scale_length": pytest.approx(0.001),
                                        "length_unit": "MILLIMETERS"}
    assert units.is_scene_mm(scene) and units.scene_units_problem(scene) is None
    after, _ = blender_io.object_to_arrays(obj)
    np.testing.assert_array_equal(after, before)  # 1 BU = 1 mm before and after
    # Blender now displays the width in mm: 81.9 BU × 0.001 m/BU = 0.0819 m
    assert obj.dimensions.x * scene.unit_settings.scale_length == pytest.approx(0.0819, rel=1e-5)
    # already mm: the operator does not apply
    assert not bpy.ops.blisk_cam.set_scene_mm.poll()
    with pytest.raises(RuntimeError, match="already uses millimetres"):
        bpy.ops.blisk_cam.set_scene_mm()


def test_operator_from_centimetres_reports_the_size_change(addon):
    scene = _setup("METRIC", 0.01, "CENTIMETERS")
    assert units.set_scene_mm(scene) == pytest.approx(10.0)
    assert units.is_scene_mm(scene)
    assert blender_io.mm_per_blender_unit(scene) == 1.0
