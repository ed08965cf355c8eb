"""The ``paths`` command: mesh file → fitted cones → planned, checked and
verified paths JSON (numpy/scipy only; Blender outputs through
:mod:`.blender`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..core.collision.options import DEFAULT_CHECK_MODE, CollisionOptions
from ..core.errors import BliskCamError
from ..core.options import PATH_OPTION_GROUPS, CutterOptions
from ..core.tool.assembly import AssemblyError, holder_profile
from .flags import (
    UsageError,
    _fail,
    add_option_flags,
    check_file_roles,
    finite,
    option_args,
    positive,
)
from .nc import add_nc_arguments, planned_mesh_stats

ENGINES = ("AUTO", "WORKBENCH", "EEVEE", "CYCLES")
FITS = ("auto", "cone", "profile")


def add_paths_arguments(paths: argparse.ArgumentParser) -> None:
    """The arguments of ``paths``: the mesh, the cones, every path option, the outputs, the
    collision options and those of ``nc`` for ``--nc``."""
    paths.add_argument(
        "--mesh", required=True, metavar="FILE", help="blade mesh .stl .obj .ply (mm)"
    )
    paths.add_argument(
        "--units", type=str.lower, choices=("mm", "m", "in"), default="mm",
        help="units of the mesh file (and of --obstacle files): mm (default), m or in; the "
        "mesh is scaled to mm (a blade whose size says other units is refused, naming this)")
    paths.add_argument(
        "--cone1", type=finite, nargs=4, metavar=("R1", "Z1", "R2", "Z2"),
        help="first (hub) cone generatrix, mm",
    )
    paths.add_argument(
        "--cone2", type=finite, nargs=4, metavar=("R1", "Z1", "R2", "Z2"),
        help="last (tip) cone generatrix, mm",
    )
    paths.add_argument(
        "--axis", type=finite, nargs=6, metavar=("OX", "OY", "OZ", "DX", "DY", "DZ"),
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
    add_option_flags(paths, PATH_OPTION_GROUPS)
    paths.add_argument("--tool-radius", type=positive, default=None, metavar="MM",
                       help="the cutter radius instead of --tool-diameter (half of it)")
    paths.add_argument("--out", required=True, metavar="FILE", help="paths JSON to write")
    paths.add_argument("--blend", metavar="FILE", default=None, help="also save a .blend")
    paths.add_argument("--preview", metavar="FILE", default=None, help="also render a PNG")
    paths.add_argument("--engine", type=str.upper, choices=ENGINES, default="AUTO",
                       help="render engine of --preview")
    paths.add_argument("--quiet", action="store_true",
                       help="no progress lines on stderr (errors and warnings still print)")
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


def read_profile_csv(path):
    """A hub or tip generatrix polyline from a text file: one point ``r, z`` (mm) per line,
    separated by a comma, semicolon or white space; ``#`` starts a comment; blank lines are
    skipped (the reader is :func:`core.part.model.read_rz_csv`, which the stock's hub profile
    uses too). Returns a ``core.part.profiles.Profile``; BliskCamError naming the file (and
    line) when it is missing or not such a list."""
    from ..core.part.model import read_rz_csv
    from ..core.part.profiles import Profile

    points = read_rz_csv(path)
    try:
        return Profile(points.tolist())
    except BliskCamError as exc:
        raise BliskCamError(f"profile file {Path(path).expanduser()}: {exc}") from None


def check_paths_args(args):
    """Checks that need more than one argument; raises UsageError (BliskCamError for an
    unreadable profile file). Fills args.axis_obj, args.cone1_obj, args.cone2_obj (core
    ``Cone`` or ``Profile`` given on the command line, or None) and args.stages (the option
    stages of the request, float64, core units)."""
    from ..core.geometry.axis import Axis
    from ..core.part.cones import Cone

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
    from .nc import resolve_blade_count

    old_only = args.blades is not None and args.blade_count is None
    count = resolve_blade_count(args)  # --blades: the deprecated name (error on a mismatch)
    if count == 1 and old_only:  # '--blades 1': the one blade's program, no neighbours
        args.blade_count, args.nc_blades = None, 1
    given = option_args(args, PATH_OPTION_GROUPS)
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
    machine_file = args.machine if args.machine and args.machine.endswith(".toml") else None
    check_file_roles(
        [("--mesh", args.mesh), ("--cone1-profile", args.cone1_profile),
         ("--cone2-profile", args.cone2_profile), ("--machine", machine_file),
         *(("--obstacle", o) for o in args.obstacle)],
        [("--out", args.out), ("--nc", args.nc), ("--blend", args.blend),
         ("--preview", args.preview), ("--report", getattr(args, "report", None))])
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


_check_paths_args = check_paths_args  # the name the tests knew it by


def parse_holder(text):
    """'z r z r ...' (mm) → ((z, r), ...); UsageError naming what is wrong."""
    try:
        return holder_profile(text, "--holder")
    except AssemblyError as exc:
        raise UsageError(str(exc)) from None


def _collision_options(args):
    """The CollisionOptions of the flags: the mode defaults to check (DEFAULT_CHECK_MODE, as
    the panel's Check Collisions) when a blade count or an obstacle is given (else off)."""
    from ..core.geometry.axis import Axis
    from ..core.process.blade_finish import PathRequest, make_cutter

    given = option_args(args, (CollisionOptions,))
    if args.holder is not None:
        given["holder"] = parse_holder(args.holder)
    if "mode" not in given:
        given["mode"] = (DEFAULT_CHECK_MODE if ("blade_count" in given or args.obstacle)
                         else "off")
    if given["mode"] != "off" and "blade_count" not in given:
        raise UsageError(f"--collisions {given['mode']} needs --blade-count N (the neighbours "
                         "are the blade turned by k·360°/N)")
    if given["mode"] == "avoid" and getattr(args, "machine", None):
        # avoidance keeps the axes inside the rotaries' reach of the machine posted for
        from ..core.machine.description import load_machine

        try:
            given["machine"] = load_machine(args.machine)
        except BliskCamError as exc:
            raise UsageError(f"--machine {args.machine}: {exc}") from None
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


def read_obstacles(files, units="mm"):
    """[(name, V, F)] of the --obstacle files (core.geometry.mesh_io; MeshError naming a bad
    file), scaled from ``units`` to mm."""
    from ..core.geometry.mesh_io import read_mesh, to_mm

    out = []
    for f in files:
        V, F = read_mesh(f)
        out.append((Path(f).stem, to_mm(V, units), F))
    return out


def plan_from_args(args, log=print, progress=None, loaded=None):
    """The ``paths`` run through the core API: read the mesh, weld, fit the cones not given,
    plan, verify (``--verify``). Returns (V, F, mesh, PathRequest, PlanResult, VerifyReport
    or None, {stage: seconds}); V, F (the file's arrays, for ``--blend``/``--preview``) are
    None without those outputs. Every stage is timed (``seconds_<stage>`` in the JSON's
    stats). ``progress``: a :class:`.progress.StageProgress` for the percentage lines on
    stderr (None: silent). ``loaded``: called with no argument once the mesh file is read
    (before the weld)."""
    from ..core.geometry.mesh import TriMesh
    from ..core.geometry.mesh_io import check_blade_size, read_mesh, read_mesh_for_weld, to_mm
    from ..core.part.fitting import fit_cones_to_mesh
    from ..core.process.blade_finish import PathRequest, iter_plan_paths
    from ..core.runtime import workers
    from .progress import StageProgress

    progress = progress or StageProgress(quiet=True)

    times = {}
    t = time.perf_counter()
    soup = getattr(args, "blend", None) or getattr(args, "preview", None)
    # a binary STL without those outputs: read and welded exactly in one pass from the file,
    # the float64 soup (3 corners a face) never built — the same mesh, ~300 MB less memory
    # touched at 1M triangles (corners None: read_mesh's way)
    if soup:
        V, F = read_mesh(args.mesh)
        V, corners = to_mm(V, args.units), None
    else:
        V, F, corners = read_mesh_for_weld(args.mesh, args.units)
    times["load"] = time.perf_counter() - t
    if loaded is not None:
        loaded()
    t = time.perf_counter()
    mesh = TriMesh.from_arrays(V, F, soup_corners=corners)
    # metres or inches: refused with the size and the fix; measured on the welded vertices
    # (the file's corners, an STL's three per face, are the same points ~6 times over)
    check_blade_size(mesh.V, args.axis_obj)
    times["weld"] = time.perf_counter() - t
    if not (getattr(args, "blend", None) or getattr(args, "preview", None)):
        V = F = None  # the file's triangle soup (3 corners a face) is not held through the plan
        # nor the maps from it into the mesh (for values carried back onto the soup; an STL
        # at 1M triangles: 32 MB held through the passes, the run's peak)
        mesh.vertex_map = mesh.face_map = None
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
    if (req.allowance > 0 or req.offset_layers > 1) and args.collision.blade_count:  # before any
        from ..core.process.blade_finish import check_allowance_in_channel  # path work
        from ..core.process.semi_layers import layer_allowances

        check_allowance_in_channel(mesh, args.axis_obj, args.collision.blade_count,
                                   max(layer_allowances(req.allowance, req.offset_from,
                                                        req.offset_layers)))
    extra = ()
    if args.collision.mode != "off":
        from ..core.process.collision_stage import collision_stage

        t = time.perf_counter()
        obstacles = read_obstacles(args.obstacle, args.units)
        times["load"] += time.perf_counter() - t
        extra = (collision_stage(args.collision, obstacles),)
    t = time.perf_counter()
    it = iter_plan_paths(mesh, req, extra=extra)
    while True:  # the stages yield Progress: a percentage line on stderr now and then
        try:
            p = next(it)
        except StopIteration as stop:
            plan = stop.value
            break
        progress.report("collisions" if "collision" in p.message else "plan", p.fraction,
                        p.message)
    times["plan"] = time.perf_counter() - t
    if extra:  # the collision stage's share of the plan
        times["collision"] = float(plan.path.stats.get("seconds_collision", 0.0))
        times["plan"] -= times["collision"]
    progress.done("collisions" if extra else "plan", times["collision" if extra else "plan"])
    if fit is not None and plan.fit is None:
        plan.fit = fit
    report = None
    if args.verify:
        from ..core.verify.measure import verify_path

        t = time.perf_counter()
        report = verify_path(mesh, plan.path, progress=progress.step("verify"),
                             workers=workers())
        times["verify"] = time.perf_counter() - t
        progress.done("verify", times["verify"])
    return V, F, mesh, req, plan, report, times


def _shown_generatrix(g):
    from ..core.part.profiles import Profile

    if isinstance(g, Profile):
        return f"profile of {len(g.as_list())} points"
    return str([round(x, 4) for x in g.as_list()])


def _verify_figures(report) -> dict:
    import numpy as np

    out = {}
    a = float(getattr(report, "allowance", 0.0) or 0.0)
    for key in ("max_material_left", "max_gouge"):
        # with an allowance: the material left on the blade, the depth cut into the allowance
        value = float(getattr(report, key)) + (a if key == "max_material_left" else 0.0)
        if np.isfinite(value):
            out[f"verify_{key}"] = value
    if a:
        out["verify_allowance"] = a
    return out


def _summary_line(path, times, report) -> str:
    program = path.program
    text = (f"{int(path.stats.get('passes', len(path.levels)))} passes, {len(path.curves)} "
            f"curves, {path.n_poses} poses, {path.length():.1f} mm of path")
    if program is not None:
        text += f", {len(program)} program poses"
    a = float(getattr(report, "allowance", 0.0) or 0.0)
    if report is not None and a:
        text += (f"; measured max material left on the blade "
                 f"{a + float(report.max_material_left):.4f} mm (allowance {a:g} mm), max cut "
                 f"into the allowance {float(report.max_gouge):.4f} mm")
    elif report is not None:
        text += (f"; measured max material left {float(report.max_material_left):.4f} mm, "
                 f"max gouge {float(report.max_gouge):.4f} mm")
    return text


def process_age():
    """Seconds since this process started (the interpreter, Blender and the imports the
    user also waits for), from Linux's /proc or Windows' process times; None where neither
    is available (macOS)."""
    import os

    if sys.platform == "win32":
        return _windows_process_age()
    try:
        with open("/proc/self/stat") as fh:
            after_name = fh.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as fh:
            uptime = float(fh.read().split()[0])
        # field 22 of stat (starttime, clock ticks after boot); fields 3.. follow the name
        return max(0.0, uptime - int(after_name[19]) / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError, AttributeError):
        return None


def _windows_process_age():
    """:func:`process_age` on Windows: now less the process' creation time (kernel32's
    GetProcessTimes, 100 ns ticks since 1601); None when the call fails."""
    import ctypes
    from ctypes import wintypes

    try:
        k32 = ctypes.WinDLL("kernel32", use_last_error=True)
        k32.GetCurrentProcess.restype = wintypes.HANDLE
        k32.GetProcessTimes.argtypes = [wintypes.HANDLE, *[ctypes.POINTER(wintypes.FILETIME)] * 4]
        times = [wintypes.FILETIME() for _ in range(4)]  # creation, exit, kernel, user
        if not k32.GetProcessTimes(k32.GetCurrentProcess(), *map(ctypes.byref, times)):
            return None
        now = wintypes.FILETIME()
        k32.GetSystemTimeAsFileTime(ctypes.byref(now))
    except (OSError, AttributeError):
        return None

    def ticks(ft):
        return (ft.dwHighDateTime << 32) | ft.dwLowDateTime

    return max(0.0, (ticks(now) - ticks(times[0])) * 1e-7)


def _cmd_paths(args):
    check_paths_args(args)
    # the modules the plan needs (numpy, scipy, the core) are imported before the startup
    # figure is taken: the user waits for them as for the interpreter, and imported inside
    # plan_from_args they would fall between the stages, in no figure
    from ..core.geometry import mesh_io  # noqa: F401
    from ..core.part import fitting  # noqa: F401
    from ..core.process import blade_finish  # noqa: F401
    from ..core.runtime import alongside
    from ..core.toolpath.paths_io import write_paths_json
    from .progress import StageProgress

    t_wall = time.perf_counter()
    startup = process_age()

    progress = StageProgress(quiet=args.quiet)
    # the mesh file's SHA-256 (for nc's constant-error budget) on a thread of its own while
    # the plan runs: hashlib releases the GIL (with --threads 1: at the write, as before).
    # Started once the file is read: the read's kernel works on every core, the weld after
    # it mostly on one (a 65 MB STL: its 0.05 s of hashing no longer slows the read)
    hashing = []
    V, F, mesh, req, plan, report, times = plan_from_args(
        args, progress=progress, loaded=lambda: hashing.append(
            alongside(lambda: planned_mesh_stats(args.mesh, args.units))))
    mesh_stats = hashing[0]
    path = plan.path
    verdict = None
    if report is not None:
        from ..core.verify.verdict import judge, verdict_dict

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
    path.stats.update(mesh_stats())
    write_paths_json(path, out)
    times["write"] = time.perf_counter() - t
    print(f"wrote {out}: {_summary_line(path, times, report)}")
    stock = (f", allowance {req.allowance:g} mm (semi-finishing: the blade offset by it)"
             if req.allowance else "")
    if req.offset_layers > 1:
        stock += ("," if not req.allowance else "") + (
            f" in {req.offset_layers} offset layers from {req.offset_from:g} mm ("
            + ", ".join(f"{a:g}" for a in path.stats["layer_allowances"]) + " mm)")
    print(f"tool: {req.cutter.describe()}, cusp {req.cusp:g} mm, chord {req.chord:g} mm"
          f"{stock}; kernels: {path.stats.get('kernels', 'numpy')}, {_threads_text(path.stats)}")
    for w in plan.warnings:
        print(f"warning: {w}")
    if verdict is not None:
        from ..core.verify.verdict import verdict_lines

        for line in verdict_lines(verdict):
            print(line)
    unresolved = _collision_lines(plan)
    nc_written = False
    if args.nc:  # the one collision gate of every NC export (core/post/gate.py)
        from ..core.post.gate import CollisionGateError
        from .nc import export_from_args

        t = time.perf_counter()
        progress.report("nc", 0.0, "posting the NC program")
        try:
            export_from_args(path, args, Path(args.nc).expanduser().resolve(),
                             Path(args.mesh).stem, part=mesh)
            nc_written = True
        except CollisionGateError as exc:
            print(f"NC not written: {exc}")
        times["nc"] = time.perf_counter() - t
        progress.done("nc", times["nc"])
    if args.blend or args.preview:
        from .blender import _blender_outputs  # bpy's side, only for these outputs

        t = time.perf_counter()
        _blender_outputs(args, V, F, req, plan, report)
        times["blender"] = time.perf_counter() - t
    # the wall time counts every stage the user waited for, the NC posting included
    wall = time.perf_counter() - t_wall + (startup or 0.0)
    print("time: " + ", ".join(f"{k} {v:.2f} s" for k, v in times.items())
          + f"; wall {wall:.2f} s")
    if unresolved:
        nc_text = ("the NC program was written with them marked (--allow-collisions)"
                   if nc_written else "the NC program was not")
        _fail(f"{unresolved[0]} pose(s) are unresolved collisions (first: {unresolved[1]}); "
              f"the outputs were written, {nc_text}")
        return 4
    return 0


def _threads_text(stats) -> str:
    """'2 threads' (or '1 thread') of the JSON's stats (the plan's threads)."""
    from ..core.runtime import workers

    n = int(stats.get("threads", workers()))
    return f"{n} thread{'s' if n != 1 else ''}"


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
    ranges = summary.get("unresolved_ranges") or []
    if ranges:
        from ..core.collision.ranges import describe_ranges

        print(f"unresolved pass poses in {len(ranges)} range(s): {describe_ranges(ranges)}")
    if summary.get("tool_hint"):
        print(f"hint: {summary['tool_hint']}")
    if not rep.n_unresolved:
        return None
    import numpy as np

    from ..core.toolpath.types import STATUS_UNRESOLVED

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
