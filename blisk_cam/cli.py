"""The batch command line: ``python -m blisk_cam ...`` (bpy wheel) or
``blender -b --python scripts/blisk_batch.py -- ...`` (a Blender binary).

::

    python -m blisk_cam demo --out DIR [--mesh-resolution R] [--no-paths] [--no-preview]
    python -m blisk_cam paths --mesh FILE(.stl|.obj|.ply) \\
        --cone1 R1 Z1 R2 Z2 --cone2 R1 Z1 R2 Z2 [--axis OX OY OZ DX DY DZ] \\
        --tool ball|bull|flat|taper --tool-radius 6 [--corner-radius 2] \\
        --cusp 0.05 --chord 0.05 [--lead DEG --tilt DEG] [--link oneway|zigzag|spiral] \\
        --out paths.json [--blend out.blend] [--preview out.png] [--verify]
        [--fit auto|cone|profile] [--cone1-profile FILE.csv] [--cone2-profile FILE.csv]
        [--taper-angle DEG] [--lead-tip DEG] [--tilt-tip DEG] [--axis-mode MODE]
        [--radial-tilt DEG] [--axis-point X Y Z] [--max-axis-turn DEG]
        [--milling climb|conventional] [--approach MM] [--clearance-radius MM]
        [--clearance-margin MM] [--no-fix-gouge]

Angles are degrees on the command line (radians in the scene settings and the core).

Both commands run the add-on's operators (``blisk_cam.fit_cones``, ``generate_paths``,
``export_paths``, ``render_preview``) on a scene whose ``scene.blisk_cam`` settings are filled
from the arguments: the batch and the user interface share one code path.

Exit status 0 on success. On bad input: a non-zero status (2 for a usage error, 1 for input
the core or Blender rejects, 3 for an internal error) and exactly one line on stderr,
``blisk_cam: error: <what is wrong>``. ``bpy`` is imported only inside the commands, so this
module imports without Blender. Whatever the commands registered is unregistered before
:func:`main` returns (bpy 4.5 hangs at exit while add-on classes are registered).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import re
import sys
import time
from pathlib import Path

from .cli_options import UsageError, add_option_flags, finite, option_args
from .core.avoidance import CollisionOptions
from .core.errors import BliskCamError
from .core.options import PATH_STAGES, CutterOptions
from .core.revolution import angular_span
from .nc_cli import add_nc_arguments

__all__ = ["main", "build_parser", "UsageError", "run_operator", "build_demo_scene"]

PROG = "blisk_cam"


class CliInternalError(Exception):
    """An operator failed on something that is not bad input (exit status 3)."""


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser that raises instead of printing usage and exiting: the CLI prints one
    line itself."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


# --- argument types ----------------------------------------------------------------------
_finite = finite


def _positive(text):
    value = _finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got '{text}'")
    return value


def _non_negative(text):
    value = _finite(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"expected a number ≥ 0, got '{text}'")
    return value


def _pixels(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number of pixels, got '{text}'"
        ) from None
    if not 16 <= value <= 8192:
        raise argparse.ArgumentTypeError(f"expected 16..8192 pixels, got {value}")
    return value


def _blade_count(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected at least 1 blade, got {value}")
    return value


ENGINES = ("AUTO", "WORKBENCH", "EEVEE", "CYCLES")
FITS = ("auto", "cone", "profile")


def read_profile_csv(path):
    """A hub or tip generatrix polyline from a text file: one point ``r, z`` (mm) per line,
    separated by a comma, semicolon or white space; ``#`` starts a comment; blank lines are
    skipped. Returns a ``core.lmrs.Profile``; BliskCamError naming the file (and line) when
    it is missing or not such a list."""
    from .core.lmrs import Profile

    path = Path(path).expanduser()
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise BliskCamError(f"profile file {path} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise BliskCamError(f"cannot read profile file {path}: {exc}") from None
    points = []
    for number, line in enumerate(text.splitlines(), 1):
        fields = re.split(r"[,;\s]+", line.split("#", 1)[0].strip())
        fields = [f for f in fields if f]
        if not fields:
            continue
        try:
            values = [float(f) for f in fields]
        except ValueError:
            values = []
        if len(values) != 2 or not all(math.isfinite(v) for v in values):
            raise BliskCamError(
                f"profile file {path}, line {number}: expected two numbers 'r, z' in mm, "
                f"got '{line.strip()}'"
            )
        points.append(values)
    try:
        return Profile(points)
    except BliskCamError as exc:
        raise BliskCamError(f"profile file {path}: {exc}") from None


# long on purpose: declarative: the argument list of every command
def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the CLI (subcommands ``demo`` and ``paths``)."""
    parser = _Parser(
        prog=PROG,
        description="Blisk CAM: 5-axis finishing tool paths for blisk blades (batch mode).",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="{demo,paths,nc}")
    sub.required = True

    demo = sub.add_parser(
        "demo",
        help="build the demo blisk; write DIR/demo.blend and DIR/preview.png",
        description="Build the parametric demo blisk (a few blades, a hub sector, the hub and "
        "tip cones and the axis), save DIR/demo.blend and render DIR/preview.png.",
    )
    demo.add_argument("--out", required=True, metavar="DIR", help="output directory")
    demo.add_argument(
        "--blades",
        type=_blade_count,
        default=3,
        metavar="N",
        help="blades shown around the machined one, which is included (default 3)",
    )
    demo.add_argument(
        "--resolution", type=_pixels, nargs=2, default=(1280, 720), metavar=("W", "H")
    )
    demo.add_argument("--engine", type=str.upper, choices=ENGINES, default="AUTO")
    demo.add_argument("--no-preview", action="store_true", help="do not render preview.png")
    demo.add_argument(
        "--no-paths", action="store_true", help="do not generate the paths (nor paths.json)"
    )
    demo.add_argument(
        "--mesh-resolution", type=_positive, default=1.0, metavar="R",
        help="demo mesh resolution (1: about 100k blade triangles; 0.3 for a quick look)",
    )
    demo.add_argument("--cusp", type=_positive, default=0.05, metavar="MM",
                      help="scallop height of the demo paths (default 0.05)")
    demo.add_argument("--chord", type=_positive, default=0.05, metavar="MM",
                      help="chord error of the demo paths (default 0.05)")
    demo.set_defaults(func=_cmd_demo)

    paths = sub.add_parser(
        "paths",
        help="tool paths for a blade mesh → paths JSON",
        description="Finishing tool paths between two cones on a blade mesh (mm). Without "
        "--cone1/--cone2 the cones are fitted to the blade's boundary loops. Lengths in mm, "
        "angles in degrees. Needs only numpy and scipy; --blend and --preview need Blender's "
        "Python module (bpy).",
    )
    paths.add_argument(
        "--mesh", required=True, metavar="FILE", help="blade mesh .stl .obj .ply (mm)"
    )
    paths.add_argument(
        "--cone1", type=_finite, nargs=4, metavar=("R1", "Z1", "R2", "Z2"),
        help="first (hub) cone generatrix, mm",
    )
    paths.add_argument(
        "--cone2", type=_finite, nargs=4, metavar=("R1", "Z1", "R2", "Z2"),
        help="last (tip) cone generatrix, mm",
    )
    paths.add_argument(
        "--axis", type=_finite, nargs=6, metavar=("OX", "OY", "OZ", "DX", "DY", "DZ"),
        default=None, help="blisk axis: origin (mm) and direction (default 0 0 0 0 0 1)",
    )
    paths.add_argument(
        "--fit", type=str.lower, choices=FITS, default="auto",
        help="what is fitted for a cone not given: per end a straight cone, or a polyline "
        "profile when the cone misses the boundary loop by > 0.1 mm and the profile fits "
        "better (auto, default); cones only (cone); profiles only (profile)",
    )
    paths.add_argument("--cone1-profile", metavar="FILE", default=None,
                       help="hub generatrix as a polyline: 'r, z' per line in mm, # comments")
    paths.add_argument("--cone2-profile", metavar="FILE", default=None,
                       help="tip generatrix as a polyline (as --cone1-profile)")
    add_option_flags(paths, PATH_STAGES)
    paths.add_argument("--tool-radius", type=_positive, default=None, metavar="MM",
                       help="the cutter radius instead of --tool-diameter (half of it)")
    paths.add_argument("--out", required=True, metavar="FILE", help="paths JSON to write")
    paths.add_argument("--blend", metavar="FILE", default=None, help="also save a .blend")
    paths.add_argument("--preview", metavar="FILE", default=None, help="also render a PNG")
    paths.add_argument("--engine", type=str.upper, choices=ENGINES, default="AUTO",
                       help="render engine of --preview")
    paths.add_argument("--verify", action="store_true",
                       help="also measure the material left and gouges (printed and stored "
                       "in the JSON's stats)")
    add_option_flags(paths, (CollisionOptions,))
    paths.add_argument("--holder", metavar='"Z R Z R ..."', default=None,
                       help="tool body above the flute as a revolved profile: z (along the axis "
                       "from the tip) and radius pairs, mm, z non-decreasing, starting at the "
                       "flute length (default: the cutter's shank and holder)")
    paths.add_argument("--obstacle", metavar="FILE", action="append", default=[],
                       help="an extra obstacle mesh (hub, whole blisk, fixture; .stl .obj "
                       ".ply, mm, the blade's frame); repeatable")
    paths.add_argument("--nc", metavar="FILE", default=None,
                       help="also post the path as an NC program (needs --machine, --post)")
    add_nc_arguments(paths, with_paths=False)
    paths.set_defaults(func=_cmd_paths)

    nc = sub.add_parser(
        "nc",
        help="paths JSON → NC program for a 5-axis machine",
        description="Post a paths JSON for a machine (preset or TOML) and a controller: "
        "inverse kinematics within the limits, rotary linearization, every blade. Lengths mm, "
        "angles degrees. Needs only numpy and scipy.",
    )
    add_nc_arguments(nc)
    nc.set_defaults(func=_cmd_nc)
    return parser


