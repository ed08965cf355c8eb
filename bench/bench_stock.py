"""Benchmark the in-process stock on the demo's finishing program; prints figures (no
assertions).

    python bench/bench_stock.py [--resolution 0.05 [0.1 ...]] [--threads 1 [2 ...]]
        [--rows N] [--allowance 0.1] [--mesh-resolution 1.0] [--no-body]
        [--kernel sampled swept] [--acceptance S0 S1 [--rotor37] [--tilt 75]]

The demo blisk (default parameters), its blade-finishing program with the default request
(hub cone to tip cone, cusp and chord 0.05 mm — what ``blisk_cam demo`` plans), a stock of
the part plus ``--allowance`` at ``--resolution``; the first ``--rows`` rows of the program
(default all) are simulated. Prints: rays and stock memory, blank time, rows (moves) per
second, sub-poses and ray–solid pairs per second, the deviation-map time, the whole time (and,
for a part of the program, the whole program's time extrapolated at the measured rate) and
the peak resident memory — for every resolution and thread count given, with the backend
that ran (``kernels: compiled …`` or ``numpy``; ``BLISK_CAM_KERNELS=numpy`` forces the
reference). ``--kernel``: the compiled kernel's removal by sub-poses (``sampled``, the
numpy reference's arithmetic, flute and body pose by pose: the figures before the swept
kernel) and/or by swept volumes per move (``swept``: the flute swept, the body at the same
sub-poses through the sweep kernel, culled per move and part), each printed for the same rows
— before/after in one run.

``--acceptance S0 S1``: instead, issue #22's acceptance on the demo at full scale between the
LMCs S0 and S1: the finishing program with the axis radial, tilted 75° (its body clears the
neighbouring blade; the crashes are printed), stock = part + 0.1 mm, and the deviation on the
blade mesh against verify's material left at its vertices: prints the deviation's minimum
(bound −(chord + resolution)), its maximum where verify measures (bound cusp + chord +
resolution) and the largest |deviation − verify| there (bound resolution + 2 µm). Verify's
material left is the cuts' (``vertex_values``); the stock is cut by every row, so the figure
it is held to is the whole program's: the smaller of the cuts' and the links' material left
(:func:`link_material_left`; on the demo a link between passes comes within 0.0002 mm of the
blade, or 0.013 mm into it, at vertices the cuts leave 0.02–0.03 mm on — the gap to the cuts'
figure alone is printed too).
``--rotor37``: the same on NASA Rotor 37 (tests/data/blades: the open STL extended past hub
and tip, welded; 36 blades; the hub profile its hub cone extended 15 mm each way) between its
LMCs S0 and S1; its mesh runs past the tip cone (an extension that is no part of the blade
and that the program's links may cross): the deviation's minimum is judged up to the tip cone
and the vertices past it are counted apart. ``--tilt`` (degrees, default 75) sets the radial
axis' lean; ``--no-body`` removes with the flute only (no shank/holder: its crashes, and the
blade material they would take, are left out — the stock and deviation checked on their own).
Goal (issue #22): a full five-stage program of one sector at 0.05 mm in ≤ 10 s.
"""

from __future__ import annotations

import argparse
import resource
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.kernels import stock as compiled_stock  # noqa: E402
from blisk_cam.core.kernels.backend import backend_name  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.model import part_from_demo, theta_about  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.runtime import parallel  # noqa: E402
from blisk_cam.core.stock.blank import stock_from_allowance  # noqa: E402
from blisk_cam.core.stock.deviation import deviation_map, vertex_normals  # noqa: E402
from blisk_cam.core.stock.removal import remove_program  # noqa: E402
from blisk_cam.core.stock.simulation import part_surface  # noqa: E402
from blisk_cam.core.toolpath.types import Program  # noqa: E402


