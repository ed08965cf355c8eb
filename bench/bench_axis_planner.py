"""Benchmark of collision avoidance: the per-pose rotation (paper 004 §3, ``method="rotate"``)
against the axis planner over the whole pass (:mod:`blisk_cam.core.collision.axis_plan`,
``method="plan"``), on the demo blisk (24 blades) and on NASA Rotor 37 patterned to 36
blades.

Set-up (issue 25): Ø12 ball, 15 mm flute, Ø12 shank to 40 mm, Ø32 holder to 100 mm, safety
1 mm, ±2 neighbours — the command line's ``--tool ball --tool-diameter 12 --flute-length 15
--holder "15 6 40 6 40 16 100 16" --safety 1 --blade-count N --collisions avoid``. The demo
path: cusp 0.05, chord 0.05, local axis (lead 0, tilt 0), the hub cone 4 mm out from the hub
(the Ø12 ball does not fit the demo's 3.3 mm fillet); Rotor 37: the README's radial
75° lean, lead 5°, ``--max-tilt 85``.

Printed per case: verify of the planned path (before any avoidance); per method: colliding
share before, unresolved poses (count and share of
the pass poses), the largest turn between consecutive pass poses (degrees, and per mm of
path) and how many turns over the planner's limit have a cut (not unresolved) pose at either
end — the planner jumps only between two unresolved poses, so 0 for it —, the poses
unresolved or at either end of a turn over the planner's limit (the per-pose rotation clears
poses by turning faster than the limit: those poses do not count as resolved), verify's
material left and gouge (mm; bound cusp + chord and chord), the avoidance
wall time and its time per pose. Not a timed test: figures only.

The turn limit every method is judged by is the planner's: the planned turn + 2° per mm of
the tool's path (the ball's centre, ``axis_field.path_steps``), at most 5° per pose
(``--max-turn``; ``CollisionOptions.plan_max_turn``).

Measured on this shared 2-core machine (unresolved pass poses; ms per pass pose, the same
load within a run): demo — rotate 870 (1251 with the poses at its 345 turns over the limit),
the planner with the turn limit everywhere (the default) 824 (max turn between poses 8.6°),
with jumps 565, verify after avoidance 0.048 mm left, 0.017 mm gouge (from the hub cone
itself, where the planned path gouges 0.060 mm before any avoidance: rotate 971 (1420),
planner 887, ``--max-turn 89`` (no per-pose cap) 804 (12.5°)); Rotor 37 ×
36 — rotate 1010 (1268, 222 turns over), the planner 908 (program rows 908, every link
re-routed; 8.3°), with jumps 821; without the cap 850 (15.2°), with jumps 819; 33–38 ms per
pass pose for the planner (Rotor 37, the tree before and after side by side: 37.9 and 36.0)
against 6–14 for rotate. Before the limit was measured along the tool's path (along the
contact points): demo 806, with jumps 581, rotate 1394 counting its turns over that limit;
Rotor 37 1154 (program rows 1166), with jumps 991, rotate 2070 counting.

Run: ``python bench/bench_axis_planner.py [--case demo|r37|both] [--no-verify]
[--methods rotate,plan,plan-jumps]`` (``plan-jumps``: the planner with
``CollisionOptions.turn_jumps``, turns past the limit allowed between two unresolved poses)
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from blisk_cam.core.collision.avoid import run_collisions  # noqa: E402
from blisk_cam.core.collision.axis_field import pass_turn_limits  # noqa: E402
from blisk_cam.core.collision.options import CollisionOptions  # noqa: E402
from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.paths.orientation import consecutive_turn  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.tool.cutter import as_cutter  # noqa: E402
from blisk_cam.core.verify.measure import verify_path  # noqa: E402

HOLDER = ((15.0, 6.0), (40.0, 6.0), (40.0, 16.0), (100.0, 16.0))
DEMO_HUB_LIFT = 4.0  # mm, the demo path's hub cone moved out from the hub (radially)


def case(name):
    """(mesh, PathRequest, blade count, extra collision options)."""
    if name == "demo":
        b = make_demo_blisk()
        mesh = TriMesh.from_arrays(b.blade_vertices, b.blade_faces)
        # the hub cone 4 mm up the blade: the Ø12 ball does not fit the demo's 3.3 mm hub
        # fillet, and from the hub cone itself the planned path gouges 0.060 mm before any
        # avoidance (with 4 mm: 0.017 mm, within the chord)
        c1 = Cone(b.hub_cone.r1 + DEMO_HUB_LIFT, b.hub_cone.z1, b.hub_cone.r2 + DEMO_HUB_LIFT,
                  b.hub_cone.z2)
        req = PathRequest(b.axis, c1, b.tip_cone, tool_type="ball", tool_diameter=12.0,
                          cusp=0.05, chord=0.05)
        return mesh, req, b.blade_count, {}
    from support.blades import nasa_blade

    V, F, c1, c2 = nasa_blade("rotor37")
    mesh = TriMesh.from_arrays(V, F)
    req = PathRequest(Axis(), c1, c2, tool_type="ball", tool_diameter=12.0, cusp=0.05,
                      chord=0.05, axis_mode="radial", radial_tilt=math.radians(75),
                      lead=math.radians(5))
    return mesh, req, 36, {"max_tilt": math.radians(85)}


def turn_figures(planned, path, turn_per_mm, max_turn=None):
    """(largest turn between consecutive pass poses, deg; largest excess over the planner's
    limit — the planned turn + turn_per_mm × the tool path's length (``turn_limits``, the
    one definition the planner and the report read; a closed pass's closing cut included) —,
    deg; turns over that limit; of them, those with a pose not unresolved at either end (the
    others lie inside an unresolved stretch, which is not cut); (n,) bool: the pass poses at
    either end of such a turn; the largest turn the limit adds to a planned turn at one
    pose, deg)."""
    corner = as_cutter(planned.tool).corner_radius
    worst, excess, over, over_cut, at, added = 0.0, 0.0, 0, 0, [], 0.0
    for c0, c in zip(planned.curves, path.curves, strict=True):
        a = np.asarray(c.axis, float)
        mask = np.zeros(len(a), bool)
        at.append(mask)
        if len(a) < 2:
            continue
        idx = np.r_[np.arange(len(a)), 0] if c.closed and len(a) > 2 else np.arange(len(a))
        t = consecutive_turn(a, c.closed)
        lim = pass_turn_limits(c0.cc, c0.normal, c0.axis, c.closed, corner, turn_per_mm,
                               max_turn)
        t0 = consecutive_turn(c0.axis, c.closed)
        added = max(added, float(np.degrees((lim - t0).max())))
        worst = max(worst, float(np.degrees(t.max())))
        excess = max(excess, float(np.degrees((t - lim).max())))
        bad = t > lim + 1e-9
        un = (np.asarray(c.collision["status"]) == 2)[idx]
        over += int(np.sum(bad))
        over_cut += int(np.sum(bad & ~(un[1:] & un[:-1])))
        np.logical_or.at(mask, idx[:-1][bad], True)
        np.logical_or.at(mask, idx[1:][bad], True)
    return worst, excess, over, over_cut, np.concatenate(at), added


def run(name, methods, verify, max_turn=None):
    mesh, req, blades, extra = case(name)
    t = time.perf_counter()
    planned = plan_paths(mesh, req).path
    n = sum(len(c) for c in planned.curves)
    print(f"\n== {name}: {n} pass poses in {len(planned.curves)} passes, "
          f"planned in {time.perf_counter() - t:.1f} s; {blades} blades, Ø12 ball, flute 15, "
          f"holder {HOLDER}")
    if verify:
        t = time.perf_counter()
        vr = verify_path(mesh, planned)
        print(f"  planned (no avoidance) verify: material left {vr.max_material_left:.4f} mm, "
              f"gouge {vr.max_gouge:.4f} mm [{time.perf_counter() - t:.0f} s]", flush=True)
    for method in methods:
        opts = CollisionOptions(mode="avoid", blade_count=blades, flute_length=15.0,
                                holder=HOLDER, safety=1.0, **extra)
        if "method" not in CollisionOptions.__dataclass_fields__:
            print(f"  {method}: not in this tree")
            continue
        extra_opts = {"method": method}
        if method == "plan-jumps":  # the planner with turns past the limit between
            extra_opts = {"method": "plan", "turn_jumps": True}  # two unresolved poses
            if "turn_jumps" not in CollisionOptions.__dataclass_fields__:
                print(f"  {method}: not in this tree")
                continue
        if max_turn is not None and method != "rotate":  # the planner's per-pose cap
            extra_opts["max_turn"] = max_turn
        opts = CollisionOptions(**{**opts.__dict__, **extra_opts})
        t = time.perf_counter()
        path, rep = run_collisions(mesh, planned, options=opts)
        dt = time.perf_counter() - t
        status = np.concatenate([np.asarray(c.collision["status"]) for c in path.curves])
        unres = int(np.sum(status == 2))
        before = rep.n_colliding_before
        # the planner's limit, its per-pose cap included, judges every method
        cap = replace(opts, max_turn=max_turn).plan_max_turn
        worst, excess, over, over_cut, at, added = turn_figures(planned, path, opts.turn_per_mm,
                                                                cap)
        ranges = (path.collision or {}).get("unresolved_ranges") or []
        links = getattr(rep, "links", None) or {}
        print(f"  {method:10s}: colliding before {before} of {rep.n_checked} rows "
              f"({100 * before / rep.n_checked:.1f} %); unresolved pass poses {unres} "
              f"({100 * unres / n:.1f} %) in {len(ranges)} ranges, program rows "
              f"{rep.n_unresolved}; max turn {worst:.2f}°, {over} turns over the limit "
              f"(planned + {math.degrees(opts.turn_per_mm):g}°/mm of tool path, ≤ "
              f"{math.degrees(cap):g}° per pose; it adds up to {added:.2f}° per pose), worst "
              f"by {excess:.2f}°, {over_cut} of them with a pose "
              f"not unresolved at either end; avoidance {dt:.1f} s "
              f"({1e3 * dt / n:.2f} ms per pass pose)", flush=True)
        print(f"          poses unresolved or at a turn over the limit (what the acceptance "
              f"counts against): {int(np.sum((status == 2) | at))} "
              f"({100 * np.sum((status == 2) | at) / n:.1f} %)")
        print(f"          links: {links.get('links_colliding', 0)} colliding, "
              f"{links.get('links_rerouted', 0)} re-routed, "
              f"{links.get('links_unresolved', 0)} unresolved")
        planner = (path.collision or {}).get("planner")
        if planner:
            print(f"          planner: {planner}")
        if (path.collision or {}).get("tool_hint"):
            print(f"          hint: {path.collision['tool_hint']}")
        if verify:
            t = time.perf_counter()
            vr = verify_path(mesh, path)
            print(f"          verify: material left {vr.max_material_left:.4f} mm (bound "
                  f"{req.cusp + req.chord:.3f}), gouge {vr.max_gouge:.4f} mm (bound "
                  f"{req.chord:.3f}) [{time.perf_counter() - t:.0f} s]", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", default="both", choices=("demo", "r37", "both"))
    ap.add_argument("--methods", default="rotate,plan,plan-jumps")
    ap.add_argument("--no-verify", action="store_true")
    ap.add_argument("--max-turn", type=float, default=None, metavar="DEG",
                    help="the planner's per-pose cap on the turn its limit adds to the planned "
                         "one (CollisionOptions.max_turn; default 5°, 89 for practically none)")
    a = ap.parse_args()
    names = ("demo", "r37") if a.case == "both" else (a.case,)
    cap = None if a.max_turn is None else math.radians(a.max_turn)
    for name in names:
        run(name, a.methods.split(","), not a.no_verify, cap)


if __name__ == "__main__":
    main()
