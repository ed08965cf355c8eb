"""Hub finishing (issue 24) on NASA Rotor 37 patterned to 36 blades and on the demo blisk:
plan, then run the program on a stock of the part + 0.3 mm (radial dexels) and read the
scallop left on the hub between the first and the last pass, the gouge and the crashes.

Set-up: Rotor 37's blade (tests/data/blades) with its hub cone extended 15 mm each way as
the hub profile; Ø4 ball, scallop 0.2 mm, passes 5 mm past the edges, allowance 0.35 mm from
the blades, a slim Ø4 × 100 mm shank then a Ø20 holder; stock resolution 0.2 mm. The demo:
Ø6 ball, scallop 0.2 mm, the cutter's own shank and holder.

Printed: passes, poses, the ball's clearance from both blades, the tool body's clearance,
the planning time; then the simulation's crashes, largest gouge and the material left on the
hub in the channel (max, p99) against the target + resolution. Figures only, not a test.

Run: ``python bench/bench_hub.py [--case r37|demo|both] [--resolution MM]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


def _part(case):
    from blisk_cam.core.geometry.mesh import TriMesh
    from blisk_cam.core.geometry.mesh_io import read_mesh
    from blisk_cam.core.part.blisk import make_demo_blisk
    from blisk_cam.core.part.model import part_from_blade, part_from_demo

    if case == "demo":
        return part_from_demo(make_demo_blisk(resolution=0.3)), 6.0, None
    from support.blades import blade_meta, blade_stl

    hub = blade_meta("rotor37")["cones"]["hub"]
    a = np.array([hub["P1_xyz_mm"][0], hub["P1_xyz_mm"][2]])
    b = np.array([hub["P2_xyz_mm"][0], hub["P2_xyz_mm"][2]])
    u = (b - a) / np.linalg.norm(b - a)
    V, F = read_mesh(blade_stl("rotor37"))
    mesh = TriMesh.from_arrays(V, F)
    part = part_from_blade(mesh.V, mesh.F, np.array([a - 15 * u, b + 15 * u]), 36)
    return part, 4.0, ((20.0, 2.0), (100.0, 2.0), (100.0, 10.0), (160.0, 10.0))


def run(case, resolution, scallop=0.2):
    from blisk_cam.core.hub.surface import HubSurface
    from blisk_cam.core.process.hub_finish import HUB_FINISH, HubRequest, plan_channel
    from blisk_cam.core.process.operation import run_operation
    from blisk_cam.core.stock.blank import stock_from_allowance
    from blisk_cam.core.stock.deviation import deviation_map
    from blisk_cam.core.stock.simulation import iter_simulate
    from blisk_cam.core.tool.assembly import ToolAssembly

    part, diameter, holder = _part(case)
    req = HubRequest(tool_diameter=diameter, scallop=scallop, extend=5.0, allowance=0.35,
                     holder=holder, flute_length=20.0 if holder else None)
    t0 = time.perf_counter()
    path = run_operation(HUB_FINISH, part, req).path
    s = path.stats
    print(f"{case}: {s['passes']} passes, {s['poses']} poses, ball clearance from the blades "
          f"{s['clearance_blade0_min_mm']:.3f} / {s['clearance_blade1_min_mm']:.3f} mm "
          f"(allowance {req.allowance}), body clearance {s['body_clearance_min_mm']:.2f} mm "
          f"({s['body_collision_rows']} rows within the safety), scallop estimate "
          f"{s['scallop_estimate_mm']:.3f} mm, planned in {time.perf_counter() - t0:.1f} s")
    stock = stock_from_allowance(part, 0.3, resolution)
    t0 = time.perf_counter()
    gen = iter_simulate(part, stock, [path],
                        assembly=ToolAssembly(20.0, holder) if holder else None)
    while True:
        try:
            next(gen)
        except StopIteration as stop:
            sim = stop.value
            break
    dv = sim.summary["deviation_mm"]
    ch = plan_channel(part, req)
    hub = HubSurface(part.hub_profile, part.axis)
    sel = (ch.m > ch.m_le) & (ch.m < ch.m_te)
    ms, ta, tb = ch.m[sel][::3], ch.theta_a[sel][::3], ch.theta_b[sel][::3]
    f = np.linspace(0.02, 0.98, 200)
    th = (ta[:, None] + f[None, :] * (tb - ta)[:, None]).ravel()
    m = np.repeat(ms, len(f))
    left = deviation_map(sim.stock, hub.point(m, th), hub.normal(m, th))
    print(f"{case}: simulated at {resolution} mm in {time.perf_counter() - t0:.1f} s: "
          f"{len(sim.summary['crashes'])} crash(es), gouge {dv['max_gouge']:.3f} mm "
          f"(tolerance {dv['gouge_tolerance']:.3f}); hub left max {left.max():.3f} mm, p99 "
          f"{np.percentile(left, 99):.3f} mm (target {scallop} + resolution {resolution})")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", choices=("r37", "demo", "both"), default="both")
    ap.add_argument("--resolution", type=float, default=0.2)
    args = ap.parse_args()
    for case in (("r37", "demo") if args.case == "both" else (args.case,)):
        run(case, args.resolution)


if __name__ == "__main__":
    main()