def run(part, sub, tool, n_all, resolution, threads, a, kernel="swept"):
    n = len(sub)
    t0 = time.perf_counter()
    t = time.perf_counter()
    stock = stock_from_allowance(part, a.allowance, resolution)
    t_blank = time.perf_counter() - t
    mem = (stock.lo.nbytes + stock.hi.nbytes) / 1e6
    print(f"--- {resolution:g} mm, {threads} thread(s), flute {kernel}")
    print(f"stock: part + {a.allowance:g} mm at {resolution:g} mm: {stock.n_theta} × "
          f"{stock.n_z} = {stock.n_rays} rays, K = {stock.lo.shape[1]}, {mem:.0f} MB, "
          f"{stock.volume():.0f} mm³; built in {t_blank:.2f} s")
    t = time.perf_counter()
    cpu = time.process_time()
    with parallel(threads):
        res = remove_program(stock, sub, tool, check_body=not a.no_body,
                             swept=(kernel == "swept"))
    t_sim = time.perf_counter() - t
    cpu = time.process_time() - cpu
    print(f"removal: {n} rows in {t_sim:.2f} s (cpu {cpu:.2f} s) = {n / t_sim:.1f} moves/s; "
          f"{res.sub_poses} sub-poses ({res.sub_poses / t_sim:.0f}/s), {res.pairs} candidate "
          f"ray–solid pairs ({res.pairs / t_sim / 1e6:.2f} M/s); removed {res.volume:.1f} mm³; "
          f"{len(res.crashes)} crash row(s)")
    t = time.perf_counter()
    V, F, N, surface = part_surface(part, resolution)
    dev = deviation_map(stock, V[surface], N[surface])
    t_dev = time.perf_counter() - t
    print(f"deviation: {int(surface.sum())} vertices in {t_dev:.2f} s "
          f"(min {dev.min():.3f}, max {dev.max():.3f} mm)")
    whole = time.perf_counter() - t0
    print(f"whole (blank + removal + deviation, the user's wall time): {whole:.2f} s")
    if n < n_all:
        est = t_blank + t_sim * n_all / n + t_dev
        print(f"whole program ({n_all} rows) at this rate: ~{est:.0f} s (extrapolated)")


