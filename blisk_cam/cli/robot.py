"""The ``robot`` command: paths JSON → robot program (numpy/scipy only, no bpy).

::

    python -m blisk_cam robot --paths paths.json --robot kr120-r2700-angled|ROBOT.toml \\
        --post krl|rapid|pdl2|fanuc-ls --out DIR [--feed MM_MIN] [--force N] \\
        [--samples N] [--max-joint-step DEG] [--min-wrist DEG] [--name NAME] [--lines N] \\
        [--blend MM] [--ptp-speed PERCENT] [--head-rpm N --head-diameter MM
        --contact-width MM --preston KP [--removal FILE.csv]]

Resolves the free angle about the tool axis over the path (:mod:`..core.robot.free_angle`),
prints the figures (minimum wrist-singularity and joint-limit margins, largest joint step) and
writes the main program and its parts into DIR (created if missing; a file there is replaced
only when Blisk CAM wrote it), each atomically. Where the path cannot be run (out of reach,
a joint limit, a singularity, a joint too fast at the feed) it lists the ranges and writes
nothing: exit 1. Progress on stderr.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys

from ..core.errors import BliskCamError
from ..core.post.common import write_atomic, write_program_folder
from ..core.post.gate import collision_gate
from ..core.robot.description import known_robots, load_robot, with_rotary_angle
from ..core.robot.free_angle import FreeAngleOptions, plan_robot
from ..core.robot.polishing import PolishingProcess, removal_per_pose
from ..core.robot.programs import DIALECTS, ProgramOptions, robot_program
from ..core.toolpath.paths_io import read_paths_json
from .flags import PROG, UsageError, finite, whole

__all__ = ["add_robot_arguments", "run_robot"]

def _positive(text):
    v = finite(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got '{text}'")
    return v


def add_robot_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """The arguments of ``robot``."""
    parser.add_argument("--paths", required=True, metavar="FILE",
                        help="paths JSON (version 1) written by 'blisk_cam paths'")
    parser.add_argument("--robot", required=True, metavar="PRESET|FILE.toml",
                        help=f"robot preset ({', '.join(known_robots())}) or a robot TOML")
    parser.add_argument("--post", required=True, type=str.lower, choices=DIALECTS,
                        help="controller language")
    parser.add_argument("--out", required=True, metavar="DIR",
                        help="directory for the main program and its parts")
    parser.add_argument("--feed", type=_positive, default=600.0, metavar="MM_MIN",
                        help="polishing feed along the path, mm/min (default 600)")
    parser.add_argument("--force", type=_positive, default=None, metavar="N",
                        help="contact force setpoint of the force-controlled head, N (written "
                        "in the header)")
    parser.add_argument("--samples", type=whole, default=36, metavar="N",
                        help="free-angle samples per turn (default 36: every 10°)")
    parser.add_argument("--max-joint-step", type=_positive, default=10.0, metavar="DEG",
                        help="largest joint step between two poses, degrees (default 10)")
    parser.add_argument("--min-wrist", type=_positive, default=5.0, metavar="DEG",
                        help="closest approach to the wrist singularity (A5 = 0), degrees "
                        "(default 5)")
    parser.add_argument("--name", default="BLISK", metavar="NAME",
                        help="program name (letters, digits, _; default BLISK)")
    parser.add_argument("--lines", type=whole, default=None, metavar="N",
                        help="motions per part file (default: KRL 1200, RAPID and PDL2 4500, "
                        "Fanuc 9999)")
    parser.add_argument("--blend", type=finite, default=0.5, metavar="MM",
                        help="approximation (blending) distance of the linear moves, mm")
    parser.add_argument("--ptp-speed", type=_positive, default=20.0, metavar="PERCENT",
                        help="joint-move speed to each stroke's start, %% of maximum (default 20)")
    parser.add_argument("--rotary-deg", type=finite, default=None, metavar="DEG",
                        help="angle at which the robot's external rotary (the TOML's [rotary]) "
                        "holds the blisk while the program runs (default: its 'angle')")
    parser.add_argument("--head-rpm", type=_positive, default=None, metavar="N",
                        help="polishing wheel speed, rev/min (with --force, --head-diameter, "
                        "--contact-width, --preston: the Preston removal depth per pass)")
    parser.add_argument("--head-diameter", type=_positive, default=None, metavar="MM",
                        help="polishing wheel diameter, mm")
    parser.add_argument("--contact-width", type=_positive, default=None, metavar="MM",
                        help="contact width across the feed, mm")
    parser.add_argument("--preston", type=_positive, default=None, metavar="KP",
                        help="Preston coefficient of abrasive and alloy, mm²/N")
    parser.add_argument("--removal", default=None, metavar="FILE.csv",
                        help="also write the removal depth at every pose (needs the process "
                        "values above)")
    parser.add_argument("--allow-collisions", action="store_true",
                        help="program a path whose collision check left unresolved poses (the "
                        "header then says how many and where); without it such a path is "
                        "refused")
    return parser


_PROCESS = ("head_rpm", "head_diameter", "contact_width", "preston")


def _process(args):
    """The polishing process of the flags, or None when none of them is given."""
    given = [k for k in _PROCESS if getattr(args, k) is not None]
    if not given and args.removal is None:
        return None
    missing = [k for k in _PROCESS if getattr(args, k) is None]
    if args.force is None:
        missing.insert(0, "force")
    if missing:
        raise UsageError("the polishing process needs " + ", ".join(
            "--" + k.replace("_", "-") for k in missing))
    return PolishingProcess(args.force, args.head_rpm, args.head_diameter, args.contact_width,
                            args.preston, args.feed)


def _removal_csv(process, path) -> str:
    depth = removal_per_pose(process, path)
    rows = ["pose,x_mm,y_mm,z_mm,removal_um"]
    for j, (p, h) in enumerate(zip(path.program.tip, depth, strict=True), 1):
        rows.append(f"{j},{p[0]:.4f},{p[1]:.4f},{p[2]:.4f},{1000 * h:.4f}")
    return "\n".join(rows) + "\n"


def _progress(p):
    print(f"{PROG}: {p.message} [{100 * p.fraction:3.0f}%]", file=sys.stderr, flush=True)


def run_robot(args) -> int:
    """Run the ``robot`` command on parsed ``args``: 0 written, 1 bad input or a path the
    robot cannot run (the ranges on stderr), 2 a bad option value."""
    try:
        if not os.path.isfile(args.paths):
            raise BliskCamError(f"paths file {args.paths} not found")
        robot = load_robot(args.robot)
        if args.rotary_deg is not None:
            robot = with_rotary_angle(robot, math.radians(args.rotary_deg))
        path = read_paths_json(args.paths)
        try:
            opt = FreeAngleOptions(samples=args.samples, feed=args.feed,
                                   max_joint_step=math.radians(args.max_joint_step),
                                   min_wrist=math.radians(args.min_wrist))
            process = _process(args)
            popt = ProgramOptions(name=args.name, feed=args.feed, ptp_percent=args.ptp_speed,
                                  blend=args.blend, force=args.force, lines=args.lines,
                                  process=process)
        except BliskCamError as exc:
            raise UsageError(str(exc)) from None
        # the gate of every export: unresolved collisions refused unless allowed, then marked
        gate = collision_gate(path, bool(args.allow_collisions))
        if gate.warning:
            print(f"{PROG}: warning: {gate.warning}", file=sys.stderr)
        popt = dataclasses.replace(popt, notes=gate.notes)
        plan = plan_robot(robot, path, opt, progress=_progress)
        if not plan.feasible:
            for b in plan.infeasible[:20]:
                print(f"{PROG}: cannot run {b.text()}", file=sys.stderr)
            more = len(plan.infeasible) - 20
            tail = f" (and {more} more)" if more > 0 else ""
            reasons = sorted({b.reason for b in plan.infeasible})
            raise BliskCamError(
                f"{len(plan.infeasible)} stretches of the path cannot be run by {robot.name} "
                f"({', '.join(reasons)}){tail}; no program written. For a wrist singularity "
                "use an angled head; for speed lower --feed; for reach or limits move the part")
        prog = robot_program(plan, args.post, popt, path)
        if os.path.exists(args.out) and not os.path.isdir(args.out):
            raise UsageError(f"--out {args.out}: exists and is not a directory")
        write_program_folder(args.out, prog.files)  # refuses to replace a file not ours
        if args.removal is not None:
            write_atomic(args.removal, _removal_csv(process, path))
    except UsageError as err:
        print(f"{PROG}: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 2
    except (BliskCamError, OSError) as err:
        print(f"{PROG}: error: {' '.join(str(err).split())}", file=sys.stderr)
        return 1
    st = plan.stats
    print(f"{prog.summary()} in {args.out}")
    print(f"robot {robot.name}: {len(plan.strokes)} strokes, {plan.n_poses} poses; min wrist-"
          f"singularity margin {st['min_wrist_deg']:.2f}°, min joint-limit margin "
          f"{st['min_limit_margin_deg']:.2f}°, max joint step {st['max_joint_step_deg']:.2f}°, "
          f"max joint speed {100 * st['max_speed_ratio']:.0f}% of its limit at "
          f"{args.feed:g} mm/min")
    if process is not None:
        print(f"polishing: {process.summary()}")
    return 0
