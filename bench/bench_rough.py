"""Benchmark channel roughing (#23) on the demo blisk; prints figures (no assertions).

    python bench/bench_rough.py [--resolution 0.5] [--mesh-resolution 0.3] [--levels from-hub]
        [--pattern zigzag] [--depth 6] [--stepover 6] [--diameter 10] [--corner 1]
        [--axis blades|radial] [--max-turn 2] [--small | --rotor37] [--order gap|level]
        [--no-simulate] [--floor-band-step 0.5] [--before-after] [--level-scallop H]

The demo blisk (default parameters, 24 blades; ``--small``: the 25 mm tall test blisk of
tests/core/test_roughing.py; ``--rotor37``: NASA Rotor 37 patterned to 36 blades, its hub
cone extended 15 mm each way, with --diameter 16 --depth 8 --stepover 8 a Ø16 R1 that does
not fit the throat at the hub) from its default blank (the envelope + 2 mm), a bull nose on a
long neck. Prints: the planning time of one gap (the program of every gap is the same one
turned by k · 2π/N, so all N gaps cost one plan), the estimated machining time of one gap and
of all gaps, then — simulating the program level by level on the periodic stock of one
sector, which is the simulation of all N gaps at once — the simulation time, the share of
the channel volume outside the allowance shell removed after each level (cumulative) and by
each level, crashes, and the least material left on the part (mm; good to the stock's
resolution / √2), the largest above the floor band (the allowance + one depth per cut
above the hub) and in it, and the largest level step cusp excess there (the bound of
tests/core/test_roughing.py: 0.5 + s |n · a| + res/√2). ``--before-after`` plans and
simulates twice, without the surface-driven floor-band passes and with them
(``--floor-band-step``), and prints the planning time of one gap, the share removed and the
points over the bound (count, largest excess) above and in the floor band side by side.
``--level-scallop H`` spaces the levels for a step cusp H (``--depth`` their cap) and prints
the steps; the bound above the floor band (its height from the stats) is then 0.5 + H +
res/√2 on the blade walls (:data:`blisk_cam.core.channel.level_scallop.WALL_SLOPE`).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import numpy as np  # noqa: E402

from blisk_cam.core.channel.level_scallop import WALL_SLOPE  # noqa: E402
from blisk_cam.core.channel.levels import channel_volume  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.model import part_from_blade, part_from_demo, theta_about  # noqa: E402
from blisk_cam.core.process.operation import run_operation  # noqa: E402
from blisk_cam.core.process.roughing import RoughingOperation, RoughRequest  # noqa: E402
from blisk_cam.core.stock.blank import stock_from_allowance, stock_from_envelope  # noqa: E402
from blisk_cam.core.stock.deviation import deviation_map  # noqa: E402
from blisk_cam.core.stock.removal import remove_program  # noqa: E402
from blisk_cam.core.stock.simulation import part_surface  # noqa: E402
from blisk_cam.core.tool.cutter import Cutter  # noqa: E402
from blisk_cam.core.toolpath.types import Program  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=0.5)
    ap.add_argument("--mesh-resolution", type=float, default=0.3)
    ap.add_argument("--levels", default="from-hub")
    ap.add_argument("--pattern", default="zigzag")
    ap.add_argument("--depth", type=float, default=6.0)
    ap.add_argument("--level-scallop", type=float, default=None)
    ap.add_argument("--stepover", type=float, default=6.0)
    ap.add_argument("--diameter", type=float, default=10.0)
    ap.add_argument("--corner", type=float, default=1.0)
    ap.add_argument("--axis", default="blades", choices=("blades", "radial"))
    ap.add_argument("--max-turn", type=float, default=2.0)
    ap.add_argument("--small", action="store_true")
    ap.add_argument("--rotor37", action="store_true")
    ap.add_argument("--order", default="gap", choices=("gap", "level"),
                    help="level: the program of every gap, a level in all gaps before the next "
                    "(simulated whole: N times the work of one gap)")
    ap.add_argument("--no-simulate", action="store_true")
    ap.add_argument("--floor-band-step", type=float, default=0.5,
                    help="rows of the surface-driven floor-band passes every MM (0: none)")
    ap.add_argument("--before-after", action="store_true",
                    help="plan and simulate without the floor-band passes and with them")
    a = ap.parse_args()

    if a.small:
        demo = make_demo_blisk(resolution=0.2, hub_cone=(150.0, -12.0, 154.0, 12.0),
                               tip_cone=(178.0, -12.0, 181.0, 12.0), chord_hub=22.0,
                               chord_tip=22.0, fillet_radius=4.0, hub_extension=4.0,
                               max_thickness_hub=2.5, max_thickness_tip=1.5)
    elif not a.rotor37:
        demo = make_demo_blisk(resolution=a.mesh_resolution)
    if a.rotor37:
        from support.blades import blade_meta, blade_stl

        from blisk_cam.core.geometry.mesh import TriMesh
        from blisk_cam.core.geometry.mesh_io import read_mesh

        hub = blade_meta("rotor37")["cones"]["hub"]
        p1 = np.array([hub["P1_xyz_mm"][0], hub["P1_xyz_mm"][2]])
        p2 = np.array([hub["P2_xyz_mm"][0], hub["P2_xyz_mm"][2]])
        u = (p2 - p1) / np.linalg.norm(p2 - p1)
        mesh = TriMesh.from_arrays(*read_mesh(blade_stl("rotor37")))
        part = part_from_blade(mesh.V, mesh.F, np.array([p1 - 15 * u, p2 + 15 * u]), 36)
    else:
        part = part_from_demo(demo)
    blank = stock_from_envelope(part, 2.0, a.resolution)
    runs = [0.0, a.floor_band_step] if a.before_after else [a.floor_band_step]
    out = [_run(a, part, blank, step) for step in runs]
    if a.before_after and not a.no_simulate:
        print("\nfloor-band passes     planning   removed   over the bound (points, max mm): "
              "above the band | in the band")
        for step, o in zip(runs, out, strict=True):
            print(f"{'none' if step == 0 else f'every {step:g} mm':20s} {o['plan']:8.1f} s "
                  f"{o['share']:8.1%}   " + " | ".join(
                      f"{n:4d}, {m:.3f}" for n, m in (o['above'], o['band'])))


def _run(a, part, blank, step) -> dict:
    """Plan (floor-band rows every ``step`` mm) and simulate; prints; returns the figures."""
    R = 0.5 * a.diameter
    tool = Cutter.bull(R, a.corner, h=3 * a.diameter, neck_length=7 * a.diameter)
    depth = dict(level_scallop=a.level_scallop, max_depth_per_cut=a.depth) \
        if a.level_scallop else dict(depth_per_cut=a.depth)
    req = RoughRequest(tool=tool, stepover=a.stepover, levels=a.levels, **depth,
                       pattern=a.pattern, follow_blades=a.axis == "blades",
                       max_turn=math.radians(a.max_turn), order=a.order,
                       floor_band_step=step)
    t = time.perf_counter()
    res = run_operation(RoughingOperation(), part, req, blank.copy())
    plan = time.perf_counter() - t
    p = res.path
    s = p.stats
    name = "rotor 37" if a.rotor37 else "demo"
    print(f"\n{name}: {part.blade_count} blades, {len(part.blade_faces)} blade triangles; blank "
          f"{blank.n_theta} × {blank.n_z} rays at {a.resolution:g} mm; tool Ø{a.diameter:g} "
          f"R{a.corner:g}; {a.levels}, {a.pattern}, depth {a.depth:g}, stepover "
          f"{a.stepover:g} mm; floor-band rows " + (f"every {step:g} mm ("
                                                      f"{s.get('floor_band_passes', 0)} passes)"
                                                      if step else "none"))
    print(f"roughing time (planning) of one gap: {plan:.2f} s (stages " + ", ".join(
        f"{k} {v:.2f}" for k, v in res.seconds.items()) + f"); all {part.blade_count} gaps: "
        f"{plan:.2f} s (the same program turned by k · 360°/{part.blade_count})")
    print(f"program: {s['levels']} levels, {s['passes']} passes, {s['rows']} rows; estimated "
          f"machining {s['machining_time_min_gap']:.1f} min per gap, "
          f"{s['machining_time_min_all_gaps']:.1f} min for all {s['gaps']} gaps "
          f"(feed {s['feed_mm_min']:g} mm/min); order by {s['order']}, the program holds "
          f"{s['gaps_in_program']} gap(s)")
    print(f"axis {s['axis']}: side tilt {s['side_tilt_range_deg'][0]:.1f}° … "
          f"{s['side_tilt_range_deg'][1]:.1f}°, largest turn between cutting poses "
          f"{s['max_axis_turn_deg']:.3f}° (bound {a.max_turn:g}° on the tool axis; "
          f"{s.get('poses_inserted_for_turn', 0)} poses inserted where the radial direction's "
          f"own turn added to the side tilt's); {s.get('wall_levels', 0)} wall levels every "
          f"{s.get('wall_level_step_mm', 0.0):.2f} mm; unreachable: "
          f"{', '.join(s['unreachable_levels']) or 'none'}")
    if a.level_scallop:
        print(f"level scallop {a.level_scallop:g} mm: steps " + ", ".join(
            f"{x:.2f}" for x in s["level_steps_mm"]) + f" mm; floor band up to "
            f"{s['floor_band_height_mm']:.2f} mm above the hub")
    for w in p.warnings:
        print(f"warning: {w}")
    if a.no_simulate:
        return {"plan": plan}
    stock = blank.copy()
    v0 = channel_volume(stock, part.hub_profile)
    shell = channel_volume(stock_from_allowance(part, 0.5, a.resolution), part.hub_profile)
    removable = v0 - shell
    P = p.program
    t = time.perf_counter()
    crashes = 0
    prev = v0
    print("level  rows      removed by it   removed so far")
    for k, (lo, hi) in enumerate(s["level_rows"]):
        if hi <= lo:
            print(f"{k + 1:5d}  (left out)")
            continue
        lo = max(lo - 1, 0)  # the move that reaches the level's first row
        sub = Program(P.tip[lo:hi], P.axis[lo:hi], P.move[lo:hi], P.curve[lo:hi],
                      P.index[lo:hi], P.flags[lo:hi])
        rr = remove_program(stock, sub, p.tool, sweep_tolerance=0.05, row_offset=lo)
        crashes += len(rr.crashes)
        v = channel_volume(stock, part.hub_profile)
        print(f"{k + 1:5d}  {hi - lo:6d}  {(prev - v) / removable:14.1%}  "
              f"{(v0 - v) / removable:14.1%}")
        prev = v
    sim = time.perf_counter() - t
    V, F, N, surf = part_surface(part, a.resolution)
    dev = deviation_map(stock, V[surf], N[surf], reach_out=12.0)
    P, Nn = V[surf], N[surf]
    r, th, z = theta_about(P, part.axis)
    H = part.hub_profile
    band = r < np.interp(z, H[:, 1], H[:, 0]) + s["floor_band_height_mm"]
    radial = np.stack([np.cos(th), np.sin(th), np.zeros_like(th)], 1)
    tang = np.stack([-np.sin(th), np.cos(th), np.zeros_like(th)], 1)
    nu, nt = np.einsum("ij,ij->i", Nn, radial), np.einsum("ij,ij->i", Nn, tang)
    t0, t1 = np.radians(s["side_tilt_range_deg"])
    na = np.max([np.abs(nu * math.cos(q) + nt * math.sin(q))
                 for q in np.linspace(min(t0, 0.0), max(t1, 0.0), 13)], axis=0)
    cusp_step = np.where(band, s.get("wall_level_step_mm") or a.depth, a.depth)
    excess = dev - (0.5 + cusp_step * na + a.resolution / math.sqrt(2))
    if a.level_scallop:  # on the walls above the band: the scallop
        wall = np.abs(nu) <= math.sin(WALL_SLOPE)
        excess = np.where(band, excess, np.where(wall, dev - (
            0.5 + a.level_scallop + a.resolution / math.sqrt(2)), -np.inf))
    figures = {"plan": plan, "share": (v0 - prev) / removable}
    for key, m in (("above", ~band), ("band", band)):
        figures[key] = (int((excess[m] > 0).sum()), max(float(excess[m].max()), 0.0)) \
            if m.any() else (0, 0.0)
    for name, m in (("above the floor band", ~band), ("in the floor band", band)):
        if m.any():
            print(f"{name}: {m.sum()} points, left {dev[m].min():.3f} … {dev[m].max():.3f} mm "
                  f"(median {np.median(dev[m]):.3f}); {int((excess[m] > 0).sum())} beyond the "
                  f"level step cusp bound, by up to {max(excess[m].max(), 0.0):.3f} mm")
    over = band & (excess > 0)
    if over.any():
        k = _touchable(part, p.tool, V, N, P, Nn, over)
        print(f"of the {int(over.sum())} floor-band points beyond the bound, {k} can be touched "
              f"at their allowance point by the cutter with an axis radial ± 20° sideways, "
              f"± 10° lead, without entering the allowance elsewhere (sampled at "
              f"{a.resolution:g} mm, 0.05 mm tolerance): "
              + ("reachable, a planning gap" if k else "out of the cutter's reach"))
    print(f"simulation (one sector = all gaps): {sim:.1f} s; crashes {crashes}; share of the "
          f"channel outside the allowance removed {(v0 - prev) / removable:.1%}; material left "
          f"min {dev.min():.3f} mm (resolution effect ±{a.resolution / math.sqrt(2):.3f}), "
          f"median {np.median(dev):.3f} mm")

    return figures

def _touchable(part, tool, V, N, P, Nn, mask, allowance=0.5) -> int:
    """How many of the points ``P[mask]`` (normals ``Nn``) the cutter can touch at their
    allowance point (P + allowance · n, the cutter's contact normal n) with an axis radial
    tilted −20 … 20° sideways and −10, 0, 10° lead, no sample of the allowance surface
    (V + allowance · N, the sector and its two neighbours) more than 0.05 mm inside it."""
    e1, e2, d = part.axis.angular_frame()
    S = V + allowance * N

    def turned(p, ang):
        q = p - part.axis.o
        zc, x, y = q @ d, q @ e1, q @ e2
        c, s = math.cos(ang), math.sin(ang)
        return part.axis.o + np.outer(zc, d) + np.outer(c * x - s * y, e1) + \
            np.outer(s * x + c * y, e2)

    S = np.concatenate([turned(S, k * part.pitch) for k in (-1, 0, 1)])
    count = 0
    for i in np.nonzero(mask)[0]:
        q = P[i] + allowance * Nn[i]
        _, th, _ = theta_about(q[None], part.axis)
        u = math.cos(th[0]) * e1 + math.sin(th[0]) * e2
        t = -math.sin(th[0]) * e1 + math.cos(th[0]) * e2
        near = S[np.linalg.norm(S - q, axis=1) < tool.h + tool.d]
        for lead in np.radians([0.0, -10.0, 10.0]):
            for side in np.radians(np.arange(-20.0, 20.1, 2.5)):
                ax = u + math.tan(side) * t + math.tan(lead) * d
                ax /= np.linalg.norm(ax)
                if Nn[i] @ ax < 1e-6:
                    continue
                tip = tool.cl_points(q[None], Nn[i][None], ax[None])[0]
                if tool.signed_distance(near, tip, ax).min() >= -0.05:
                    count += 1
                    break
            else:
                continue
            break
    return count


if __name__ == "__main__":
    main()