def _check_paths_args(args):
    """Checks that need more than one argument; raises UsageError (BliskCamError for an
    unreadable profile file). Fills args.axis_obj, args.cone1_obj, args.cone2_obj (core
    ``Cone`` or ``Profile`` given on the command line, or None) and args.stages (the option
    stages of the request, float64, core units)."""
    from .core.cones import Axis, Cone

    try:
        args.axis_obj = Axis(tuple(args.axis[:3]), tuple(args.axis[3:])) if args.axis else Axis()
    except BliskCamError as exc:
        raise UsageError(f"argument --axis: {exc}") from None
    for name in ("cone1", "cone2"):
        values = getattr(args, name)
        profile = getattr(args, f"{name}_profile")
        if values is not None and profile is not None:
            raise UsageError(f"--{name} and --{name}-profile both give cone {name[-1]}; use one")
        try:
            setattr(args, f"{name}_obj", Cone.from_list(values) if values is not None else None)
        except BliskCamError as exc:
            raise UsageError(f"argument --{name}: {exc}") from None
    if args.tool_radius is not None:
        if args.tool_diameter is not None:
            raise UsageError("--tool-diameter and --tool-radius both give the tool size; use one")
        args.tool_diameter = 2.0 * args.tool_radius
    given = option_args(args, PATH_STAGES)
    _check_orientation_args(args, given)
    tool = given.get("tool_type", "ball")
    diameter = given.get("tool_diameter", CutterOptions().tool_diameter)
    corner = given.get("corner_radius")
    if tool == "bull":
        if corner is None:
            raise UsageError("--tool bull needs --corner-radius")
        if not 0.0 < corner < diameter / 2:
            raise UsageError(
                f"--corner-radius {corner:g} must be > 0 and < half the --tool-diameter "
                f"({diameter:g}) for a bull-nose cutter"
            )
    elif corner is not None and corner > diameter / 2:
        raise UsageError(
            f"--corner-radius {corner:g} is larger than the tool radius {diameter / 2:g}"
        )
    if "taper_angle" in given and tool != "taper":
        raise UsageError(f"--taper-angle needs --tool taper (got --tool {tool})")
    if args.nc and not (args.machine and args.post):
        raise UsageError("--nc needs --machine (preset or TOML) and --post (controller)")
    if (args.machine or args.post) and not args.nc:
        raise UsageError("--machine/--post post the path with --nc FILE; give --nc")
    for opt in ("out", "blend", "preview", "nc"):
        value = getattr(args, opt)
        if value is not None and not Path(value).expanduser().resolve().parent.is_dir():
            raise UsageError(f"--{opt} {value}: the directory does not exist")
    args.stages = given
    args.collision = _collision_options(args)
    for name in ("cone1", "cone2"):  # read last: a bad file is bad input (status 1)
        profile = getattr(args, f"{name}_profile")
        if profile is not None:
            setattr(args, f"{name}_obj", read_profile_csv(profile))


