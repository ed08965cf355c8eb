"""The command line: ``python -m blisk_cam ...`` (bpy wheel) or
``blender -b --python scripts/blender_cli.py -- ...`` (a Blender binary).

::

    python -m blisk_cam demo --out DIR [--mesh-resolution R] [--no-paths] [--no-preview]
    python -m blisk_cam paths --mesh FILE(.stl|.obj|.ply) \
        --cone1 R1 Z1 R2 Z2 --cone2 R1 Z1 R2 Z2 [--axis OX OY OZ DX DY DZ] \
        --tool ball|bull|flat|taper --tool-radius 6 [--corner-radius 2] \
        --cusp 0.05 --chord 0.05 [--lead DEG --tilt DEG] [--link oneway|zigzag|spiral] \
        --out paths.json [--blend out.blend] [--preview out.png] [--verify]
        [--fit auto|cone|profile] [--cone1-profile FILE.csv] [--cone2-profile FILE.csv]
        [--taper-angle DEG] [--lead-tip DEG] [--tilt-tip DEG] [--axis-mode MODE]
        [--radial-tilt DEG] [--axis-point X Y Z] [--max-axis-turn DEG]
        [--milling climb|conventional] [--approach MM] [--clearance-radius MM]
        [--clearance-margin MM] [--no-fix-gouge]
    python -m blisk_cam nc --paths paths.json --machine PRESET|FILE.toml --post POST --out FILE
    python -m blisk_cam robot --paths paths.json --robot PRESET|FILE.toml \
        --post krl|rapid|pdl2|fanuc-ls --out DIR [--feed MM_MIN] [--force N]
    python -m blisk_cam hub --part MESH --blade-count N --tool-diameter MM --scallop MM \
        [--operation hub|fillet] --out hub.json   (see cli/hub.py)
    python -m blisk_cam batch JOBS.toml --out DIR [--scheduler ADDRESS] [--workers N] [--serial]

Angles are degrees on the command line (radians in the scene settings and the core).

Both commands run the add-on's operators (``blisk_cam.fit_cones``, ``generate_paths``,
``export_paths``, ``render_preview``) on a scene whose ``scene.blisk_cam`` settings are filled
from the arguments: the command line and the user interface share one code path.

Exit status 0 on success. On bad input: a non-zero status (2 for a usage error, 1 for input
the core or Blender rejects, 3 for an internal error) and exactly one line on stderr,
``blisk_cam: error: <what is wrong>``. ``bpy`` is imported only inside the commands, so this
module imports without Blender. Whatever the commands registered is unregistered before
:func:`main` returns (bpy 4.5 hangs at exit while add-on classes are registered).
"""

from __future__ import annotations

import argparse
import sys

from ..core.errors import BliskCamError
from ..core.kernels.backend import backend_name
from ..core.runtime import parallel
from ..core.version import __version__
from .console import never_fail_on_encoding
from .flags import (
    PROG,
    CliInternalError,
    UsageError,
    _fail,
    add_threads_argument,
    finite,
    positive,
)

__all__ = ["main", "build_parser"]

#: the commands that compute in this process and take ``--threads N`` (demo runs Blender's
#: operators, which choose their own threads; batch sizes its Dask cluster with --workers)
THREADED_COMMANDS = ("paths", "nc", "robot", "simulate", "rough", "hub", "process")


class _Parser(argparse.ArgumentParser):
    """An ArgumentParser that raises instead of printing usage and exiting: the CLI prints one
    line itself."""

    def error(self, message):
        raise UsageError(f"{message} (see '{self.prog} --help')")


# --- argument types ----------------------------------------------------------------------
_finite = finite


_positive = positive


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




