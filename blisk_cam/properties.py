"""Scene settings of Blisk CAM (``bpy.types.Scene.blisk_cam``), saved in the .blend.

Lengths are millimetres and angles radians, as in ``core``; operators convert to plain core
dataclasses (cutter, tolerances) at the boundary, so nothing in ``core`` ever sees this group.
Only the blade and the axis are object references (pointer properties, never Python globals).

The ``stat_*`` and ``fit_*`` properties are written by the operators (statistics of the last
generated path and residuals of the last cone fit) so that they survive a save and reload;
the panels show them read-only.
"""

import math

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
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

AXIS_MODES = (
    ("LOCAL", "Lead/Tilt", "Lead and tilt in the local frame (feed, normal, side) of each pose"),
    ("RADIAL", "Radial", "Lead in the feed direction, then lean away from (> 0) or toward (< 0) "
     "the blisk axis by the radial tilt"),
    ("TOWARD_AXIS", "Toward Axis", "Tool axis through the blisk axis (toward it, fixed line)"),
    ("FROM_AXIS", "Away from Axis", "Tool axis away from the blisk axis (fixed line)"),
    ("TOWARD_POINT", "Toward Point", "Tool axis toward the fixed point"),
    ("FROM_POINT", "Away from Point", "Tool axis away from the fixed point"),
)

FIT_GENERATRICES = (
    ("AUTO", "Auto", "Per end a straight cone, or a polyline profile when the cone misses the "
     "boundary loop by more than 0.1 mm and the profile fits better (curved hub, LMRS)"),
    ("CONE", "Cone", "Straight cones (the paper's linear morphing cones)"),
    ("PROFILE", "Profile", "Least-squares polyline profiles (linear morphing revolution surfaces)"),
)

COLOR_MODES = (
    ("SOLID", "Solid", "One colour for all tool path curves"),
    ("MORPH", "Morph Ratio", "Colour each curve by its morph ratio s (cone 1 → cone 2)"),
    ("CUSP", "Cusp Height", "Colour by the measured scallop height left between passes"),
)


#: hard cap on the pose empties (objects); every pose is in the point cloud anyway
MAX_POSE_EMPTIES = 10_000

PREVIEW_ENGINES = (
    ("AUTO", "Auto", "Workbench when an OpenGL context is available, else Cycles on the CPU"),
    ("WORKBENCH", "Workbench", "Fast OpenGL preview (falls back to Cycles without OpenGL)"),
    ("EEVEE", "EEVEE", "EEVEE (falls back to Cycles without OpenGL)"),
    ("CYCLES", "Cycles", "Cycles on the CPU"),
)


def _update_display(self, context):
    """Re-style the existing output curves (bevel, colours) when a display option changes."""
    from . import output

    scene = getattr(context, "scene", None)
    if scene is not None:
        output.restyle(scene)


def _cone1_edited(self, _context):
    """Editing cone 1's numbers (panel, gizmo, Python) replaces a fitted profile: the numbers
    are what the user now means, never silently ignored."""
    if self.profile1:
        self.profile1 = ""