def parse_holder(text):
    """'z r z r ...' (mm) → ((z, r), ...); UsageError naming what is wrong."""
    try:
        values = [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise UsageError(f"--holder '{text}': expected numbers 'z r z r ...' in mm") from None
    if len(values) < 2 or len(values) % 2:
        raise UsageError(f"--holder '{text}': expected pairs 'z r', got {len(values)} "
                         "number(s)")
    return tuple(zip(values[::2], values[1::2], strict=True))


def _collision_options(args):
    """The CollisionOptions of the flags: the mode defaults to avoid when a blade count or an
    obstacle is given (else off)."""
    from .core.cones import Axis
    from .core.pipeline import PathRequest, make_cutter

    given = option_args(args, (CollisionOptions,))
    if args.holder is not None:
        given["holder"] = parse_holder(args.holder)
    if "mode" not in given:
        given["mode"] = "avoid" if ("blade_count" in given or args.obstacle) else "off"
    if given["mode"] != "off" and "blade_count" not in given:
        raise UsageError(f"--collisions {given['mode']} needs --blade-count N (the neighbours "
                         "are the blade turned by k·360°/N)")
    try:
        options = CollisionOptions(**given)
        if options.mode != "off":
            options.assembly(make_cutter(PathRequest(Axis(), **args.stages)))
    except BliskCamError as exc:
        raise UsageError(str(exc)) from None
    return options


def _check_orientation_args(args, given):
    """Options that only make sense together (UsageError naming them)."""
    mode = given.get("axis_mode", "local")
    word = mode.replace("_line", "_axis").replace("_", "-")
    fixed = mode.endswith(("_line", "_point"))
    if "radial_tilt" in given and mode != "radial":
        raise UsageError("--radial-tilt needs --axis-mode radial")
    if mode == "radial" and (given.get("tilt") or given.get("tilt_tip")):
        raise UsageError("--axis-mode radial replaces --tilt/--tilt-tip by --radial-tilt")
    if fixed and (given.get("lead") or given.get("tilt") or "lead_tip" in given
                  or "tilt_tip" in given):
        raise UsageError(f"--axis-mode {word} fixes the tool axis; drop --lead/--tilt "
                         "(and --lead-tip/--tilt-tip)")
    if mode.endswith("_point") and "axis_point" not in given:
        raise UsageError(f"--axis-mode {word} needs --axis-point X Y Z")
    if "axis_point" in given and not mode.endswith("_point"):
        raise UsageError("--axis-point needs --axis-mode toward-point or from-point")
    if mode.endswith("_line"):
        given.update(axis_point=tuple(map(float, args.axis_obj.o)),
                     axis_direction=tuple(map(float, args.axis_obj.d)))


# --- Blender session ---------------------------------------------------------------------
def _import_bpy():
    try:
        import bpy
    except ImportError:
        raise BliskCamError(
            "this command needs Blender's Python module: pip install bpy (matching your "
            "Python), or run it in Blender: blender -b --python scripts/blisk_batch.py -- ..."
        ) from None
    return bpy


@contextlib.contextmanager
def _blender_session(register_addon=True, *, required=False):
    """An empty factory scene; the add-on registered for the duration if it was not already
    (so that ``scene.blisk_cam`` and the operators exist and settings are saved in .blend
    files), and unregistered after. With ``required`` a failed registration is an error;
    otherwise the command goes on without the add-on. Yields the scene."""
    bpy = _import_bpy()
    from .blender_io import quiet_output

    with quiet_output():
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    registered_here = False
    if register_addon:
        from . import is_registered, register

        if not is_registered():
            try:
                register()
                registered_here = True
            except Exception as exc:
                if required:
                    raise CliInternalError(
                        f"cannot register the Blisk CAM add-on: {type(exc).__name__}: {exc}"
                    ) from None
                print(f"note: add-on not registered ({type(exc).__name__}: {exc}); "
                      "settings are not stored in the .blend")
    if required and not hasattr(bpy.types.Scene, "blisk_cam"):
        raise CliInternalError("the Blisk CAM add-on is not registered in this Blender")
    try:
        yield bpy.context.scene
    finally:
        if registered_here:
            from . import unregister

            unregister()


def _save_blend(bpy, path):
    from .blender_io import quiet_output

    path = Path(path).expanduser().resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    with quiet_output():
        try:
            bpy.ops.wm.save_as_mainfile(filepath=str(path), check_existing=False)
        except RuntimeError as exc:
            raise BliskCamError(f"cannot save {path}: {str(exc).strip()}") from None
    return path


# --- demo --------------------------------------------------------------------------------
def _rotate_about_axis(V, axis, angle):
    """Rotate (n, 3) points about the axis line by ``angle`` radians (right hand about d)."""
    import numpy as np

    d = axis.d
    c, s = math.cos(angle), math.sin(angle)
    K = np.array([[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]])
    R = c * np.eye(3) + s * K + (1.0 - c) * np.outer(d, d)
    return (V - axis.o) @ R.T + axis.o


def build_demo_scene(scene=None, *, blades=3, demo=None):
    """Build the demo blisk in the current scene; returns a dict of the objects created.

    Objects (collection "Blisk CAM Demo"): "Blade" (the one to machine), "Blade ±k"
    (neighbours), "Hub", "Cone 1 (hub)", "Cone 2 (tip)" and "Blisk Axis" (an Empty, local
    Z = axis). Sets ``scene.blisk_cam`` when the add-on is registered. The scene's length
    unit becomes millimetres (scale 0.001: one Blender unit stays one mm).
    """
    import bpy
    import numpy as np

    from .blender_io import (
        arrays_to_object,
        axis_to_object,
        cone_to_object,
        ensure_collection,
    )
    from .core.cones import meridional

    if demo is None:
        from .core.demo import make_demo_blisk

        demo = make_demo_blisk()
    scene = scene or bpy.context.scene
    units = scene.unit_settings
    units.system = "METRIC"
    units.scale_length = 0.001  # Blender's millimetre preset: 1 BU shown as 1 mm
    units.length_unit = "MILLIMETERS"
    axis = demo.axis
    coll = ensure_collection("Blisk CAM Demo", scene.collection)
    Vb = np.asarray(demo.blade_vertices, dtype=np.float64)
    Fb = np.asarray(demo.blade_faces, dtype=np.int64)
    pitch = 2.0 * math.pi / max(int(demo.blade_count), 1)

    objs = {}
    objs["blade"] = arrays_to_object(
        "Blade", Vb, Fb, coll, color=(0.85, 0.62, 0.30, 1.0), smooth=False
    )
    # neighbours alternate +1, -1, +2, ... so that the machined blade stays in the middle
    offsets = []
    for k in range(1, blades):
        offsets.append((k + 1) // 2 if k % 2 else -(k // 2))
    for k in offsets:
        if hasattr(demo, "blade"):  # core.demo: blade i = blade 0 turned by i pitches
            Vk, Fk = demo.blade(k)
        else:
            Vk, Fk = _rotate_about_axis(Vb, axis, k * pitch), Fb
        objs[f"blade{k:+d}"] = arrays_to_object(
            f"Blade {k:+d}", Vk, Fk, coll, color=(0.62, 0.64, 0.68, 1.0)
        )
    Vh = np.asarray(demo.hub_vertices, dtype=np.float64)
    Fh = np.asarray(demo.hub_faces, dtype=np.int64)
    if len(Fh):
        objs["hub"] = arrays_to_object("Hub", Vh, Fh, coll, color=(0.42, 0.44, 0.48, 1.0))

    # cones over the angular range of the blades shown, a little wider
    mean, half = angular_span(Vb, axis)
    lo = min(offsets, default=0) * pitch + mean - half - 0.35 * pitch
    hi = max(offsets, default=0) * pitch + mean + half + 0.35 * pitch
    r, _ = meridional(Vb, axis)
    extent = float(r.max() - r.min()) if len(r) else 10.0
    # Cone 1 coincides with the hub surface: show it as a wire grid (a fill would z-fight);
    # cone 2 as a see-through surface with its grid.
    for key, name, cone, color, fill in (
        ("cone1", "Cone 1 (hub)", demo.hub_cone, (0.1, 0.45, 1.0, 0.3), False),
        ("cone2", "Cone 2 (tip)", demo.tip_cone, (1.0, 0.4, 0.1, 0.3), True),
    ):
        length = math.hypot(cone.r2 - cone.r1, cone.z2 - cone.z1)
        objs[key] = cone_to_object(
            name, cone, axis, coll, theta=(lo, hi), segments=48, rows=6,
            extend=0.1 * max(length, 0.1 * extent), color=color,
            wire=0.006 * extent, fill=fill,
        )
    z = (Vb - axis.o) @ axis.d
    z_range = (float(z.min()) - 0.3 * extent, float(z.max()) + 0.3 * extent)
    # the axis as an Empty (local Z = axis; what the "Axis" setting takes). It lies far inside
    # the hub, outside the sector view, so no rendering rod (axis_to_object kind="ROD").
    objs["axis"] = axis_to_object("Blisk Axis", axis, coll, kind="EMPTY", z_range=z_range)

    settings = getattr(scene, "blisk_cam", None)
    if settings is not None:
        with contextlib.suppress(AttributeError, TypeError, ValueError):
            settings.blade = objs["blade"]
            settings.axis_object = objs["axis"]
            settings.cone1 = demo.hub_cone.as_list()
            settings.cone2 = demo.tip_cone.as_list()
    return objs


def demo_view_direction(demo, *, turn=0.35, elevation=0.9):
    """A 3/4 view of the demo blade: from outside the blisk, ``turn`` radians around the axis
    from the blade's mean angle and ``elevation`` radians up toward the axis direction."""
    import numpy as np

    e1, e2, d = demo.axis.angular_frame()
    mean, _ = angular_span(np.asarray(demo.blade_vertices, dtype=np.float64), demo.axis)
    a = mean + turn
    radial = math.cos(a) * e1 + math.sin(a) * e2
    return tuple(math.cos(elevation) * radial + math.sin(elevation) * d)


def _cmd_demo(args):
    t0 = time.perf_counter()
    out = Path(args.out).expanduser().resolve()
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {args.out}: exists and is not a directory")
    bpy = _import_bpy()
    from .core.demo import make_demo_blisk

    demo = make_demo_blisk(resolution=args.mesh_resolution)
    out.mkdir(parents=True, exist_ok=True)
    with _blender_session(required=True) as scene:
        from . import render

        objs = build_demo_scene(scene, blades=args.blades, demo=demo)
        settings = scene.blisk_cam
        settings.cusp, settings.chord = args.cusp, args.chord
        settings.verify = False
        if not args.no_paths:
            _paths_by_operators(bpy, scene, out / "paths.json")
            for key in ("cone1", "cone2"):  # the output collection shows the cones now: once
                bpy.data.objects.remove(objs.pop(key), do_unlink=True)
        # frame the sector; the axis (far inside the hub) is shown only where it falls in view
        shown = [o for k, o in objs.items() if k != "axis"]
        view = demo_view_direction(demo)
        scene.camera = render.frame_camera(
            scene, shown, view=view, resolution=tuple(args.resolution)
        )
        render.match_viewports_to_camera(scene.camera, objs["blade"])
        blend = _save_blend(bpy, out / "demo.blend")
        print(f"demo blend: {blend}")
        if not args.no_preview:
            _render_by_operator(
                bpy, out / "preview.png", args.engine, args.resolution,
                frame="SCENE", view=view, keep_camera=True,
            )
    print(f"done in {time.perf_counter() - t0:.1f} s")
    return 0


def _engine_label(engine):
    return {"BLENDER_WORKBENCH": "Workbench", "CYCLES": "Cycles CPU"}.get(engine, engine)


# --- paths -------------------------------------------------------------------------------
def run_operator(bpy, name, **kwargs):
    """Run ``bpy.ops.blisk_cam.<name>`` (EXEC, no file browser) with Blender's report output
    captured. An ERROR report becomes a :class:`BliskCamError` carrying the message (a
    :class:`CliInternalError` when the operator reported an internal error); returns the
    operator's result set."""
    from .blender_io import quiet_output
    from .operators.common import INTERNAL_ERROR

    op = getattr(bpy.ops.blisk_cam, name)
    with quiet_output():
        try:
            return op("EXEC_DEFAULT", **kwargs)
        except RuntimeError as exc:
            message = str(exc).strip()
            error = message
        except TypeError as exc:  # a bad keyword: a bug in the caller
            raise CliInternalError(f"{name}: {exc}") from None
    message = error.removeprefix("Error:").strip()
    # a failed poll: "Operator bpy.ops.blisk_cam.<name>.poll() <poll message>"
    message = re.sub(r"^Operator bpy\.ops\.[\w.]+\.poll\(\)\s*(failed,)?\s*", "", message)
    if message.startswith(INTERNAL_ERROR):
        raise CliInternalError(message)
    raise BliskCamError(message or f"blisk_cam.{name} cannot run in this scene")


def _paths_by_operators(bpy, scene, out, *, fit=False, keep=(None, None)):
    """fit_cones (when ``fit``; a generatrix given in ``keep`` — core ``Cone`` or
    ``Profile`` — is put back afterwards) → generate_paths → export_paths, all by the
    operators; prints the fit and the summary. Returns the JSON's path."""
    from .operators.common import set_generatrix
    from .operators.generate_paths import summary

    s = scene.blisk_cam
    if fit:
        run_operator(bpy, "fit_cones")
        for k, given in ((1, keep[0]), (2, keep[1])):
            if given is not None:
                set_generatrix(s, k, given)

        def shown(k):
            text = getattr(s, f"profile{k}")
            if text:
                import json

                return f"profile of {len(json.loads(text))} points"
            return str([round(x, 4) for x in getattr(s, f"cone{k}")])

        print(
            f"fitted cones: cone1 {shown(1)} (residual {s.fit_residual1:.4f} mm), "
            f"cone2 {shown(2)} (residual {s.fit_residual2:.4f} mm)"
        )
    run_operator(bpy, "generate_paths")
    out = Path(out).expanduser().resolve()
    run_operator(bpy, "export_paths", filepath=str(out))
    print(f"wrote {out}: {summary(s)}")
    if s.stat_warnings:
        import json

        with open(out, encoding="utf-8") as fh:
            d = json.load(fh)
        for w in (d.get("stats", {}).get("warnings", []) or []) + d.get("warnings", []):
            print(f"warning: {w}")
    return out


def _render_by_operator(bpy, filepath, engine, resolution, **kwargs):
    """``blisk_cam.render_preview`` to ``filepath``; prints what it wrote."""
    from .render import resolve_engine

    path = Path(filepath).expanduser().resolve()
    t0 = time.perf_counter()
    run_operator(
        bpy, "render_preview", filepath=str(path), engine=engine,
        resolution=tuple(resolution), **kwargs,
    )
    label = _engine_label(resolve_engine(engine))
    print(f"preview:    {path} ({label}, {time.perf_counter() - t0:.1f} s)")
    return path


def read_obstacles(files):
    """[(name, V, F)] of the --obstacle files (core.mesh_io; MeshError naming a bad file)."""
    from .core.mesh_io import read_mesh

    out = []
    for f in files:
        V, F = read_mesh(f)
        out.append((Path(f).stem, V, F))
    return out


def plan_from_args(args, log=print):
    """The ``paths`` run through the core API: read the mesh, weld, fit the cones not given,
    plan, verify (``--verify``). Returns (V, F, mesh, PathRequest, PlanResult, VerifyReport
    or None, {stage: seconds}). Every stage is timed (``seconds_<stage>`` in the JSON's
    stats)."""
    from .core.fitting import fit_cones_to_mesh
    from .core.mesh import TriMesh
    from .core.mesh_io import read_mesh
    from .core.pipeline import PathRequest, plan_paths

    times = {}
    t = time.perf_counter()
    V, F = read_mesh(args.mesh)
    times["load"] = time.perf_counter() - t
    t = time.perf_counter()
    mesh = TriMesh.from_arrays(V, F)
    times["weld"] = time.perf_counter() - t
    c1, c2 = args.cone1_obj, args.cone2_obj
    fit = None
    if c1 is None or c2 is None:
        t = time.perf_counter()
        fit = fit_cones_to_mesh(mesh, args.axis_obj, generatrix=args.fit)
        c1, c2 = c1 or fit.cone1, c2 or fit.cone2
        times["fit"] = time.perf_counter() - t
        log(f"fitted cones: cone1 {_shown_generatrix(fit.cone1)} (residual "
            f"{fit.residual1:.4f} mm), cone2 {_shown_generatrix(fit.cone2)} (residual "
            f"{fit.residual2:.4f} mm)")
    req = PathRequest(args.axis_obj, c1, c2, **args.stages)
    extra = ()
    if args.collision.mode != "off":
        from .core.pipeline import collision_stage

        t = time.perf_counter()
        obstacles = read_obstacles(args.obstacle)
        times["load"] += time.perf_counter() - t
        extra = (collision_stage(args.collision, obstacles),)
    t = time.perf_counter()
    plan = plan_paths(mesh, req, extra=extra)
    times["plan"] = time.perf_counter() - t
    if extra:  # the collision stage's share of the plan
        times["collision"] = float(plan.path.stats.get("seconds_collision", 0.0))
        times["plan"] -= times["collision"]
    if fit is not None and plan.fit is None:
        plan.fit = fit
    report = None
    if args.verify:
        from .core.verify import verify_path

        t = time.perf_counter()
        report = verify_path(mesh, plan.path)
        times["verify"] = time.perf_counter() - t
    return V, F, mesh, req, plan, report, times


def _shown_generatrix(g):
    from .core.lmrs import Profile

    if isinstance(g, Profile):
        return f"profile of {len(g.as_list())} points"
    return str([round(x, 4) for x in g.as_list()])


def _verify_figures(report) -> dict:
    import numpy as np

    out = {}
    for key in ("max_material_left", "max_gouge"):
        value = float(getattr(report, key))
        if np.isfinite(value):
            out[f"verify_{key}"] = value
    return out


def _summary_line(path, times, report) -> str:
    program = path.program
    text = (f"{int(path.stats.get('passes', len(path.levels)))} passes, {len(path.curves)} "
            f"curves, {path.n_poses} poses, {path.length():.1f} mm of path")
    if program is not None:
        text += f", {len(program)} program poses"
    if report is not None:
        text += (f"; measured max material left {float(report.max_material_left):.4f} mm, "
                 f"max gouge {float(report.max_gouge):.4f} mm")
    return text


def process_age():
    """Seconds since this process started (the interpreter, Blender and the imports the
    user also waits for), from Linux's /proc; None where that is not available."""
    import os

    try:
        with open("/proc/self/stat") as fh:
            after_name = fh.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        # field 22 of stat (starttime, clock ticks after boot); fields 3.. follow the name
        return max(0.0, uptime - int(after_name[19]) / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _cmd_paths(args):
    t_wall = time.perf_counter()
    startup = process_age()
    _check_paths_args(args)
    from .core.paths_io import write_paths_json

    V, F, mesh, req, plan, report, times = plan_from_args(args)
    path = plan.path
    verdict = None
    if report is not None:
        from .core.verdict import judge, verdict_dict

        path.stats.update(_verify_figures(report))
        verdict = judge(report, req.cusp, req.chord, path.tool, path)
        path.verify = verdict_dict(verdict)
    out = Path(args.out).expanduser().resolve()
    t = time.perf_counter()
    # every stage up to the write (the write's own time is printed: it cannot be in the file)
    if startup is not None:  # the wall time counts from the process start, as the user waits
        times = {"startup": startup, **times}
    path.stats.update({f"seconds_{k}": v for k, v in times.items()})
    if plan.collision is not None:
        path.stats["seconds_collision"] = times["collision"]
    path.stats["seconds_wall"] = time.perf_counter() - t_wall + (startup or 0.0)
    write_paths_json(path, out)
    times["write"] = time.perf_counter() - t
    wall = time.perf_counter() - t_wall + (startup or 0.0)
    print(f"wrote {out}: {_summary_line(path, times, report)}")
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in times.items())
          + f"; wall {wall:.2f} s")
    print(f"tool: {req.cutter.describe()}, cusp {req.cusp:g} mm, chord {req.chord:g} mm")
    for w in plan.warnings:
        print(f"warning: {w}")
    if verdict is not None:
        from .core.verdict import verdict_lines

        for line in verdict_lines(verdict):
            print(line)
    unresolved = _collision_lines(plan)
    if args.nc and unresolved:
        print(f"NC not written: {unresolved[0]} unresolved collision(s)")
    elif args.nc:
        from .nc_cli import export_from_args

        export_from_args(path, args, Path(args.nc).expanduser().resolve(), Path(args.mesh).stem)
    if args.blend or args.preview:
        _blender_outputs(args, V, F, req, plan, report)
    if unresolved:
        _fail(f"{unresolved[0]} pose(s) are unresolved collisions (first: {unresolved[1]}); "
              f"the outputs were written, the NC program was not")
        return 4
    return 0


def _mm(x) -> str:
    return "n/a" if x is None else f"{float(x):.3f}"


def _collision_lines(plan):
    """Print the collision summary; returns (count, first pose) of the unresolved poses, or
    None when every pose is clear or corrected (or nothing was checked)."""
    rep = plan.collision
    if rep is None:
        return None
    summary = plan.path.collision or {}
    print(f"collisions ({summary.get('mode')}): {summary.get('checked_poses')} poses checked "
          f"against {len(summary.get('obstacles', {}).get('names', []) or []) or 'the'} "
          f"obstacle(s), {summary.get('colliding_before')} colliding before, "
          f"{summary.get('corrected')} corrected, {summary.get('unresolved')} unresolved; "
          f"min clearance {_mm(summary.get('min_clearance'))} mm ({rep.assembly_text})")
    if summary.get("links_colliding"):
        print(f"colliding links (retract, rapids, approach): {summary['links_colliding']}, "
              f"{summary.get('links_rerouted', 0)} re-routed through the clearance surface "
              f"({summary.get('link_poses_rerouted', 0)} poses), "
              f"{summary.get('links_unresolved', 0)} unresolved")
    if not rep.n_unresolved:
        return None
    import numpy as np

    from .core.avoidance import STATUS_UNRESOLVED

    prog = plan.path.program
    first = "?"
    if prog is not None and prog.collision_status is not None:
        j = int(np.flatnonzero(np.asarray(prog.collision_status) == STATUS_UNRESOLVED)[0])
        x, y, z = (float(v) for v in prog.tip[j])
        where = (f"pass {int(prog.curve[j])} pose {int(prog.index[j])}" if prog.curve[j] >= 0
                 else _link_name(summary, j))
        first = f"program row {j}, {where}, tip ({x:.3f}, {y:.3f}, {z:.3f}) mm"
    return int(rep.n_unresolved), first


def _link_name(summary, row) -> str:
    """The unresolved link holding program row ``row``, as the collision summary names it."""
    for u in summary.get("unresolved_links", []) or []:
        a, b = u["rows"]
        if a <= row < b:
            def pose(p, what):
                return what if p is None else f"pass {p['curve']} pose {p['index']}"

            return (f"the link from {pose(u['from'], 'the start')} to "
                    f"{pose(u['to'], 'the end')} ({u['reason']})")
    return "a link move"


def _cmd_nc(args):
    from .nc_cli import run_nc

    return run_nc(args)


def _blender_outputs(args, V, F, req, plan, report):
    """--blend / --preview: the blade, the settings of the request and the path objects in a
    fresh scene (the same objects Generate Paths makes), saved and/or rendered."""
    bpy = _import_bpy()
    from . import output
    from .blender_io import arrays_to_object, axis_to_object
    from .operators.common import set_settings_from_request

    with _blender_session(required=True) as scene:
        units = scene.unit_settings
        units.system, units.scale_length, units.length_unit = "METRIC", 0.001, "MILLIMETERS"
        blade = arrays_to_object(Path(args.mesh).stem, V, F, scene.collection,
                                 color=(0.85, 0.62, 0.30, 1.0))
        s = scene.blisk_cam
        s.blade = blade
        if args.axis:
            s.axis_object = axis_to_object("Blisk Axis", args.axis_obj, kind="EMPTY")
        set_settings_from_request(s, req, fit=args.fit)
        output.write_path_objects(scene, blade, plan.path, s, verify=report)
        if plan.fit is not None:
            s.fit_residual1, s.fit_residual2 = plan.fit.residual1, plan.fit.residual2
        from .operators.generate_paths import store_statistics

        store_statistics(s, blade.name, plan.path, report,
                         float(plan.path.stats.get("seconds_wall", 0.0)))
        if args.blend:
            print(f"blend: {_save_blend(bpy, args.blend)}")
        if args.preview:
            _render_by_operator(bpy, args.preview, args.engine, (1280, 720))


# --- entry point -------------------------------------------------------------------------
def _one_line(text) -> str:
    return " ".join(str(text).split()) or "unknown error"


def _fail(message) -> None:
    sys.stdout.flush()
    print(f"{PROG}: error: {_one_line(message)}", file=sys.stderr, flush=True)


def main(argv=None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser()
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv:
        _fail(f"no command given; use '{PROG} demo --out DIR' or '{PROG} paths --mesh FILE ...'")
        return 2
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:
            raise UsageError(f"unrecognized arguments: {' '.join(extra)} (see "
                             f"'{PROG} {args.command} --help')")
    except UsageError as exc:
        _fail(exc)
        return 2
    except SystemExit as exc:  # --help
        return exc.code if isinstance(exc.code, int) else 0
    try:
        return int(args.func(args) or 0)
    except UsageError as exc:
        _fail(exc)
        return 2
    except CliInternalError as exc:
        _fail(f"internal error: {exc}")
        return 3
    except BliskCamError as exc:
        _fail(exc)
        return 1
    except OSError as exc:
        _fail(f"{exc.strerror or exc}: {exc.filename}" if exc.filename else exc)
        return 1
    except KeyboardInterrupt:
        _fail("interrupted")
        return 130
    except Exception as exc:  # one line even for a bug; BLISK_CAM_DEBUG=1 shows the traceback
        import os

        if os.environ.get("BLISK_CAM_DEBUG"):
            import traceback

            traceback.print_exc()
        _fail(f"internal error: {type(exc).__name__}: {exc}")
        return 3