def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of the CLI (subcommands ``demo``, ``paths``, ``nc``, ``robot``,
    ``simulate``, ``rough``, ``hub``, ``batch``, ``process``).

    ``command``: the one subcommand about to run (the first word of the command line); only
    its arguments are declared — the others are listed with their help, but their arguments
    (and the modules that declare them: the machines and posts of ``nc``, the patterns of
    ``rough``, ...) are neither imported nor built, which a run waits for otherwise (~0.1 s
    of a ``paths`` run). A word that is not a command (``--help``, ``--version``, a typo):
    no command's arguments — the top level's help, version and errors name the commands
    only (``--version`` took 0.28 s of CPU building them all, 0.14 s without). None: the
    whole parser."""
    parser = _Parser(
        prog=PROG,
        description="Blisk CAM: 5-axis finishing tool paths for blisk blades (command line).",
    )
    parser.add_argument("--version", action="version",
                        version=f"{PROG} {__version__} (kernels: {backend_name()})")
    sub = parser.add_subparsers(dest="command",
                                metavar="{demo,paths,nc,robot,simulate,rough,hub,batch,process}")
    sub.required = True

    commands = (
        ("demo", "build the demo blisk; write DIR/demo.blend and DIR/preview.png",
         "Build the parametric demo blisk (a few blades, a hub sector, the hub and tip cones and "
         "the axis), save DIR/demo.blend and render DIR/preview.png.",
         _add_demo_arguments, _cmd_demo),
        ("paths", "tool paths for a blade mesh → paths JSON",
         "Finishing tool paths between two cones on a blade mesh (mm). Without --cone1/--cone2 "
         "the cones are fitted to the blade's boundary loops. Lengths in mm, angles in degrees. "
         "Needs only numpy and scipy; --blend and --preview need Blender's Python module (bpy).",
         _add_paths_arguments, _cmd_paths),
        ("nc", "paths JSON → NC program for a 5-axis machine",
         "Post a paths JSON for a machine (preset or TOML) and a controller: inverse kinematics "
         "within the limits, rotary linearization, every blade. Lengths mm, angles degrees. "
         "Needs only numpy and scipy.",
         _add_nc_arguments, _cmd_nc),
        ("robot", "paths JSON → robot polishing program (KRL, RAPID, PDL2, Fanuc LS)",
         "Program a 6-axis robot (preset or TOML) holding a polishing head along a paths JSON: "
         "the angle about the tool axis resolved over the path, one arm configuration per "
         "stroke, joint limits, speeds and singularities checked; the program split into the "
         "files the controller accepts. Lengths mm, angles degrees. Needs only numpy and scipy.",
         _add_robot_arguments, _cmd_robot),
        ("simulate", "material removal on the blisk's stock → deviation map and verdict",
         "Run programs (paths JSON) on a stock of one pitch sector (radial dexels), measure the "
         "deviation on the part (+ material left, − gouge, mm) and judge it: exit 5 when a "
         "gouge exceeds the tolerance or a rapid or the tool body removes material. Needs "
         "only numpy and scipy.",
         _add_simulate_arguments, _cmd_simulate),
        ("rough", "channel roughing from the blank → paths JSON (\"operation\": \"rough\")",
         "Rough the channels between the blades from the blank down to an allowance (default "
         "0.5 mm) in levels (from the hub, from the shroud or morphed), zig-zag or plunge; "
         "the tool, its shank and holder kept clear of the allowance. One gap is planned; "
         "nc and simulate repeat it for the N gaps. Lengths mm, angles degrees. Needs only "
         "numpy and scipy.",
         _add_rough_arguments, _cmd_rough),
        ("hub", "hub or fillet finishing of a blisk → paths JSON",
         "Finish the hub between two blades (boundary-conformed passes from the leading to "
         "the trailing edge, spaced by stepover or scallop on the hub's curvature, two regions, "
         "extended past the edges) or the fillet around the blade root with a ball smaller "
         "than the fillet. Lengths in mm, angles in degrees. Needs only numpy and scipy.",
         _add_hub_arguments, _cmd_hub),
        ("batch", "run the jobs of a TOML file on a Dask cluster → DIR",
         "Run the jobs of JOBS.toml (single commands, per-blade paths of a whole-blisk scan, "
         "sweeps over tool, lead, tilt and holder length) on a Dask cluster: a local cluster "
         "of this machine's cores, or --scheduler ADDRESS. Each job's files land in DIR/<job>/; "
         "DIR/summary.csv and summary.md list every job; a re-run skips the jobs whose inputs "
         "and outputs did not change. Exit 6 when a job (or a blade) failed. Needs Dask: "
         "pip install 'blisk-cam[batch]'.",
         _add_batch_arguments, _cmd_batch),
        ("process", "a whole job (part, stock, tools, operations in order) → DIR",
         "Run a job file: each operation in order on the stock the previous one left (paths "
         "JSON, stock, deviation map per operation), one NC program per post with a tool "
         "change per tool, cutting data at the effective diameter from the part's material, "
         "and a setup sheet. DIR is written as a whole at the end. Exit 5 when an operation's "
         "verdict or the final verdict failed, 6 when the final verdict is incomplete (zones "
         "no finishing operation plans to cut, named 'not machined'), 4 when the collision "
         "gate refused a post. Needs only numpy and scipy.",
         _add_process_arguments, _cmd_process),
    )
    for name, help_text, description, add_arguments, run in commands:
        parsed = sub.add_parser(name, help=help_text, description=description)
        if command is None or name == command:
            add_arguments(parsed)
            if name in THREADED_COMMANDS:
                add_threads_argument(parsed)
        parsed.set_defaults(func=run)
    return parser


# --- each command's module, imported only for the command that runs --------------------------
def _add_paths_arguments(parser):
    from .paths import add_paths_arguments

    add_paths_arguments(parser)


def _add_nc_arguments(parser):
    from .nc import add_nc_arguments

    add_nc_arguments(parser)


def _add_robot_arguments(parser):
    from .robot import add_robot_arguments

    add_robot_arguments(parser)


def _add_simulate_arguments(parser):
    from .simulate import add_simulate_arguments

    add_simulate_arguments(parser)


def _add_rough_arguments(parser):
    from .rough import add_rough_arguments

    add_rough_arguments(parser)


def _add_hub_arguments(parser):
    from .hub import add_hub_arguments

    add_hub_arguments(parser)


def _add_process_arguments(parser):
    from .process import add_process_arguments

    add_process_arguments(parser)


def _cmd_demo(args):
    from .blender import _cmd_demo as run_demo

    return run_demo(args)


def _cmd_paths(args):
    from .paths import _cmd_paths as run_paths

    return run_paths(args)


def _add_demo_arguments(demo: argparse.ArgumentParser) -> None:
    """The arguments of ``demo``."""
    from .paths import ENGINES

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


def _add_batch_arguments(batch: argparse.ArgumentParser) -> None:
    """The arguments of ``batch``."""
    batch.add_argument("jobs", metavar="JOBS.toml", help="the jobs file")
    batch.add_argument("--out", required=True, metavar="DIR", help="output folder")
    batch.add_argument("--scheduler", metavar="ADDRESS", default=None,
                       help="a running Dask scheduler (tcp://host:8786); default: a local "
                       "cluster")
    batch.add_argument("--workers", type=_blade_count, default=None, metavar="N",
                       help="local cluster worker processes (default: the cores)")
    batch.add_argument("--serial", action="store_true",
                       help="no cluster: the jobs one after another in this process")


def _cmd_batch(args):
    import importlib.util

    if args.scheduler and args.workers:
        raise UsageError("--workers sizes the local cluster; with --scheduler the scheduler's "
                         "workers run the jobs: drop one")
    if not args.serial and importlib.util.find_spec("distributed") is None:
        raise BliskCamError("batch runs need Dask, which is not installed: pip install "
                            "'blisk-cam[batch]' (or run the jobs one by one with --serial)")
    from ..batch.run import run_batch

    report = run_batch(args.jobs, args.out, scheduler=args.scheduler, workers=args.workers,
                       serial=args.serial)
    for row in report.rows:
        print(f"{row['job']}: {row['status']}" + (f" — {row['detail']}" if row.get("detail")
                                                  else ""))
    print(f"wrote {report.out / 'summary.md'} ({len(report.rows)} jobs, {report.wall:.1f} s)")
    if report.failed:
        _fail(f"{len(report.failed)} job(s) failed or partly failed: "
              f"{', '.join(report.failed)}; see {report.out / 'summary.md'}")
        return 6
    return 0


def _cmd_nc(args):
    from .nc import run_nc

    return run_nc(args)


def _cmd_robot(args):
    from .robot import run_robot

    return run_robot(args)


def _cmd_process(args):
    from .process import run_process

    return run_process(args)


def _cmd_hub(args):
    from .hub import run_hub

    return run_hub(args)


def _cmd_simulate(args):
    from .simulate import run_simulate

    return run_simulate(args)


def _cmd_rough(args):
    from .rough import run_rough

    return run_rough(args)


def main(argv=None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    never_fail_on_encoding()
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(argv[0] if argv else None)  # only the arguments of the command run
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
        if getattr(args, "threads", False) is False:  # a command without --threads
            return int(args.func(args) or 0)
        with parallel(args.threads) as n:  # every core unless --threads N
            args.threads = n
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
