"""Scene settings of Blisk CAM (``bpy.types.Scene.blisk_cam``), saved in the .blend.

Lengths are millimetres and angles radians, as in ``core``; operators convert to plain core
dataclasses (cutter, tolerances) at the boundary, so nothing in ``core`` ever sees this group.
Only the blade and the axis are object references (pointer properties, never Python globals).
"""

import bpy
from bpy.props import (
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
)
from bpy.types import PropertyGroup


def poll_mesh(_self, obj):
    """Pointer poll: mesh objects only (UI filter; Python assignment is not checked)."""
    return obj.type == "MESH"


def poll_empty(_self, obj):
    """Pointer poll: empties only (UI filter; Python assignment is not checked)."""
    return obj.type == "EMPTY"


TOOL_TYPES = (
    ("BALL", "Ball", "Ball-end mill: corner radius equals the tool radius"),
    ("BULL", "Bull Nose", "Torus mill: flat bottom with a corner radius"),
    ("FLAT", "Flat", "Flat-end mill: corner radius 0"),
    ("TAPER", "Taper", "Tapered ball-end mill"),
)

LINK_MODES = (
    ("ONE_WAY", "One Way", "Every pass in the same direction, retract between passes"),
    ("ZIGZAG", "Zig-Zag", "Alternate the direction of successive passes"),
    ("SPIRAL", "Spiral", "Blend successive passes into one continuous spiral"),
)

COLOR_MODES = (
    ("SOLID", "Solid", "One colour for all tool path curves"),
    ("MORPH", "Morph Ratio", "Colour each curve by its morph ratio s (cone 1 → cone 2)"),
    ("CUSP", "Cusp Height", "Colour by the measured scallop height left between passes"),
)


class BliskCamSettings(PropertyGroup):
    """Inputs of one Blisk CAM job: geometry, cones, cutter, tolerances, display."""

    # Geometry ---------------------------------------------------------------------------
    blade: PointerProperty(
        name="Blade",
        description="Mesh object of the blade (world frame, mm)",
        type=bpy.types.Object,
        poll=poll_mesh,
    )
    axis_object: PointerProperty(
        name="Axis",
        description="Empty whose local Z is the blisk axis (default: the blade's world Z "
        "through its origin)",
        type=bpy.types.Object,
        poll=poll_empty,
    )
    cone1: FloatVectorProperty(
        name="Cone 1",
        description="First cone (hub side) as generatrix r1, z1, r2, z2 in mm",
        size=4,
        default=(0.0, 0.0, 0.0, 0.0),
        precision=4,
    )
    cone2: FloatVectorProperty(
        name="Cone 2",
        description="Last cone (tip side) as generatrix r1, z1, r2, z2 in mm",
        size=4,
        default=(0.0, 0.0, 0.0, 0.0),
        precision=4,
    )

    # Cutter -----------------------------------------------------------------------------
    tool_type: EnumProperty(
        name="Tool", description="Cutter shape", items=TOOL_TYPES, default="BALL"
    )
    tool_radius: FloatProperty(
        name="Tool Radius",
        description="Cutter radius in mm",
        default=6.0,
        min=0.001,
        soft_max=50.0,
        precision=3,
    )
    corner_radius: FloatProperty(
        name="Corner Radius",
        description="Corner radius of a bull-nose cutter in mm",
        default=2.0,
        min=0.0,
        soft_max=50.0,
        precision=3,
    )

    # Tolerances -------------------------------------------------------------------------
    cusp: FloatProperty(
        name="Cusp",
        description="Largest scallop height left between passes in mm",
        default=0.05,
        min=1e-5,
        soft_max=1.0,
        precision=4,
        step=0.1,
    )
    chord: FloatProperty(
        name="Chord",
        description="Largest chord error along a pass (surface and tool path) in mm",
        default=0.05,
        min=1e-5,
        soft_max=1.0,
        precision=4,
        step=0.1,
    )

    # Orientation and linking ------------------------------------------------------------
    lead: FloatProperty(
        name="Lead",
        description="Lead angle of the tool axis in the feed direction",
        default=0.0,
        subtype="ANGLE",
        unit="ROTATION",
    )
    tilt: FloatProperty(
        name="Tilt",
        description="Tilt (side) angle of the tool axis across the feed direction",
        default=0.0,
        subtype="ANGLE",
        unit="ROTATION",
    )
    link_mode: EnumProperty(
        name="Linking", description="Order of the passes", items=LINK_MODES, default="ONE_WAY"
    )

    # Display and statistics -------------------------------------------------------------
    pose_count: IntProperty(
        name="Poses Shown",
        description="Number of tool poses drawn along the paths (0: none)",
        default=500,
        min=0,
        soft_max=5000,
    )
    curve_bevel: FloatProperty(
        name="Curve Bevel",
        description="Bevel depth of the tool path curves in mm (0: lines only)",
        default=0.2,
        min=0.0,
        soft_max=5.0,
        precision=3,
    )
    color_mode: EnumProperty(
        name="Colour",
        description="Colouring of the tool path curves",
        items=COLOR_MODES,
        default="MORPH",
    )
    feed: FloatProperty(
        name="Feed",
        description="Feed rate in mm/min, for the machining time statistics",
        default=1000.0,
        min=1.0,
        soft_max=20000.0,
    )


CLASSES = [BliskCamSettings]


def register():
    bpy.types.Scene.blisk_cam = PointerProperty(type=BliskCamSettings)


def unregister():
    del bpy.types.Scene.blisk_cam
