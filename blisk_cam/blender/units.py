"""Scene units: tell when a scene does not show millimetres, and switch it to millimetres.

Blisk CAM works in millimetres. In the default scene (``scale_length`` = 1, metric, length
unit metres) it reads one Blender unit as one millimetre (:func:`.objects.mm_per_blender_unit`)
— but Blender *displays* that unit as a metre: NASA Rotor 37, imported from an STL in mm,
shows as 81.9 m wide. Blender's millimetre setup (``scale_length`` = 0.001, length unit
millimetres) keeps the same factor (1 BU = 1 mm for the add-on) and shows 81.9 mm: switching
to it changes no geometry, only what the user reads. A scene at another scale (centimetres:
1 BU = 10 mm, inches: 25.4 mm) is read at its own scale; switching it to millimetres makes the
add-on read its existing objects at a different size (:func:`set_scene_mm` returns the factor
so the caller can say so).

bpy only at call time (``scene`` is passed in); no core code here.
"""

from __future__ import annotations

import math

__all__ = ["MM_SCALE_LENGTH", "is_scene_mm", "scene_units", "scene_units_problem", "set_scene_mm"]

#: ``unit_settings.scale_length`` of a millimetre scene (1 BU = 0.001 m)
MM_SCALE_LENGTH = 0.001

_UNIT_WORDS = {
    "ADAPTIVE": "adaptive units", "KILOMETERS": "kilometres", "METERS": "metres",
    "CENTIMETERS": "centimetres", "MILLIMETERS": "millimetres", "MICROMETERS": "micrometres",
    "MILES": "miles", "FEET": "feet", "INCHES": "inches", "THOU": "thou",
}


def scene_units(scene) -> dict:
    """``{"system", "scale_length", "length_unit"}`` of the scene's unit settings."""
    u = scene.unit_settings
    return {"system": str(u.system), "scale_length": float(u.scale_length),
            "length_unit": str(u.length_unit)}


def is_scene_mm(scene) -> bool:
    """True when the scene is metric, shows lengths in millimetres and 1 BU = 1 mm
    (``scale_length`` 0.001)."""
    u = scene_units(scene)
    # scale_length is a float32 in RNA: 0.001 reads back as 0.00100000005
    return (u["system"] == "METRIC" and u["length_unit"] == "MILLIMETERS"
            and math.isclose(u["scale_length"], MM_SCALE_LENGTH, rel_tol=1e-6))


def scene_units_problem(scene) -> str | None:
    """None for a millimetre scene; else one sentence saying what the user sees and the fix
    (for a panel line or a report)."""
    if scene is None or is_scene_mm(scene):
        return None
    from .objects import mm_per_blender_unit

    u = scene_units(scene)
    f = mm_per_blender_unit(scene)
    if u["system"] == "NONE":
        shown = "without units"
    else:
        shown = f"in {_UNIT_WORDS.get(u['length_unit'], u['length_unit'].lower())}"
    if f == 1.0:
        what = ("Blisk CAM reads 1 Blender unit as 1 mm, so a blade 81.9 mm wide is shown as "
                "81.9 m" if u["system"] == "METRIC" and u["length_unit"] in ("METERS", "ADAPTIVE")
                else "Blisk CAM reads 1 Blender unit as 1 mm")
    else:
        what = f"Blisk CAM reads 1 Blender unit as {f:g} mm (unit scale {u['scale_length']:g})"
    return (f"The scene shows lengths {shown} (unit system {u['system'].title()}): {what}. "
            "Set the scene to millimetres (Blisk CAM › Set Scene to Millimetres)")


def set_scene_mm(scene) -> float:
    """Make the scene metric, 1 BU = 1 mm, lengths shown in millimetres.

    Returns the factor by which the add-on's reading of existing objects changes
    (old mm per Blender unit ÷ new): 1.0 from the default scene (nothing changes but the
    display), 10.0 from a centimetre scene (its objects are now read 10 × smaller)."""
    from .objects import mm_per_blender_unit

    old = mm_per_blender_unit(scene)
    u = scene.unit_settings
    u.system = "METRIC"
    u.scale_length = MM_SCALE_LENGTH
    u.length_unit = "MILLIMETERS"
    return old / mm_per_blender_unit(scene)
