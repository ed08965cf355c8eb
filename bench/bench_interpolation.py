"""Constant machining error vs chord height linear interpolation (issue 12, paper 002).

On the demo blade and on NASA Rotor 37 (when its data is present), Ø12 ball, AC trunnion,
axis near radial: densely planned passes (chord 0.002 mm), blocks chosen by

* constant-error: the longest blocks whose error bound ≤ [dM] (``--max-error``),
* chord: the longest blocks whose tip chord height ≤ h, h tuned (bisection) until its
  measured maximum error equals constant-error's measured maximum,

then both measured exactly (joint-linear motion, forward kinematics, cutter-to-mesh signed
distance). Prints block counts, the per-block error band (% of [dM]) and search speed.

    python bench/bench_interpolation.py [--max-error 0.01] [--only demo|rotor37]
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.geometry.distance import MeshDistance  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.machine import block_search as B  # noqa: E402
from blisk_cam.core.machine import interpolation as I  # noqa: E402
from blisk_cam.core.machine.description import load_machine  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402


def demo_case(cusp=3.0, chord=0.002):
    from blisk_cam.core.part.blisk import make_demo_blisk
    from blisk_cam.core.part.cones import Cone

    d = make_demo_blisk(resolution=0.5, fillet=True, fillet_radius=10.0)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=cusp, chord=chord, axis_mode="radial",
                      radial_tilt=math.radians(75.0))
    return mesh, plan_paths(mesh, req).path


def rotor37_case(cusp=1.0, chord=0.002):
    from blisk_cam.core.geometry.axis import Axis
    from tests.support.blades import nasa_blade

    V, F, c1, c2 = nasa_blade("rotor37")
    mesh = TriMesh.from_arrays(V, F)
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_radius=6.0, cusp=cusp, chord=chord,
                      axis_mode="radial", radial_tilt=math.radians(75.0))
    return mesh, plan_paths(mesh, req).path


def band(meas, tol):
    r = meas / tol
    return r.min(), r.max(), float(np.mean((r >= 0.7) & (r <= 1.0 + 1e-3 / tol)))


def compare(name, mesh, path, tol, machine):
    md = MeshDistance(mesh)
    t = time.perf_counter()
    _, rep = I.interpolate_program(path, machine, "constant-error", max_error=tol, mesh=md)
    wall = time.perf_counter() - t
    m_ce = np.concatenate([s.measured for s in rep.sets])
    b_ce = np.concatenate([s.bound for s in rep.sets])
    dps = [s.dense for s in rep.sets]
    target = float(m_ce.max())
    t = time.perf_counter()
    h, E, M = B.match_chord_height(dps, machine, path.tool, target, mesh=md)
    t_match = time.perf_counter() - t
    t = time.perf_counter()
    B.search_chord(dps, h)
    t_chord = time.perf_counter() - t
    m_ch = np.concatenate(M)
    n_ce, n_ch = len(m_ce), len(m_ch)
    lo, hi, frac = band(m_ce, tol)
    clo, chi, _ = band(m_ch, tol)
    print(f"== {name}: {rep.passes} passes, {rep.input_poses} planned cut poses, "
          f"{rep.dense} dense poses, [dM] = {1000 * tol:g} µm")
    print(f"constant-error: {n_ce} blocks, measured max {1000 * target:.2f} µm, per-block "
          f"maxima {100 * lo:.1f}–{100 * hi:.1f} % of [dM] ({100 * frac:.1f} % of blocks in "
          f"70–100 %), measured ≤ bound on {np.mean(m_ce <= b_ce + 1e-12) * 100:.1f} % of "
          f"blocks (max measured/bound {np.max(m_ce / np.maximum(b_ce, 1e-15)):.3f} for bound "
          f"> 1 µm: {np.max(np.where(b_ce > 1e-3, m_ce / np.maximum(b_ce, 1e-15), 0)):.3f})")
    print(f"   search {rep.seconds_search:.3f} s = {rep.poses_per_second:,.0f} dense poses/s "
          f"({rep.input_poses_per_second:,.0f} planned poses/s); prepare "
          f"{rep.seconds_prepare:.3f} s; whole interpolate_program with measuring {wall:.2f} s")
    print(f"chord height {1000 * h:.3f} µm (tuned to equal measured max, {t_match:.1f} s): "
          f"{n_ch} blocks, measured max {1000 * m_ch.max():.2f} µm, per-block maxima "
          f"{100 * clo:.1f}–{100 * chi:.1f} % of [dM]; search {t_chord:.3f} s")
    # the chord maximum jumps with h: also the first h (2 % steps) whose maximum exceeds
    # constant-error's, i.e. chord height given a larger error than constant-error
    h2 = h
    for _ in range(60):
        h2 *= 1.02
        E2 = B.search_chord(dps, h2)
        M2 = [B.measure_blocks(machine, path.tool, dp, e)[0] for dp, e in zip(dps, E2,
                                                                            strict=True)]
        if max(float(x.max()) for x in M2) > target:
            break
    n_ch2 = sum(len(e) - 1 for e in E2)
    m2 = max(float(x.max()) for x in M2)
    print(f"   (next chord height {1000 * h2:.3f} µm: {n_ch2} blocks, measured max (path) "
          f"{1000 * m2:.2f} µm — above constant-error's)")
    print(f"→ constant-error needs {100 * (1 - n_ce / n_ch):.1f} % fewer blocks "
          f"({n_ce} vs {n_ch}); {100 * (1 - n_ce / n_ch2):.1f} % fewer than the chord height "
          f"just above equal error")
    return n_ce, n_ch


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-error", type=float, default=0.01)
    ap.add_argument("--only", choices=("demo", "rotor37"))
    args = ap.parse_args(argv)
    machine = load_machine("ac-trunnion")
    if args.only in (None, "demo"):
        mesh, path = demo_case()
        compare("demo blade (5 passes around the blade)", mesh, path, args.max_error, machine)
    if args.only in (None, "rotor37"):
        compare("Rotor 37", *rotor37_case(), args.max_error, machine)


if __name__ == "__main__":
    main()
