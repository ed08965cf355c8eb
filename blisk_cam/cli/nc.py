"""The ``nc`` command: paths JSON → NC program (numpy/scipy only, no bpy).

::

    python -m blisk_cam nc --paths paths.json --machine ac-trunnion|FILE.toml \\
        --post linuxcnc|fanuc|siemens|heidenhain|apt --out FILE [--blades N] \\
        [--feed MM_MIN] [--spindle RPM] [--tool-number T] [--no-coolant] ...

(every NC option of :class:`~blisk_cam.core.post.blocks.NcOptions` has its flag)

:func:`add_nc_arguments` fills a (sub)parser, :func:`run_nc` runs it: exit 0 on success, 1 with
one line on stderr (``blisk_cam: error: ...``) for bad input or an unreachable pose (naming the
pose, the axis and the value).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import replace

import numpy as np

from ..core.errors import BliskCamError
from ..core.files import file_sha256
from ..core.machine.description import Machine, known_presets, load_machine
from ..core.post.blocks import NcOptions
from ..core.post.common import POSTS, write_atomic
from ..core.toolpath.paths_io import read_paths_json
from .flags import PROG, UsageError, add_option_flags, check_file_roles, option_args
from .progress import StageProgress

__all__ = ["add_nc_arguments", "run_nc"]


def add_nc_arguments(parser: argparse.ArgumentParser, *, with_paths: bool = True):
    """Add the ``nc`` options to ``parser``: the files, the machine and post, and every
    declared NC option (:class:`~blisk_cam.core.post.blocks.NcOptions`). ``with_paths``
    False: for ``paths ... --nc FILE`` (the path comes from the same run)."""
    if with_paths:
        parser.add_argument("--paths", required=True, metavar="FILE",
                            help="paths JSON (version 1) written by 'blisk_cam paths'")
        parser.add_argument("--out", required=True, metavar="FILE", help="NC program to write")
        parser.add_argument("--quiet", action="store_true",
                            help="no progress lines on stderr (errors and warnings still print)")
    parser.add_argument("--machine", required=with_paths, metavar="PRESET|FILE.toml",
                        help=f"machine preset ({', '.join(known_presets())}) or a machine "
                        "TOML file")
    parser.add_argument("--post", required=with_paths, type=str.lower, metavar="POST",
                        help="controller dialect: one of " + ", ".join(POSTS))
    add_option_flags(parser, (NcOptions,))
    if with_paths:  # 'paths' has it already (the collision options)
        parser.add_argument("--blade-count", type=_whole_at_least_1, default=None,
                            metavar="N", help="blades on the blisk: the program is repeated "
                            "for N blades, blade k turned by k*360/N about the blisk axis "
                            "(default 1: the one blade)")
    parser.add_argument("--part-origin", type=_xyz, default=None, metavar="X,Y,Z",
                        help="where the part (paths) origin sits, mm in the machine "
                        "description's frame with the rotaries at 0 (instead of the machine's "
                        "[part] origin); TCP programs state it as the work offset to set")
    parser.add_argument("--blades", type=_whole_at_least_1, default=None, metavar="N",
                        help="deprecated: the old name of --blade-count (must agree with it)")
    parser.add_argument("--allow-collisions", action="store_true",
                        help="post a path whose collision check left unresolved poses (the "
                        "program header then says how many and where); without it such a "
                        "path is refused")
    if with_paths:  # 'paths' has the mesh already
        parser.add_argument("--part-mesh", default=None, metavar="FILE",
                            help="the blade mesh the paths were planned on (.stl .obj .ply, "
                            "mm): --interpolation constant-error then budgets the planned "
                            "path's own deviation from it in every block (default: the mesh "
                            "the paths JSON records, if unchanged; without a mesh the path's "
                            "chord tolerance is budgeted whole)")
    parser.add_argument("--report", default=None, metavar="FILE.json",
                        help="also write the export report (with the interpolation's) as JSON")
    return parser


def _xyz(text):
    """argparse type: 'X,Y,Z' → three finite numbers (mm)."""
    try:
        v = [float(x) for x in str(text).split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(math.isfinite(x) for x in v):
        raise argparse.ArgumentTypeError(f"expected three numbers X,Y,Z in mm, got '{text}'")
    return tuple(v)


def machine_of(args):
    """The machine of ``args.machine`` (preset, TOML or a loaded Machine) with
    ``--part-origin`` applied."""
    machine = args.machine if isinstance(args.machine, Machine) else load_machine(args.machine)
    if getattr(args, "part_origin", None) is not None:
        machine = replace(machine, part_origin=np.array(args.part_origin, dtype=float))
    return machine


def _part_mesh(args):
    """The TriMesh of ``--part-mesh`` (None when not given); BliskCamError for a file that
    cannot be read."""
    f = getattr(args, "part_mesh", None)
    if not f:
        return None
    from ..core.geometry.mesh_io import read_trimesh

    return read_trimesh(f)  # a binary STL welded as it is read (no float64 soup)


def planned_mesh_stats(mesh_file, units: str = "mm") -> dict:
    """What ``paths`` records in the JSON's ``stats`` of the mesh it planned on (absolute name,
    units, SHA-256), so that ``nc`` can budget constant-error interpolation against it."""
    return {"mesh_file": os.path.abspath(mesh_file), "mesh_units": units,
            "mesh_sha256": file_sha256(mesh_file)}


def recorded_mesh(path):
    """The mesh the paths were planned on, as recorded by :func:`planned_mesh_stats`, when the
    file is still there with the same bytes; else None, with a warning on stderr saying why
    (nothing recorded: None, silently — the program header says what was budgeted)."""
    from ..core.geometry.mesh_io import read_trimesh

    f, sha = path.stats.get("mesh_file"), path.stats.get("mesh_sha256")
    if not f or not sha:
        return None
    why = ("is not there any more" if not os.path.isfile(f)
           else "has changed since the paths were planned" if file_sha256(f) != sha else None)
    if why:
        print(f"{PROG}: warning: the blade mesh {f} {why}: constant-error budgets the path's "
              "chord tolerance whole; give the blade mesh with --part-mesh", file=sys.stderr)
        return None
    mesh = read_trimesh(f, path.stats.get("mesh_units", "mm"))
    print(f"{PROG}: constant-error measured against {f}, the mesh the paths were planned on "
          "(--part-mesh gives another)", file=sys.stderr)
    return mesh


def _whole_at_least_1(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected at least 1 blade, got {value}")
    return value


def resolve_blade_count(args, warn=True):
    """The one blade count of the command line: ``--blade-count``, or the deprecated
    ``--blades`` (a note on stderr); UsageError when both are given and differ. Sets
    ``args.blade_count`` (None when neither is given) and returns it."""
    old = getattr(args, "blades", None)
    count = getattr(args, "blade_count", None)
    if old is not None:
        if count is not None and count != old:
            raise UsageError(f"--blades {old} and --blade-count {count} disagree; --blades is "
                             "the old name of --blade-count (the blades on the blisk, used by "
                             "the collision check and the NC program): give --blade-count once")
        if warn:
            print(f"{PROG}: warning: --blades is deprecated; use --blade-count {old}",
                  file=sys.stderr)
        count = old
        args.blades = None
    args.blade_count = count
    return count


def nc_options(args, **extra):
    """The :class:`NcOptions` of the parsed flags (UsageError for a value out of bounds);
    the blades from the one blade count (:func:`resolve_blade_count`, default 1)."""
    count = resolve_blade_count(args)
    count = count or getattr(args, "nc_blades", None) or 1
    return NcOptions(**option_args(args, (NcOptions,)), blades=count,
                     allow_collisions=bool(getattr(args, "allow_collisions", False)), **extra)


def export_from_args(path, args, out, blade_name, part=None):
    """Post ``path`` for ``args.machine``/``args.post`` into ``out``; prints the summary.
    ``part``: the part's mesh (constant-error budgets the planned path's own deviation from
    it; without it the path's chord tolerance)."""
    try:
        options = nc_options(args, blade_name=blade_name)
    except BliskCamError as exc:  # options that only make sense together

        raise UsageError(str(exc)) from None
    if options.interpolation and part is None:
        part = recorded_mesh(path)
    from ..core.post.export import export_nc  # not for the flags alone (paths --help)

    report = export_nc(path, machine_of(args), args.post, options, out, part=part)
    print(report.summary())
    if report.gate.warning:
        print(f"{PROG}: warning: {report.gate.warning}", file=sys.stderr)
    if getattr(args, "report", None):
        _write_report(report, args.report)
    return report