def _cone2_edited(self, _context):
    if self.profile2:
        self.profile2 = ""


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
        update=_cone1_edited,
    )
    cone2: FloatVectorProperty(
        name="Cone 2",
        description="Last cone (tip side) as generatrix r1, z1, r2, z2 in mm",
        size=4,
        default=(0.0, 0.0, 0.0, 0.0),
        precision=4,
        update=_cone2_edited,
    )
    profile1: StringProperty(
        name="Profile 1",
        description="Hub generatrix as a polyline, JSON [[r, z], ...] in mm (empty: the straight "
        "cone 1). Set by Fit Cones or --cone1-profile; used instead of cone 1, whose numbers "
        "then hold its least-squares straight cone. Editing cone 1 clears it",
        default="",
    )
    profile2: StringProperty(
        name="Profile 2",
        description="Tip generatrix as a polyline, JSON [[r, z], ...] in mm (empty: the straight "
        "cone 2); see Profile 1",
        default="",
    )
    fit_generatrix: EnumProperty(
        name="Fit",
        description="What Fit Cones fits to the hub and tip boundary loops",
        items=FIT_GENERATRICES,
        default="AUTO",
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
    taper_angle: FloatProperty(
        name="Taper Angle",
        description="Side angle of a tapered ball-end mill (half the cone angle)",
        default=math.radians(3.0),
        min=math.radians(0.01),
        max=math.radians(59.0),
        subtype="ANGLE",
        unit="ROTATION",
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
    vary_lead_tilt: BoolProperty(
        name="Vary to Tip",
        description="Vary lead and tilt linearly from the hub values (cone 1) to the tip values "
        "(cone 2)",
        default=False,
    )
    lead_tip: FloatProperty(
        name="Lead at Tip",
        description="Lead angle at the tip (cone 2) when Vary to Tip is on",
        default=0.0,
        subtype="ANGLE",
        unit="ROTATION",
    )
    tilt_tip: FloatProperty(
        name="Tilt at Tip",
        description="Tilt angle at the tip (cone 2) when Vary to Tip is on",
        default=0.0,
        subtype="ANGLE",
        unit="ROTATION",
    )
    axis_mode: EnumProperty(
        name="Tool Axis", description="How the tool axis is chosen", items=AXIS_MODES,
        default="LOCAL",
    )
    radial_tilt: FloatProperty(
        name="Radial Tilt",
        description="Mode Radial: lean of the tool axis away from (> 0) or toward (< 0) the "
        "blisk axis",
        default=0.0,
        subtype="ANGLE",
        unit="ROTATION",
    )
    axis_point: FloatVectorProperty(
        name="Axis Point",
        description="Modes Toward/Away from Point: the fixed point, world frame, mm",
        size=3,
        default=(0.0, 0.0, 0.0),
        precision=3,
    )
    max_axis_turn: FloatProperty(
        name="Max Axis Turn",
        description="Smooth the tool axes so that consecutive poses turn by at most this angle "
        "(0: no smoothing)",
        default=0.0,
        min=0.0,
        max=math.radians(89.0),
        subtype="ANGLE",
        unit="ROTATION",
    )
    fix_local_gouge: BoolProperty(
        name="Fix Local Gouges",
        description="Raise lead/tilt (up to 30°/20°) where the cutter would gouge the surface "
        "next to the contact point (off: only flag those poses)",
        default=True,
    )
    link_mode: EnumProperty(
        name="Linking", description="Order of the passes", items=LINK_MODES, default="ONE_WAY"
    )
    climb: BoolProperty(
        name="Climb Milling",
        description="Climb milling for a clockwise (M03) spindle (off: conventional milling)",
        default=True,
    )
    approach: FloatProperty(
        name="Approach",
        description="Approach and retract distance along the tool axis, mm",
        default=2.0,
        min=0.0,
        soft_max=50.0,
        precision=3,
    )
    clearance_radius: FloatProperty(
        name="Clearance Radius",
        description="Radius of the clearance cylinder for rapid moves, mm (0: the passes' "
        "largest radius plus the clearance margin)",
        default=0.0,
        min=0.0,
        soft_max=2000.0,
        precision=3,
    )
    clearance_margin: FloatProperty(
        name="Clearance Margin",
        description="Margin of the automatic clearance radius above the passes, mm",
        default=5.0,
        min=0.0,
        soft_max=100.0,
        precision=3,
    )

    # Display and statistics -------------------------------------------------------------
    show_gizmos: BoolProperty(
        name="Show Cone Gizmos",
        description="Show and edit the two cones in the 3D viewport",
        default=True,
    )
    live_preview: BoolProperty(
        name="Live Preview",
        description="Slice a few LMC curves while dragging a cone handle",
        default=False,
    )
    pose_count: IntProperty(
        name="Poses Shown",
        description="Number of tool-pose arrows (empties) spread evenly along the paths when "
        "they are generated (0: none); the pose point cloud always holds every pose",
        default=500,
        min=0,
        max=MAX_POSE_EMPTIES,
        soft_max=2000,
    )
    curve_bevel: FloatProperty(
        name="Curve Bevel",
        description="Bevel depth of the tool path curves in mm (0: lines only)",
        default=0.2,
        min=0.0,
        soft_max=5.0,
        precision=3,
        update=_update_display,
    )
    color_mode: EnumProperty(
        name="Colour",
        description="Colouring of the tool path curves",
        items=COLOR_MODES,
        default="MORPH",
        update=_update_display,
    )
    feed: FloatProperty(
        name="Feed",
        description="Feed rate in mm/min, for the machining time statistics",
        default=1000.0,
        min=1.0,
        soft_max=20000.0,
    )


    # Verification -----------------------------------------------------------------------
    verify: BoolProperty(
        name="Verify",
        description="After generating, measure the material left and the gouges of the path "
        "on the mesh (independent check; takes about as long as the generation)",
        default=True,
    )
    verify_map: BoolProperty(
        name="Verify Colour Map",
        description="After verifying, add a copy of the blade coloured by the material left "
        "(green→blue) and gouges (red); grey outside the machined region",
        default=False,
    )

    # Preview ----------------------------------------------------------------------------
    preview_path: StringProperty(
        name="Preview File",
        description="PNG written by Render Preview",
        default="//blisk_cam_preview.png",
        subtype="FILE_PATH",
    )
    preview_engine: EnumProperty(
        name="Engine",
        description="Render engine of the preview",
        items=PREVIEW_ENGINES,
        default="AUTO",
    )

    # Results of the last run (written by the operators, shown read-only) ----------------
    fit_residual1: FloatProperty(
        name="Cone 1 Residual",
        description="Largest distance of a hub boundary vertex from the fitted cone 1, mm "
        "(-1: cones not fitted)",
        default=-1.0,
    )
    fit_residual2: FloatProperty(
        name="Cone 2 Residual",
        description="Largest distance of a tip boundary vertex from the fitted cone 2, mm "
        "(-1: cones not fitted)",
        default=-1.0,
    )
    has_result: BoolProperty(name="Has Paths", default=False)
    stat_blade: StringProperty(name="Blade of the Paths", default="")
    stat_curves: IntProperty(name="Curves", default=0)
    stat_passes: IntProperty(name="Passes", default=0)
    stat_poses: IntProperty(name="Poses", default=0)
    stat_length: FloatProperty(name="Path Length", description="Tool tip path length, mm",
                               default=0.0)
    stat_link_length: FloatProperty(
        name="Link Length",
        description="Length of the linking moves at feed (approach, retract, links), mm",
        default=0.0,
    )
    stat_rapid_length: FloatProperty(name="Rapid Length",
                                     description="Length of the rapid moves, mm", default=0.0)
    stat_warnings: IntProperty(name="Warnings", default=0)
    stat_seconds: FloatProperty(name="Generation Time", default=0.0)
    stat_cusp: FloatProperty(
        name="Cusp (generator)",
        description="Largest scallop between passes measured by the generator, mm",
        default=0.0,
    )
    stat_verified: BoolProperty(name="Verified", default=False)
    stat_material_left: FloatProperty(
        name="Max Material Left",
        description="Largest material left measured by the independent check, mm",
        default=0.0,
    )
    stat_gouge: FloatProperty(
        name="Max Gouge",
        description="Deepest gouge measured by the independent check, mm",
        default=0.0,
    )


CLASSES = [BliskCamSettings]


def register():
    bpy.types.Scene.blisk_cam = PointerProperty(type=BliskCamSettings)


def unregister():
    del bpy.types.Scene.blisk_cam
