"""The ``rough`` command: channel roughing of a blisk from its blank (numpy/scipy only).

::

    python -m blisk_cam rough --part MESH [--hub-profile CSV] --blade-count N \\
        --stock (PROFILE.csv | MESH | envelope:MM | STATE.npz) \\
        --tool flat|bull|ball --tool-diameter MM [--corner-radius MM] \\
        --levels from-hub|from-shroud|morph (--depth-per-cut MM | --level-scallop MM) \\
        [--max-depth-per-cut MM] --stepover MM \\
        --pattern zigzag|plunge|trochoid [--order gap|level] [--floor-band-step 0.5] \\
        --allowance 0.5 [--hub-allowance MM] \\
        --out rough.json \\
        [--nc FILE --machine PRESET --post POST] [--lead DEG] [--side-tilt DEG] ...

``--part``, ``--hub-profile``, ``--blade-count`` and ``--stock`` mean what they mean for
``simulate`` (the same readers). The paths JSON holds the program of one gap (between blade
0 and blade 1) with ``"operation": "rough"``; ``nc`` and ``--nc`` repeat it for the N gaps,
``simulate`` runs it on the blank. With ``--order level`` each level is linked alone and the
posts run level 1 in every gap, then level 2 … (``stats.level_blocks``).
Exit 0 on success, 1 on bad input (one line on stderr), 2 on a usage error. Progress on
stderr.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from ..core.errors import BliskCamError
from .flags import PROG, UsageError, add_part_arguments, check_file_roles, positive
from .nc import add_nc_arguments
from .simulate import _part, _stock

__all__ = ["add_rough_arguments", "run_rough"]


def _non_negative(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number ≥ 0, got '{text}'") from None
    if not (math.isfinite(v) and v >= 0):
        raise argparse.ArgumentTypeError(f"expected a number ≥ 0, got '{text}'")
    return v


def _number(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got '{text}'")
    return v


def add_rough_arguments(parser: argparse.ArgumentParser):
    """Add the ``rough`` options to ``parser``."""
    from ..core.channel.gaps import GAP_ORDERS
    from ..core.channel.levels import LEVEL_MODES
    from ..core.process.roughing import BODY_MEETS_STOCK, PATTERNS

    add_part_arguments(parser)
    parser.add_argument("--stock", required=True, metavar="BLANK",
                        help="the blank: a closed (r, z) profile CSV, a closed mesh, "
                        "'envelope:MM' (the part's envelope plus MM) or a stock state .npz")
    parser.add_argument("--resolution", type=positive, default=0.25, metavar="MM",
                        help="resolution of the blank's dexels, mm (default 0.25)")
    g = parser.add_argument_group("Roughing")
    g.add_argument("--tool", required=True, type=str.lower, choices=("flat", "bull", "ball"),
                   help="cutter type (DIN 66215)")
    g.add_argument("--tool-diameter", required=True, type=positive, metavar="MM")
    g.add_argument("--corner-radius", type=_non_negative, default=None, metavar="MM",
                   help="corner radius of a bull-nose cutter, mm")
    g.add_argument("--flute-length", type=positive, default=None, metavar="MM",
                   help="cutting length above the tip, mm (default 3 × diameter)")
    g.add_argument("--neck-length", type=_non_negative, default=None, metavar="MM",
                   help="extra shank length between the flute and the holder, mm (default 0: "
                   "the holder 2 × diameter above the flute)")
    g.add_argument("--holder-diameter", type=positive, default=None, metavar="MM",
                   help="holder diameter, mm (default 2.5 × shank)")
    g.add_argument("--levels", type=str.lower, choices=LEVEL_MODES, default="from-hub",
                   help="level surfaces: offset from the hub, from the shroud, or morphed "
                   "hub → shroud (default from-hub)")
    depth = g.add_mutually_exclusive_group(required=True)
    depth.add_argument("--depth-per-cut", type=positive, default=None, metavar="MM",
                       help="constant largest step between levels, mm")
    depth.add_argument("--level-scallop", type=positive, default=None, metavar="MM",
                       help="instead, levels spaced from the blade walls' slope so that the "
                       "step cusp a level leaves on them is at most MM (the worst point of "
                       "each level decides; capped by --max-depth-per-cut)")
    g.add_argument("--max-depth-per-cut", type=positive, default=None, metavar="MM",
                   help="with --level-scallop: the largest step between levels, mm (default: "
                   "the flute length)")
    g.add_argument("--stepover", required=True, type=positive, metavar="MM",
                   help="largest step across the channel, mm (≤ the tool diameter)")
    g.add_argument("--pattern", type=str.lower, choices=PATTERNS, default="zigzag",
                   help="zigzag: passes along the channel stepped across it; plunge: feeds "
                   "along the tool axis; trochoid: loops across the channel stepped along it "
                   "by --stepover, then a pass along each wall (default zigzag)")
    g.add_argument("--order", type=str.lower, choices=GAP_ORDERS, default="gap",
                   help="gap: every level of a gap, then the next gap; level: a level in "
                   "every gap, then the next level (each level linked alone; the post "
                   "interleaves the gaps) (default gap)")
    g.add_argument("--body-meets-stock", type=str.lower, choices=BODY_MEETS_STOCK,
                   default="leave-out",
                   help="where the tool body would meet the stock the levels above left: "
                   "leave-out that stretch with a warning naming the level (default), or flag "
                   "it: kept, its rows marked as unresolved collisions (--nc then refuses them "
                   "unless --allow-collisions)")
    g.add_argument("--floor-band-step", type=_non_negative, default=0.5, metavar="MM",
                   help="with --axis blades: rows of surface-driven passes on the blades' "
                   "allowance offset every MM from the hub to the level above, which keep the "
                   "level-step cusp there too (0: none, shorter but leaves more on the walls "
                   "by the hub) (default 0.5)")
    g.add_argument("--allowance", type=_non_negative, default=0.5, metavar="MM",
                   help="material left on the blades, mm (default 0.5)")
    g.add_argument("--hub-allowance", type=_non_negative, default=None, metavar="MM",
                   help="material left on the hub, mm (default: --allowance)")
    g.add_argument("--lead", type=_number, default=0.0, metavar="DEG",
                   help="tool axis tilt from radial toward +z, degrees (default 0)")
    g.add_argument("--side-tilt", type=_number, default=0.0, metavar="DEG",
                   help="tool axis tilt from radial toward +θ, degrees (default 0)")
    g.add_argument("--axis", type=str.lower, choices=("blades", "radial"), default="blades",
                   help="tool axis through the channel: leaning with the blades' mean camber "
                   "surface (default; the floor level radial) or radial; --lead and "
                   "--side-tilt are added to either")
    g.add_argument("--max-turn", type=positive, default=2.0, metavar="DEG",
                   help="largest turn of the tool axis between consecutive cutting poses, "
                   "degrees (default 2)")
    g.add_argument("--safety", type=_non_negative, default=0.5, metavar="MM",
                   help="distance of the shank and holder from the allowance, mm (default 0.5)")
    g.add_argument("--rapid-feed", type=positive, default=10000.0, metavar="MM_MIN",
                   help="rapid traverse for the time estimate, mm/min (default 10000)")
    parser.add_argument("--out", required=True, metavar="rough.json",
                        help="the paths JSON (\"operation\": \"rough\")")
    parser.add_argument("--nc", metavar="FILE", default=None,
                        help="also post the program for all N gaps (needs --machine, --post)")
    add_nc_arguments(parser, with_paths=False)
    return parser


def _check(args):
    if args.blade_count < 1:
        raise UsageError(f"--blade-count must be at least 1, got {args.blade_count}")
    if args.nc and not (args.machine and args.post):
        raise UsageError("--nc needs --machine (preset or TOML) and --post (controller)")
    if (args.machine or args.post) and not args.nc:
        raise UsageError("--machine/--post post the program with --nc FILE; give --nc")
    if args.max_depth_per_cut is not None and args.level_scallop is None:
        raise UsageError("--max-depth-per-cut caps the steps of --level-scallop; with "
                         "--depth-per-cut (constant steps) leave it out")
    if args.tool == "bull" and not args.corner_radius:
        raise UsageError("--tool bull needs --corner-radius (0 < r < diameter/2)")
    if args.tool != "bull" and args.corner_radius:
        raise UsageError(f"--corner-radius is for a bull-nose cutter, not --tool {args.tool}")
    stock_file = None if args.stock.startswith("envelope:") else args.stock
    check_file_roles([("--part", args.part), ("--hub-profile", args.hub_profile),
                      ("--stock", stock_file)],
                     [("--out", args.out), ("--nc", args.nc)])
    for opt in ("out", "nc"):
        value = getattr(args, opt)
        if value is not None and not Path(value).expanduser().resolve().parent.is_dir():
            raise UsageError(f"--{opt} {value}: the directory does not exist")
    for f in [args.part] + ([args.hub_profile] if args.hub_profile else []):
        if not Path(f).is_file():
            raise BliskCamError(f"file {f} not found")


def run_rough(args) -> int:
    """Run the ``rough`` command; returns the exit status."""
    from ..core.process.operation import iter_run_operation
    from ..core.process.roughing import RoughingOperation, RoughRequest
    from ..core.tool.cutter import Cutter
    from ..core.toolpath.paths_io import write_paths_json

    def log(msg):
        print(f"{PROG} rough: {msg}", file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    _check(args)
    if args.stock.startswith("allowance:"):
        raise UsageError("--stock allowance:MM is the part plus an allowance, already rough; "
                         "give the blank (a profile, a mesh, envelope:MM or a saved state)")
    kw = {k: v for k, v in (("h", args.flute_length), ("neck_length", args.neck_length),
                            ("holder_diameter", args.holder_diameter)) if v is not None}
    cutter = Cutter.from_spec(args.tool, 0.5 * args.tool_diameter, args.corner_radius, **kw)
    part = _part(args, log)
    stock = _stock(args, part)
    log(f"blank: {stock.n_theta} × {stock.n_z} rays at {stock.resolution:g} mm")
    req = RoughRequest(
        tool=cutter, stepover=args.stepover, depth_per_cut=args.depth_per_cut,
        levels=args.levels, pattern=args.pattern, allowance=args.allowance,
        hub_allowance=args.hub_allowance, lead=math.radians(args.lead),
        side_tilt=math.radians(args.side_tilt), safety=args.safety,
        feed=args.feed or 1000.0, plunge_feed=args.approach_feed or None,
        rapid_feed=args.rapid_feed, spindle=args.spindle,
        follow_blades=args.axis == "blades", max_turn=math.radians(args.max_turn),
        order=args.order, floor_band_step=args.floor_band_step,
        level_scallop=args.level_scallop, max_depth_per_cut=args.max_depth_per_cut,
        body_meets_stock=args.body_meets_stock)
    gen = iter_run_operation(RoughingOperation(), part, req, stock)
    while True:
        try:
            pr = next(gen)
        except StopIteration as stop:
            result = stop.value
            break
        log(f"{100 * pr.fraction:3.0f} % {pr.message}")
    path = result.path
    write_paths_json(path, Path(args.out).expanduser())
    s = path.stats
    for w in path.warnings:
        print(f"warning: {w}")
    print(f"wrote {args.out}: {s['levels']} levels, {s['passes']} passes, {s['rows']} rows; "
          f"estimated {s['machining_time_min_gap']:.1f} min per gap, "
          f"{s['machining_time_min_all_gaps']:.1f} min for the {s['gaps']} gaps "
          f"(by {s['order']}); axis "
          f"{s['axis']}, largest turn between cutting poses {s['max_axis_turn_deg']:.2f}°; "
          f"{time.perf_counter() - t0:.1f} s")
    if args.nc:
        from .nc import export_from_args

        export_from_args(path, args, Path(args.nc).expanduser().resolve(),
                         Path(args.part).stem + "_rough")
    return 0