def acceptance(a):
    """Issue #22's acceptance on the demo between two LMCs (module docstring)."""
    import math

    import numpy as np

    from blisk_cam.core.verify.links import link_material_left
    from blisk_cam.core.verify.measure import verify_path

    cusp = chord = 0.05
    if a.rotor37:
        sys.path.insert(0, str(ROOT / "tests"))
        from support.blades import blade_cones, blade_meta, blade_stl

        from blisk_cam.core.geometry.mesh_io import read_mesh
        from blisk_cam.core.part.cones import MorphingCones
        from blisk_cam.core.part.model import part_from_blade

        hub = blade_meta("rotor37")["cones"]["hub"]
        p1 = np.array([hub["P1_xyz_mm"][0], hub["P1_xyz_mm"][2]])
        p2 = np.array([hub["P2_xyz_mm"][0], hub["P2_xyz_mm"][2]])
        u = (p2 - p1) / np.linalg.norm(p2 - p1)
        mesh = TriMesh.from_arrays(*read_mesh(blade_stl("rotor37")))
        part = part_from_blade(mesh.V, mesh.F, np.array([p1 - 15 * u, p2 + 15 * u]), 36)
        mc = MorphingCones(*blade_cones("rotor37"))
        name = "rotor 37"
    else:
        demo = make_demo_blisk(resolution=a.mesh_resolution)
        part = part_from_demo(demo)
        mesh = TriMesh.from_arrays(demo.blade_vertices, demo.blade_faces)
        mc = demo.morphing_cones
        name = "demo"
    # the blade proper: up to the tip cone (Rotor 37's mesh runs past it, an extension that
    # is no part of the blade; the program's links may run through it)
    rv, _, zv = theta_about(mesh.V, part.axis)
    tc = mc.cone_at(1.0)
    blade = rv <= tc.r1 + (zv - tc.z1) * (tc.r2 - tc.r1) / (tc.z2 - tc.z1)
    t = time.perf_counter()
    req = PathRequest(axis=part.axis, cone1=mc.cone_at(a.acceptance[0]),
                      cone2=mc.cone_at(a.acceptance[1]), cusp=cusp, chord=chord,
                      axis_mode="radial", radial_tilt=math.radians(a.tilt))
    path = plan_paths(mesh, req).path
    print(f"{name}: {len(mesh.F)} blade triangles; LMC {a.acceptance[0]:g}..{a.acceptance[1]:g}: "
          f"{len(path.program)} rows, planned in {time.perf_counter() - t:.1f} s")
    t = time.perf_counter()
    report = verify_path(mesh, path)
    cuts = report.vertex_values
    reached = np.isfinite(cuts)
    links = link_material_left(path.program, path.tool, mesh.V)
    vv = np.fmin(cuts, links)  # the material the whole program leaves
    print(f"verify: {time.perf_counter() - t:.1f} s, {int(reached.sum())} of {len(vv)} vertices "
          f"measured, max material left {report.max_material_left:.4f} mm, max gouge "
          f"{report.max_gouge:.4f} mm, link gouge {report.link_gouge:.4f} mm (row "
          f"{report.link_gouge_row}); the links pass nearer than the cuts at "
          f"{int((links < cuts)[reached].sum())} vertices (by up to "
          f"{np.nanmax(np.where(reached, cuts - links, np.nan)):.4f} mm)")
    print(f"kernels: {backend_name()}"
          f"{' (swept flute)' if compiled_stock.sweep_available() else ''}")
    for res in a.resolution:
        t = time.perf_counter()
        cpu = time.process_time()
        stock = stock_from_allowance(part, 0.1, res)
        with parallel(a.threads[0]):
            out = remove_program(stock, path.program, path.tool, check_body=not a.no_body)
        dev = deviation_map(stock, mesh.V, vertex_normals(mesh.V, mesh.F))
        wall, cpu = time.perf_counter() - t, time.process_time() - cpu
        gap = np.abs(dev[reached] - vv[reached])
        gap_cuts = np.abs(dev[reached] - cuts[reached])
        print(f"--- {res:g} mm: {wall:.1f} s (cpu {cpu:.1f} s), {len(out.crashes)} crash row(s)")
        print(f"deviation min {dev.min():.4f} (bound {-(chord + res):.4f}); max where verify "
              f"measures {dev[reached].max():.4f} (bound {cusp + chord + res:.4f}); "
              f"|deviation − verify| max {gap.max():.4f}, p99 {np.percentile(gap, 99):.4f} "
              f"(bound {res + 0.002:.4f}) mm, {int((gap > res + 0.002).sum())} of "
              f"{int(reached.sum())} vertices beyond it; against the cuts' figure alone: max "
              f"{gap_cuts.max():.4f}, {int((gap_cuts > res + 0.002).sum())} beyond")
        if not blade.all():
            past = dev[~blade]
            print(f"past the tip cone (the mesh's extension): {int((~blade).sum())} vertices, "
                  f"{int((past < -(chord + res)).sum())} below the bound (min {past.min():.4f}); "
                  f"up to the tip cone: deviation min {dev[blade].min():.4f}")
        ok = (dev[blade].min() >= -(chord + res) and dev[reached].max() <= cusp + chord + res
              and gap.max() <= res + 0.002 and not out.crashes)
        print(f"acceptance{' (up to the tip cone)' if not blade.all() else ''}: "
              f"{'met' if ok else 'NOT met'}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, nargs="+", default=[0.05])
    ap.add_argument("--threads", type=int, nargs="+", default=[1])
    ap.add_argument("--rows", type=int, default=0, help="simulate the first N rows (0: all)")
    ap.add_argument("--allowance", type=float, default=0.1)
    ap.add_argument("--mesh-resolution", type=float, default=1.0)
    ap.add_argument("--no-body", action="store_true", help="skip the shank/holder crash check")
    ap.add_argument("--kernel", nargs="+", default=["sampled", "swept"],
                    choices=["sampled", "swept"], help="the compiled flute removal(s) to time")
    ap.add_argument("--acceptance", type=float, nargs=2, metavar=("S0", "S1"),
                    help="issue #22's acceptance between the LMCs S0 and S1 instead")
    ap.add_argument("--tilt", type=float, default=75.0,
                    help="acceptance: the radial axis' lean away from the blisk axis, degrees")
    ap.add_argument("--rotor37", action="store_true",
                    help="the acceptance on NASA Rotor 37 (36 blades, hub cone profile "
                         "extended 15 mm each way) instead of the demo")
    a = ap.parse_args()
    if a.acceptance:
        acceptance(a)
        return

    demo = make_demo_blisk(resolution=a.mesh_resolution)
    part = part_from_demo(demo)
    t = time.perf_counter()
    mesh = TriMesh.from_arrays(demo.blade_vertices, demo.blade_faces)
    req = PathRequest(axis=demo.axis, cone1=demo.hub_cone, cone2=demo.tip_cone, cusp=0.05,
                      chord=0.05)
    path = plan_paths(mesh, req).path
    P = path.program
    print(f"demo: {len(demo.blade_faces)} blade triangles; program {len(P)} rows "
          f"({path.tool.describe() if hasattr(path.tool, 'describe') else path.tool.type}), "
          f"planned in {time.perf_counter() - t:.1f} s")
    n = len(P) if a.rows <= 0 else min(a.rows, len(P))
    sub = Program(P.tip[:n], P.axis[:n], P.move[:n], P.curve[:n], P.index[:n], P.flags[:n])

    kern = backend_name()
    if kern != "numpy" and not compiled_stock.available():
        kern += " (without the stock kernel: numpy removal)"
    print(f"kernels: {kern}")
    kernels = a.kernel if compiled_stock.sweep_available() else ["sampled"]
    for res in a.resolution:
        for threads in a.threads:
            for kernel in kernels:
                run(part, sub, path.tool, len(P), res, threads, a, kernel)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak resident memory: {peak:.0f} MB")


if __name__ == "__main__":
    main()