def _write_report(report, filename):
    """The export report as JSON (atomically)."""
    import json


    d = {k: getattr(report, k) for k in ("filename", "post", "machine", "blocks", "inserted",
                                         "minutes", "max_deviation", "blades", "indexed")}
    d["axis_ranges"] = {k: list(v) for k, v in report.axis_ranges.items()}
    if report.interpolation is not None:
        d["interpolation"] = report.interpolation.as_dict()
    return write_atomic(filename, json.dumps(d, indent=1))


def run_nc(args) -> int:
    """Run the ``nc`` command on parsed ``args``; prints a summary on stdout, returns the exit
    status (0 ok, 1 bad input with one line on stderr, 2 a bad option value)."""
    from ..core.post.export import get_post
    from ..core.post.gate import collision_gate

    try:
        resolve_blade_count(args)
        check_file_roles(
            [("--paths", args.paths),
             ("--machine", args.machine if str(args.machine).endswith(".toml") else None),
             ("--part-mesh", getattr(args, "part_mesh", None))],
            [("--out", args.out), ("--report", getattr(args, "report", None))])
        machine = machine_of(args)  # cheap: a bad machine file before the paths
        if not os.path.isfile(args.paths):
            raise BliskCamError(f"paths file {args.paths} not found")
        path = read_paths_json(args.paths)
        args.machine = machine
        get_post(args.post).check(machine)  # cheap refusals before the progress line
        collision_gate(path, bool(args.allow_collisions))
        part = _part_mesh(args)
        folder = os.path.dirname(os.path.abspath(os.fspath(args.out)))
        if not os.path.isdir(folder):
            raise BliskCamError(f"cannot write {args.out}: the directory {folder} does not "
                                "exist")
        progress = StageProgress(quiet=args.quiet)
        t = time.perf_counter()
        progress.report("nc", 0.0, "posting the NC program")
        export_from_args(path, args, args.out,
                         os.path.splitext(os.path.basename(args.paths))[0],
                         part=part)
        progress.done("nc", time.perf_counter() - t)
    except UsageError as err:
        print(f"{PROG}: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except (BliskCamError, OSError) as err:
        msg = " ".join(str(err).split())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 1
    return 0

