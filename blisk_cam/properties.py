"""Scene settings of Blisk CAM (``bpy.types.Scene.blisk_cam``), saved in the .blend.

Lengths are millimetres and angles radians, as in ``core``; operators convert to plain core
dataclasses (cutter, tolerances) at the boundary, so nothing in ``core`` ever sees this group.
Only the blade and the axis are object references (pointer properties, never Python globals).

The ``stat_*`` and ``fit_*`` properties are written by the operators (statistics of the last
generated path and residuals of the last cone fit) so that they survive a save and reload;
the panels show them read-only.
"""


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

from .core.collision.options import CollisionOptions
from .core.display import MAX_POSE_EMPTIES
from .core.machine.description import known_presets
from .core.options import PATH_OPTION_GROUPS, fields
from .core.post.blocks import NcOptions
from .core.post.export import POSTS
from .core.process.cutting_data import MATERIALS
from .core.robot.description import known_robots
from .core.robot.programs import DIALECTS

#: option stages of the NC export and the collision check (declared in core)
NC_OPTION_GROUPS = (NcOptions,)
COLLISION_OPTION_GROUPS = (CollisionOptions,)


def poll_mesh(_self, obj):
    """Pointer poll: mesh objects only (UI filter; Python assignment is not checked)."""
    return obj.type == "MESH"


def poll_empty(_self, obj):
    """Pointer poll: empties only (UI filter; Python assignment is not checked)."""
    return obj.type == "EMPTY"


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


PREVIEW_ENGINES = (
    ("AUTO", "Auto", "Workbench when an OpenGL context is available, else Cycles on the CPU"),
    ("WORKBENCH", "Workbench", "Fast OpenGL preview (falls back to Cycles without OpenGL)"),
    ("EEVEE", "EEVEE", "EEVEE (falls back to Cycles without OpenGL)"),
    ("CYCLES", "Cycles", "Cycles on the CPU"),
)


