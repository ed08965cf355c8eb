"""The ``hub`` command: hub finishing or fillet finishing of a blisk (numpy/scipy only).

::

    python -m blisk_cam hub --part MESH [--hub-profile CSV] --blade-count N \\
        [--operation hub|fillet] --tool-diameter MM (--stepover MM | --scallop MM) \\
        [--ring-width MM (--ring-stepover MM | --ring-scallop MM)] [--extend MM] \\
        [--lead DEG] [--tilt DEG] [--axis channel|normal] [--allowance MM] [--gaps one|all] \\
        [--fillet-radius MM --layers K] [--holder "Z R ..."] --out PATHS.json \\
        [--nc FILE --machine PRESET --post POST]

``--part`` is read as ``simulate`` reads it (the whole blisk split into hub and blades, or
one blade with ``--hub-profile``). The paths JSON carries ``"operation": "hub-finish"`` or
``"fillet-finish"`` and a linked program, so ``nc`` and ``simulate`` read it. With ``--gaps
one`` (default) the file holds gap 0 (blade 0 for fillets) and ``nc --blade-count N`` repeats
it for every blade; ``--gaps all`` writes all N. Exit 0, 1 on bad input (one line), 2 on a
usage error. Lengths mm, angles degrees.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from copy import copy

from ..core.errors import BliskCamError
from .flags import PROG, UsageError, add_part_arguments, check_file_roles, finite, positive

__all__ = ["add_hub_arguments", "run_hub"]


def _non_negative(text):
    value = finite(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"expected a number ≥ 0, got '{text}'")
    return value


def add_hub_arguments(parser: argparse.ArgumentParser):
    """Add the ``hub`` options to ``parser``."""
    from .nc import add_nc_arguments

    add_part_arguments(parser)
    parser.add_argument("--operation", choices=("hub", "fillet"), default="hub",
                        help="hub: the hub between two blades; fillet: loops along the "
                        "fillet around the blade root (default hub)")
    parser.add_argument("--tool-diameter", required=True, type=positive, metavar="MM",
                        help="ball diameter, mm")
    sp = parser.add_mutually_exclusive_group()
    sp.add_argument("--stepover", type=positive, metavar="MM", help="distance between passes")
    sp.add_argument("--scallop", type=positive, metavar="MM",
                    help="scallop height on the hub (the stepover follows its curvature)")
    parser.add_argument("--ring-width", type=_non_negative, default=0.0, metavar="MM",
                        help="ring beside each blade root with its own spacing (default 0)")
    rs = parser.add_mutually_exclusive_group()
    rs.add_argument("--ring-stepover", type=positive, metavar="MM")
    rs.add_argument("--ring-scallop", type=positive, metavar="MM")
    parser.add_argument("--extend", type=_non_negative, default=5.0, metavar="MM",
                        help="passes extended past the leading and trailing edges (default 5)")
    parser.add_argument("--lead", type=finite, default=10.0, metavar="DEG",
                        help="tool axis leaned along the feed, degrees (default 10: the ball "
                        "never cuts at its tip)")
    parser.add_argument("--tilt", type=finite, default=None, metavar="DEG",
                        help="tool axis tilted across the feed, degrees: toward the channel's "
                        "middle (hub, default 0) or away from the wall (fillet, default 20)")
    parser.add_argument("--axis", choices=("channel", "normal"), default="channel",
                        help="hub: aim the tool axis through the channel at the blade tips "
                        "(default) or lean it from the hub normal")
    parser.add_argument("--aim-spread", type=_non_negative, default=0.3, metavar="F",
                        help="hub, --axis channel: how far across the tips' gap the outer "
                        "passes aim, 0 … 1 (default 0.3)")
    parser.add_argument("--allowance", type=_non_negative, default=0.0, metavar="MM",
                        help="distance kept from the blades (default 0)")
    parser.add_argument("--hub-allowance", type=_non_negative, default=0.0, metavar="MM",
                        help="hub: stock left on the hub, mm (default 0; e.g. 0.1 to "
                        "semi-finish it: the passes run on the hub offset by it)")
    parser.add_argument("--chord", type=positive, default=0.05, metavar="MM",
                        help="chord tolerance (default 0.05)")
    parser.add_argument("--gaps", choices=("one", "all"), default="one",
                        help="gap 0 only (nc repeats it per blade) or all N (default one)")
    parser.add_argument("--fillet-radius", type=positive, default=None, metavar="MM",
                        help="fillet: the fillet radius (the ball must be smaller)")
    parser.add_argument("--layers", type=int, default=1, metavar="K",
                        help="fillet: loops across the fillet (1: the lower edge only)")
    parser.add_argument("--holder", metavar='"Z R Z R ..."', default=None,
                        help="body profile above the flute (mm; default: the cutter's shank "
                        "and holder)")
    parser.add_argument("--flute-length", type=positive, default=None, metavar="MM")
    parser.add_argument("--safety", type=_non_negative, default=1.0, metavar="MM",
                        help="clearance the shank and holder keep from the blades (default 1)")
    parser.add_argument("--collisions", choices=("check", "off"), default="check")
    parser.add_argument("--out", required=True, metavar="PATHS.json", help="paths JSON")
    parser.add_argument("--nc", metavar="FILE", default=None,
                        help="also post an NC program (needs --machine and --post)")
    add_nc_arguments(parser, with_paths=False)
    return parser


def _request(args):
    from ..core.process.hub_finish import HubRequest
    from ..core.tool.assembly import holder_profile

    fillet = args.operation == "fillet"
    if not fillet and args.stepover is None and args.scallop is None:
        raise UsageError("give the hub spacing: --stepover MM or --scallop MM")
    if fillet and args.hub_allowance:
        raise UsageError("--hub-allowance is for hub finishing: the fillet pass leaves no "
                         "stock on the hub")
    if fillet and args.fillet_radius is None:
        raise UsageError("--operation fillet needs --fillet-radius MM (the ball must be "
                         "smaller than the fillet)")
    # the fillet's axis leans off the wall by itself when aimed through the channel; with the
    # hub normal as reference it needs a tilt away from the blade
    tilt = args.tilt if args.tilt is not None else (
        20.0 if fillet and args.axis == "normal" else 0.0)
    return HubRequest(
        tool_diameter=args.tool_diameter, stepover=args.stepover, scallop=args.scallop,
        ring_width=args.ring_width, ring_stepover=args.ring_stepover,
        ring_scallop=args.ring_scallop, extend=args.extend, lead=math.radians(args.lead),
        tilt=math.radians(tilt), axis_mode=args.axis, aim_spread=args.aim_spread,
        allowance=args.allowance, hub_allowance=args.hub_allowance, chord=args.chord,
        gaps=args.gaps,
        collisions=args.collisions, flute_length=args.flute_length,
        holder=holder_profile(args.holder, "--holder") if args.holder else None,
        safety=args.safety, fillet_radius=args.fillet_radius, layers=args.layers)


def run_hub(args) -> int:
    """Run the ``hub`` command; returns the exit status."""
    from ..core.process.fillet_finish import FILLET_FINISH
    from ..core.process.hub_finish import HUB_FINISH
    from ..core.process.operation import iter_run_operation
    from ..core.toolpath.paths_io import write_paths_json
    from .simulate import _part

    def log(msg):
        print(f"{PROG} hub: {msg}", file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    if args.blade_count < 2:
        raise UsageError(f"--blade-count must be at least 2 (a gap between two blades), got "
                         f"{args.blade_count}")
    if args.nc and not (args.machine and args.post):
        raise UsageError("--nc needs --machine and --post")
    if not 0.0 <= args.aim_spread <= 1.0:
        raise UsageError(f"--aim-spread must lie in [0, 1], got {args.aim_spread:g}")
    check_file_roles([("--part", args.part), ("--hub-profile", args.hub_profile)],
                     [("--out", args.out), ("--nc", args.nc)])
    for f in [args.part] + ([args.hub_profile] if args.hub_profile else []):
        if not os.path.isfile(f):
            raise BliskCamError(f"file {f} not found")
    req = _request(args)
    part = _part(args, log)
    op = FILLET_FINISH if args.operation == "fillet" else HUB_FINISH
    gen = iter_run_operation(op, part, req)
    last = ""
    while True:
        try:
            pr = next(gen)
        except StopIteration as stop:
            result = stop.value
            break
        if pr.message != last:
            log(pr.message)
            last = pr.message
    path = result.path
    write_paths_json(path, args.out)
    s = path.stats
    print(f"wrote {args.out}: {path.operation}, {s['curves']} passes, {s['poses']} poses, "
          f"{s['gaps']} gap(s); clearance from the blades ≥ "
          f"{min(s['clearance_blade0_min_mm'], s.get('clearance_blade1_min_mm', math.inf)):.3f}"
          f" mm" + (f", body clearance ≥ {s['body_clearance_min_mm']:.2f} mm"
                    if "body_clearance_min_mm" in s else "")
          + (f", scallop ≈ {s['scallop_estimate_mm']:.3f} mm" if "scallop_estimate_mm" in s
             else "") + f", {time.perf_counter() - t0:.1f} s")
    for w in path.warnings:
        print(f"{PROG}: warning: {w}", file=sys.stderr)
    if args.nc:
        from .nc import export_from_args, machine_of

        nc_args = copy(args)
        nc_args.blade_count = 1 if args.gaps == "all" else args.blade_count
        nc_args.machine = machine_of(args)
        export_from_args(path, nc_args, args.nc, os.path.splitext(os.path.basename(args.out))[0])
    return 0
