"""The ``nc`` command: paths JSON → NC program (numpy/scipy only, no bpy).

::

    python -m blisk_cam nc --paths paths.json --machine ac-trunnion|FILE.toml \\
        --post linuxcnc|fanuc|siemens|heidenhain|apt --out FILE [--blades N] \\
        [--feed MM_MIN] [--spindle RPM] [--tool-number T] [--coolant on|off] \\
        [--interpolation constant-error --max-error MM | --interpolation chord \\
         --chord-height MM] [--report FILE.json]

:func:`add_nc_arguments` fills a (sub)parser, :func:`run_nc` runs it: exit 0 on success, 1 with
one line on stderr (``blisk_cam: error: ...``) for bad input or an unreachable pose (naming the
pose, the axis and the value).
"""

from __future__ import annotations

import argparse
import math
import os
import sys

from .core.errors import BliskCamError

__all__ = ["add_nc_arguments", "run_nc", "main"]

PROG = "blisk_cam"


def _positive(text):
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number")
    return v


def _count(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be ≥ 1")
    return v


def _tool_number(text):
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be ≥ 0")
    return v


def add_nc_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add the ``nc`` options to ``parser`` (a subparser of the main CLI)."""
    from .core.post import POSTS

    parser.add_argument("--paths", required=True, metavar="FILE", help="paths JSON (version 1)")
    parser.add_argument("--machine", required=True, metavar="PRESET|FILE.toml",
                        help="machine preset (ac-trunnion, bc-trunnion, bc-head-table) or TOML")
    parser.add_argument("--post", required=True, type=str.lower, metavar="POST",
                        help="one of " + ", ".join(POSTS))
    parser.add_argument("--out", required=True, metavar="FILE", help="NC program to write")
    parser.add_argument("--blades", type=_count, default=1, metavar="N",
                        help="repeat the blade's moves for N blades (k·360°/N)")
    parser.add_argument("--feed", type=_positive, default=1000.0, metavar="MM_MIN")
    parser.add_argument("--spindle", type=_positive, default=10000.0, metavar="RPM")
    parser.add_argument("--tool-number", type=_tool_number, default=1, metavar="T")
    parser.add_argument("--coolant", choices=("on", "off"), default="on")
    parser.add_argument("--interpolation", choices=("constant-error", "chord"), default=None,
                        help="choose the cut blocks: constant-error (paper 002: every block's "
                        "machining error bound ≤ --max-error) or chord (tip chord height ≤ "
                        "--chord-height); default: the planned poses, linearized")
    parser.add_argument("--max-error", type=_positive, default=None, metavar="MM",
                        help="permissible machining error [dM] of constant-error blocks")
    parser.add_argument("--chord-height", type=_positive, default=None, metavar="MM",
                        help="chord height of chord blocks")
    parser.add_argument("--report", default=None, metavar="FILE.json",
                        help="write the export report (with the interpolation's) as JSON")
    return parser


def run_nc(args) -> int:
    """Run the ``nc`` command on parsed ``args``; prints a summary on stdout, returns the exit
    status (0 ok, 1 bad input with one line on stderr)."""
    from .core.nc import export_nc
    from .core.paths_io import read_paths_json
    from .core.post.blocks import NcOptions

    try:
        if not os.path.isfile(args.paths):
            raise BliskCamError(f"paths file {args.paths} not found")
        path = read_paths_json(args.paths)
        interp = getattr(args, "interpolation", None)
        max_error = getattr(args, "max_error", None)
        chord_height = getattr(args, "chord_height", None)
        if interp == "constant-error" and max_error is None:
            raise BliskCamError("--interpolation constant-error needs --max-error MM")
        if interp == "chord" and chord_height is None:
            raise BliskCamError("--interpolation chord needs --chord-height MM")
        if interp is None and (max_error is not None or chord_height is not None):
            raise BliskCamError("--max-error/--chord-height need --interpolation")
        opts = NcOptions(
            feed=args.feed, spindle=args.spindle, tool_number=args.tool_number,
            coolant=args.coolant == "on", blades=args.blades,
            blade_name=os.path.splitext(os.path.basename(args.paths))[0],
            interpolation=interp, max_error=max_error, chord_height=chord_height,
        )
        report = export_nc(path, args.machine, args.post, opts, args.out)
        if getattr(args, "report", None):
            _write_report(report, args.report)
    except (BliskCamError, OSError) as err:
        msg = " ".join(str(err).split())
        print(f"{PROG}: error: {msg}", file=sys.stderr)
        return 1
    print(report.summary())
    return 0


def _write_report(report, filename):
    import json

    d = {k: getattr(report, k) for k in ("filename", "post", "machine", "blocks", "inserted",
                                         "minutes", "max_deviation", "blades", "indexed")}
    d["axis_ranges"] = {k: list(v) for k, v in report.axis_ranges.items()}
    if report.interpolation is not None:
        d["interpolation"] = report.interpolation.as_dict()
    with open(filename, "w", encoding="utf-8") as fh:
        json.dump(d, fh, indent=1)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"{PROG}: error: {message}", file=sys.stderr)
        raise SystemExit(2)


def main(argv=None) -> int:
    """Stand-alone entry (``python -m blisk_cam.nc_cli ...``) until the lead wires ``nc`` into
    the main CLI."""
    parser = add_nc_arguments(_Parser(prog=f"{PROG} nc"))
    return run_nc(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
