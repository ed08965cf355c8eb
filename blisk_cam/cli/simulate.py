"""The ``simulate`` command: material removal of programs on a blisk's stock, the deviation
map as the verdict (numpy/scipy only, no bpy).

::

    python -m blisk_cam simulate --part MESH [--hub-profile CSV] --blade-count N \\
        --stock (PROFILE.csv | MESH | allowance:MM | envelope:MM | STATE.npz) \\
        --program PATHS.json [PATHS2.json ...] [--resolution 0.05] --out REPORT.json \\
        [--deviation PART.ply] [--stock-mesh STOCK.stl] [--save-stock STATE.npz] \\
        [--gouge-tolerance MM]

``--part`` is the whole blisk (split into hub and blades, N checked), or with
``--hub-profile`` one blade. Exit 0 when the verdict passes, 5 when it fails (a gouge beyond
the tolerance or a crash: a rapid or the tool body removing material), 1 on bad input, 2 on a
usage error. Progress on stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from ..core.errors import BliskCamError
from ..core.files import write_atomic
from .flags import PROG, UsageError, add_part_arguments

__all__ = ["add_simulate_arguments", "run_simulate"]

EXIT_VERDICT_FAILED = 5


def add_simulate_arguments(parser: argparse.ArgumentParser):
    """Add the ``simulate`` options to ``parser``."""
    add_part_arguments(parser)
    parser.add_argument("--stock", required=True, metavar="BLANK",
                        help="the blank: a closed (r, z) profile CSV, a closed mesh, "
                        "'allowance:MM' (the part plus MM), 'envelope:MM' (the part's envelope "
                        "plus MM) or a stock state .npz saved by --save-stock")
    parser.add_argument("--program", required=True, nargs="+", metavar="PATHS.json",
                        help="paths JSON files with linked programs, run in this order")
    parser.add_argument("--resolution", type=float, default=0.05, metavar="MM",
                        help="stock resolution, mm (default 0.05)")
    parser.add_argument("--gouge-tolerance", type=float, default=None, metavar="MM",
                        help="largest gouge that passes, mm (default: the programs' largest "
                        "chord tolerance + the resolution)")
    parser.add_argument("--out", required=True, metavar="REPORT.json",
                        help="the summary and verdict (JSON)")
    parser.add_argument("--deviation", metavar="PART.ply", default=None,
                        help="the part mesh with a per-vertex float 'deviation' (mm)")
    parser.add_argument("--stock-mesh", metavar="STOCK.stl", default=None,
                        help="the remaining stock of one sector as an STL skin of its dexels")
    parser.add_argument("--save-stock", metavar="STATE.npz", default=None,
                        help="save the stock after the programs (the next operation's --stock)")
    return parser


def _check_args(args):
    if not (0.005 <= args.resolution <= 10.0):
        raise UsageError(f"--resolution must be in [0.005, 10] mm, got {args.resolution:g}")
    if args.blade_count < 1:
        raise UsageError(f"--blade-count must be at least 1, got {args.blade_count}")
    if args.gouge_tolerance is not None and not args.gouge_tolerance >= 0:
        raise UsageError(f"--gouge-tolerance must be ≥ 0 mm, got {args.gouge_tolerance:g}")
    inputs = {Path(p).expanduser().resolve() for p in [args.part, *args.program]
              + ([args.hub_profile] if args.hub_profile else [])}
    if ":" not in args.stock or os.path.exists(args.stock):
        inputs.add(Path(args.stock).expanduser().resolve())
    outs = [o for o in (args.out, args.deviation, args.stock_mesh, args.save_stock) if o]
    for o in outs:
        if Path(o).expanduser().resolve() in inputs:
            raise UsageError(f"output {o} is also an input; choose another file name")
    for f in [args.part, *args.program] + ([args.hub_profile] if args.hub_profile else []):
        if not os.path.isfile(f):
            raise BliskCamError(f"file {f} not found")


def _part(args, log):
    from ..core.geometry.mesh_io import read_mesh, read_trimesh
    from ..core.part.model import part_from_blade, read_rz_csv, split_blisk_mesh

    if args.hub_profile:
        # welded: an STL's triangle soup has no boundary loops to close the blade on (a
        # binary STL welded as it is read, no float64 soup)
        mesh = read_trimesh(args.part)
        return part_from_blade(mesh.V, mesh.F, read_rz_csv(args.hub_profile), args.blade_count)
    V, F = read_mesh(args.part)
    split = split_blisk_mesh(V, F, args.blade_count)
    log(f"part: {len(split.hub_faces)} hub faces, {len(split.blade_faces)} blade faces, "
        f"{split.blade_count} blades")
    return split.part


def _stock(args, part):
    from ..core.stock.blank import is_part_based, stock_from_spec

    spec = args.stock
    if is_part_based(spec):
        kind, _, value = spec.partition(":")
        try:
            float(value)
        except ValueError:
            raise UsageError(f"--stock {spec}: expected a number of mm after '{kind}:'") from None
    return stock_from_spec(spec, part, args.resolution)


def run_simulate(args) -> int:
    """Run the ``simulate`` command; returns the exit status (0 passed, 5 verdict failed)."""
    from ..core.runtime import parallel
    from ..core.stock.deviation import ply_bytes, stl_bytes, stock_skin
    from ..core.stock.simulation import iter_simulate
    from ..core.toolpath.paths_io import read_paths_json

    def log(msg):
        print(f"{PROG} simulate: {msg}", file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    _check_args(args)
    part = _part(args, log)
    paths = [read_paths_json(p) for p in args.program]
    stock = _stock(args, part)
    log(f"stock: {stock.n_theta} × {stock.n_z} rays at {stock.resolution:g} mm, "
        f"{stock.volume():.1f} mm³ in one sector")
    gen = iter_simulate(part, stock, paths, gouge_tolerance=args.gouge_tolerance)
    last = -1.0
    while True:
        try:
            with parallel(args.threads):  # the compiled removal kernel: --threads (every core)
                pr = next(gen)
        except StopIteration as stop:
            sim = stop.value
            break
        if pr.fraction - last >= 0.05 or pr.fraction >= 1.0:
            log(f"{100 * pr.fraction:3.0f} % {pr.message}")
            last = pr.fraction
    summary = dict(sim.summary)
    summary["seconds"] = round(time.perf_counter() - t0, 3)
    summary["programs"] = [str(p) for p in args.program]
    write_atomic(Path(args.out).expanduser(),
                        (json.dumps(summary, indent=1) + "\n").encode("utf-8"))
    if args.deviation:
        write_atomic(Path(args.deviation).expanduser(),
                            ply_bytes(sim.V, sim.F, sim.deviation, sim.judged))
    if args.stock_mesh:
        Vs, Fs = stock_skin(sim.stock)
        write_atomic(Path(args.stock_mesh).expanduser(), stl_bytes(Vs, Fs))
    if args.save_stock:
        sim.stock.save(Path(args.save_stock).expanduser())
    dv = summary["deviation_mm"]
    print(f"wrote {args.out}: removed {summary['volume_removed_mm3']['sector']:.1f} mm³ per "
          f"sector, left max {dv['max_left']:.3f} mm (p95 {dv['p95_left']:.3f}), gouge max "
          f"{dv['max_gouge']:.3f} mm"
          + (f" into the allowance {dv['allowance']:g} mm" if dv.get("allowance") else "")
          + f" (tolerance {dv['gouge_tolerance']:.3f}), "
          f"{len(summary['crashes'])} crash(es), {summary['seconds']:.1f} s"
          + (f"; {dv['not_judged_area_mm2']:.1f} mm² below the stock's resolution not judged"
             if dv.get("not_judged_area_mm2") else ""))
    if not summary["passed"]:
        why = []
        if summary["crashes"]:
            c = summary["crashes"][0]
            why.append(f"{len(summary['crashes'])} crash(es), first at row {c['row']} "
                       f"({c['kind']}, {c['move']} move)")
        if dv["max_gouge"] > dv["gouge_tolerance"]:
            why.append(f"gouge {dv['max_gouge']:.3f} mm at {dv['max_gouge_at_mm']} beyond the "
                       f"tolerance {dv['gouge_tolerance']:.3f} mm")
        print(f"{PROG}: verdict: FAILED — " + "; ".join(why), file=sys.stderr)
        return EXIT_VERDICT_FAILED
    print("verdict: passed")
    return 0