def _update_display(self, context):
    """Re-style the existing output curves (bevel, colours) when a display option changes."""
    from .blender import path_objects as output

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

    # The core options (cutter, tolerances, tool axis, gouge fix, linking) are generated
    # from their one declaration in core.options: see option_properties() below.
    # Hand-made: the hub → tip variation behind its toggle, and the fixed point.
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
    axis_point: FloatVectorProperty(
        name="Axis Point",
        description="Modes Toward/Away from Point: the fixed point, world frame, mm",
        size=3,
        default=(0.0, 0.0, 0.0),
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
    stat_verdict: StringProperty(
        name="Verdict",
        description="PASS or FAIL of the measured figures against cusp + chord and chord "
        "(empty when not verified)",
        default="",
    )
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


def _tool_radius_get(self):
    return 0.5 * self.tool_diameter


def _tool_radius_set(self, value):
    self.tool_diameter = 2.0 * value


def option_property(name, spec, default):
    """The Blender property of one core option (:mod:`blisk_cam.core.options`): same label,
    help, default and bounds; angles in radians with subtype ANGLE (shown in degrees); an
    optional option (default None) stored as ``spec.none_as``; choices as an enum of
    ``Choice.blender_id`` (a bool with choices stays a checkbox)."""
    common = dict(name=spec.label, description=spec.help)
    if isinstance(default, bool):
        return BoolProperty(default=default, **common)
    if spec.choices is not None:
        items = [(c.blender_id, c.label, c.help) for c in spec.choices]
        return EnumProperty(items=items, default=spec.choice(default).blender_id, **common)
    value = spec.none_as if default is None else default
    if isinstance(value, int) and not isinstance(value, float) and spec.unit == "":
        kw = {k: v for k, v in (("min", spec.lo), ("max", spec.hi)) if v is not None}
        if default is None and "min" in kw and value < kw["min"]:
            kw["min"] = value  # "not set" (e.g. Blade Count 0) must stay reachable
        return IntProperty(default=value, **kw, **common)
    kw = {}
    if spec.lo is not None:  # an open bound: the smallest value the panel can show
        kw["min"] = spec.lo + (10.0 ** -spec.precision if spec.lo_open else 0.0)
    if spec.hi is not None:
        kw["max"] = spec.hi - (10.0 ** -spec.precision if spec.hi_open else 0.0)
    if spec.soft_max is not None:
        kw["soft_max"] = spec.soft_max
    if spec.unit == "deg":
        kw.update(subtype="ANGLE", unit="ROTATION")
    else:
        kw["precision"] = spec.precision
    if spec.size > 1:
        return FloatVectorProperty(size=spec.size, default=value, **kw, **common)
    return FloatProperty(default=float(value), **kw, **common)


def option_properties(stages) -> dict:
    """{property name: property} of every option of ``stages`` that Blender declares."""
    out = {}
    for stage in stages:
        for name, spec, default in fields(stage):
            if spec.blender:
                out[spec.prop_name(name)] = option_property(name, spec, default)
    return out


#: machine presets shipped in blisk_cam/machines, and a file of the user's
MACHINE_ITEMS = [(name, name, f"The shipped machine preset '{name}'")
                 for name in known_presets()] + [
    ("FILE", "TOML File", "A machine description file (see the README)")]
POST_ITEMS = [(name, name, f"NC program for {name}") for name in POSTS]
#: robot presets shipped in blisk_cam/robots, and a file of the user's; the robot languages
ROBOT_ITEMS = [(name, name, f"The shipped robot preset '{name}'") for name in known_robots()] + [
    ("FILE", "TOML File", "A robot description file (see the README)")]
ROBOT_POST_ITEMS = [(d, label, f"{label} robot program") for d, label in zip(
    DIALECTS, ("KUKA KRL", "ABB RAPID", "Comau PDL2", "Fanuc LS"), strict=True)]


BliskCamSettings.__annotations__.update(option_properties(PATH_OPTION_GROUPS))
BliskCamSettings.__annotations__.update(option_properties(NC_OPTION_GROUPS))
BliskCamSettings.__annotations__.update(option_properties(COLLISION_OPTION_GROUPS))
# the machine and the post of "Machine & NC" (their lists come from core: presets, posts)
BliskCamSettings.__annotations__.update(
    machine=EnumProperty(name="Machine", description="Machine preset, or a TOML file",
                         items=MACHINE_ITEMS, default=MACHINE_ITEMS[0][0]),
    machine_file=StringProperty(name="Machine File", subtype="FILE_PATH", default="",
                                description="Machine description (TOML) when Machine is "
                                "TOML File"),
    post=EnumProperty(name="Post", description="Controller dialect of the NC program",
                      items=POST_ITEMS, default=POST_ITEMS[0][0]),
    nc_path=StringProperty(name="NC File", subtype="FILE_PATH", default="//blade.nc",
                           description="NC program written by Export NC"),
    # the part origin of the set-up, instead of editing a copy of the preset (issue 28)
    use_part_origin=BoolProperty(
        name="Part Origin", default=False,
        description="Place the part (paths) origin here instead of the machine's [part] "
        "origin; TCP programs state it as the work offset to set"),
    part_origin=FloatVectorProperty(
        name="Part Origin", size=3, default=(0.0, 0.0, 0.0), precision=3,
        description="Where the part (paths) origin sits, mm in the machine description's "
        "frame with the rotaries at 0"),
    holder=StringProperty(
        name="Holder", default="",
        description="Tool body above the flute as 'z r z r ...' in mm (z along the tool axis "
        "from the tip, starting at the flute length; empty: the cutter's shank and holder)"),
    obstacles=PointerProperty(
        name="Obstacles", type=bpy.types.Collection,
        description="Extra obstacle meshes (hub, whole blisk, fixture) for the collision "
        "check"),
    # the per-blade run of a whole-blisk scan (issue 27)
    per_blade_scan=PointerProperty(
        name="Scan", type=bpy.types.Object, poll=poll_mesh,
        description="Whole-blisk scan mesh (hub and every blade; read, never modified); "
        "empty: the active object"),
    per_blade_folder=StringProperty(
        name="Results Folder", subtype="DIR_PATH", default="",
        description="Job folder of a per-blade batch run (blades.csv, blade_<k>.json) for "
        "Load Results"),
    export_anyway=BoolProperty(
        name="Export Anyway", default=False,
        description="Export NC even while poses are unresolved collisions (not recommended)"),
)
# the "Robot" panel: the polishing cell of issue 26 (core/robot), as `blisk_cam robot` takes it
BliskCamSettings.__annotations__.update(
    robot=EnumProperty(name="Robot", description="Robot preset, or a TOML file",
                       items=ROBOT_ITEMS,
                       default="kr120-r2700-angled" if "kr120-r2700-angled" in known_robots()
                       else ROBOT_ITEMS[0][0]),
    robot_file=StringProperty(name="Robot File", subtype="FILE_PATH", default="",
                              description="Robot description (TOML) when Robot is TOML File"),
    robot_post=EnumProperty(name="Language", description="Controller language of the program",
                            items=ROBOT_POST_ITEMS, default=ROBOT_POST_ITEMS[0][0]),
    robot_feed=FloatProperty(name="Feed", description="Polishing feed along the path, mm/min",
                             default=600.0, min=0.001, precision=1),
    robot_force=FloatProperty(name="Force", description="Contact force setpoint of the "
                              "force-controlled head, N (written in the header; 0: not stated)",
                              default=0.0, min=0.0, precision=1),
    robot_out=StringProperty(name="Output Folder", subtype="DIR_PATH", default="//robot",
                             description="Folder for the main program and its parts (created "
                             "if missing; only files Blisk CAM wrote are replaced)"),
    robot_samples=IntProperty(name="Free-Angle Samples", default=36, min=4, max=720,
                              description="Samples of the free angle about the tool axis per "
                              "turn (36: every 10°)"),
    robot_max_step=FloatProperty(name="Max Joint Step", default=0.17453292519943295,
                                 min=0.0001, max=3.14159, subtype="ANGLE", unit="ROTATION",
                                 description="Largest joint step between two poses"),
    robot_min_wrist=FloatProperty(name="Min Wrist Margin", default=0.08726646259971647,
                                  min=0.0001, max=1.5, subtype="ANGLE", unit="ROTATION",
                                  description="Closest approach to the wrist singularity "
                                  "(A5 = 0)"),
    robot_summary=StringProperty(name="Robot Result", default="",
                                 description="Figures of the last robot export or display"),
)
# the "Stock" panel: the material-removal simulation of issue 22 (core/stock), as
# `blisk_cam simulate` takes it; the blade count is the scene's one Blade Count
BliskCamSettings.__annotations__.update(
    stock_part_source=EnumProperty(
        name="Part", description="What the part is",
        items=[("BLADE_HUB", "Blade + Hub Profile", "The Setup panel's blade and a hub "
                "profile CSV ('r, z' per line, mm) revolved about the axis"),
               ("MESH", "Whole-Blisk Mesh", "A mesh of the whole blisk, split into hub and "
                "blades (the blade count checked against its symmetry)")],
        default="BLADE_HUB"),
    stock_part=PointerProperty(
        name="Blisk Mesh", type=bpy.types.Object, poll=poll_mesh,
        description="Whole-blisk mesh (read, never modified); empty: the active object"),
    stock_hub_profile=StringProperty(
        name="Hub Profile", subtype="FILE_PATH", default="",
        description="Hub generatrix CSV, 'r, z' per line in mm"),
    stock_blank=EnumProperty(
        name="Blank", description="The stock the program starts from",
        items=[("ALLOWANCE", "Part + Allowance", "The part plus a uniform allowance (check "
                "a finishing or semi-finishing program on its own)"),
               ("ENVELOPE", "Envelope + Margin", "The part's revolved envelope plus a margin"),
               ("PROFILE", "Profile CSV", "A closed (r, z) profile revolved about the axis"),
               ("MESH", "Blank Mesh", "A closed mesh object")],
        default="ALLOWANCE"),
    stock_allowance=FloatProperty(name="Allowance", default=0.1, min=0.0, soft_max=10.0,
                                  precision=3, description="Uniform allowance on the part, mm"),
    stock_margin=FloatProperty(name="Margin", default=2.0, min=0.0, soft_max=50.0, precision=2,
                               description="Margin around the part's envelope, mm"),
    stock_profile=StringProperty(name="Blank Profile", subtype="FILE_PATH", default="",
                                 description="Closed blank profile CSV, 'r, z' per line, mm"),
    stock_blank_object=PointerProperty(
        name="Blank Mesh", type=bpy.types.Object, poll=poll_mesh,
        description="Closed mesh of the blank (read, never modified)"),
    stock_resolution=FloatProperty(name="Resolution", default=0.05, min=0.005, max=10.0,
                                   precision=3, description="Stock resolution (dexel "
                                   "spacing), mm"),
    stock_gouge_tolerance=FloatProperty(
        name="Gouge Tolerance", default=0.0, min=0.0, soft_max=1.0, precision=3,
        description="Largest gouge that passes, mm (0: the paths' chord tolerance + the "
        "resolution)"),
)


# --- the "Operations" panel: the whole blisk as one job (issue 24, core/process/job) --------
def _kind_number(name: str) -> int:
    """A stable enum number for a kind's name (a kind registered later never shifts the
    kinds saved in a .blend)."""
    import zlib

    return zlib.crc32(name.encode()) & 0x3FFFFFFF


_KIND_ITEMS: list = []  # Blender needs the dynamic items' strings kept alive


def kind_items(_self, _context):
    """Every registered operation kind (``core.process.operation_kinds.OPERATION_KINDS``)."""
    from .core.process.operation_kinds import OPERATION_KINDS

    items = [(k.name, k.name, k.title, _kind_number(k.name)) for k in OPERATION_KINDS.values()]
    if items != _KIND_ITEMS:
        _KIND_ITEMS[:] = items
    return _KIND_ITEMS


def _kind_edited(self, _context):
    sync_operation_options(self)


def sync_operation_options(op) -> None:
    """One option row per key the operation's kind declares (values typed for keys the kind
    still has are kept; the others dropped)."""
    from .core.process.operation_kinds import OPERATION_KINDS

    kind = OPERATION_KINDS.get(op.kind)
    keys = list(kind.options) if kind is not None else []
    values = {o.key: o.value for o in op.options}
    op.options.clear()
    for key in keys:
        item = op.options.add()
        item.key, item.value = key, values.get(key, "")


def _operation_selected(self, context):
    from .blender.operation_objects import show_operation_stock

    show_operation_stock(context.scene)


class BliskCamOperationOption(PropertyGroup):
    """One option of an operation: its key and its value as written in a job file (a TOML
    value: ``0.3``, ``"radial"`` or a bare word, ``[170, -25, 185, 35]``); empty: the kind's
    default."""

    key: StringProperty(name="Key")
    value: StringProperty(name="Value", description="The option's value as in a job file "
                          "(number, word, or list [a, b, ...]); empty: the kind's default")


class BliskCamOperation(PropertyGroup):
    """One operation of the job: name, kind, tool number, enabled, its options."""

    name: StringProperty(name="Name", default="operation")
    kind: EnumProperty(name="Kind", items=kind_items, update=_kind_edited,
                       description="Operation kind (the job file's kind)")
    tool: IntProperty(name="Tool", default=1, min=0, description="T number of the tool table")
    enabled: BoolProperty(name="Enabled", default=True,
                          description="Run this operation in Generate All")
    uid: IntProperty(name="Id", default=0, description="Identity of the operation's results")
    options: bpy.props.CollectionProperty(type=BliskCamOperationOption)
    result: StringProperty(name="Result", default="",
                           description="The last Generate All's figures for this operation")


TOOL_TYPE_ITEMS = [("ball", "Ball", "Ball end mill"), ("bull", "Bull Nose",
                                                         "Torus end mill (corner radius)"),
                   ("flat", "Flat", "Flat end mill"), ("taper", "Taper", "Tapered ball")]


class BliskCamJobTool(PropertyGroup):
    """One tool of the job's tool table (the job file's [[tool]])."""

    number: IntProperty(name="T", default=1, min=0, description="Tool number")
    type: EnumProperty(name="Type", items=TOOL_TYPE_ITEMS, default="ball")
    diameter: FloatProperty(name="Diameter", default=12.0, min=0.001, precision=3,
                            description="Cutter diameter, mm")
    corner_radius: FloatProperty(name="Corner Radius", default=0.0, min=0.0, precision=3,
                                 description="Corner radius of a bull nose, mm")
    flutes: IntProperty(name="Flutes", default=2, min=1, max=32)
    flute_length: FloatProperty(name="Flute Length", default=0.0, min=0.0, precision=2,
                                description="Flute length, mm (0: from the stick-out or the "
                                "cutter's default)")
    stick_out: FloatProperty(name="Stick-Out", default=0.0, min=0.0, precision=2,
                             description="Length out of the holder, mm (0: not given)")
    holder: StringProperty(name="Holder", default="",
                           description="Tool body above the flute as 'z r z r ...' mm from "
                           "the tip (empty: a shank to the stick-out, or the cutter's own)")


MATERIAL_ITEMS = [("NONE", "Not Given", "Give vc and fz (or spindle and feed) per operation")]
MATERIAL_ITEMS += [(m, m, f"Cutting data for {m} (the table's sources: README)")
                   for m in MATERIALS]

BliskCamSettings.__annotations__.update(
    operations=bpy.props.CollectionProperty(type=BliskCamOperation),
    operation_index=IntProperty(name="Operation", default=0, min=0,
                                update=_operation_selected,
                                description="The selected operation (the stock shown is the "
                                "one after it)"),
    job_tools=bpy.props.CollectionProperty(type=BliskCamJobTool),
    job_tool_index=IntProperty(name="Tool", default=0, min=0),
    job_part_source=EnumProperty(
        name="Part", description="The job's part",
        items=[("DEMO", "Demo Blisk", "The built-in demo blisk"),
               ("FILE", "Mesh File", "A whole-blisk mesh file, or a blade mesh with a hub "
                "profile CSV")], default="DEMO"),
    job_part_file=StringProperty(name="Part File", subtype="FILE_PATH", default="",
                                 description="Whole-blisk (or blade) mesh file"),
    job_hub_profile=StringProperty(name="Hub Profile", subtype="FILE_PATH", default="",
                                   description="With a blade mesh: hub profile CSV ('r, z' "
                                   "per line, mm); empty: the file is the whole blisk"),
    job_demo_resolution=FloatProperty(name="Demo Resolution", default=0.3, min=0.05, max=5.0,
                                      precision=2, description="Demo blisk mesh resolution, mm"),
    job_material=EnumProperty(name="Material", items=MATERIAL_ITEMS, default="NONE",
                              description="The part's material (cutting data)"),
    job_next_uid=IntProperty(default=1),
)
# the radius, for scripts and old files' habits: half the diameter, not stored
BliskCamSettings.__annotations__["tool_radius"] = FloatProperty(
    name="Tool Radius", description="Cutter radius in mm (half the diameter)",
    get=_tool_radius_get, set=_tool_radius_set, min=0.0005, precision=3)

CLASSES = [BliskCamOperationOption, BliskCamOperation, BliskCamJobTool, BliskCamSettings]


def register():
    bpy.types.Scene.blisk_cam = PointerProperty(type=BliskCamSettings)


def unregister():
    del bpy.types.Scene.blisk_cam
