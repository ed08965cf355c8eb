"""Constant-error interpolation on blades the project was not tuned on (issue 28 row 11).

Blades made by the demo generator with other parameters (chords, stagger, camber, lean,
thickness, edge radii), clean and scan-like (noise, jitter, slivers), cut with a Ø12 ball at
other radial tilts (88°, 75°, 60°) on other machines; densely planned (chord 0.002 mm),
constant-error blocks with ``--max-error`` (default 0.01 mm) as ``nc`` posts them, then every
cut block measured independently against the MESH: the block's joint-linear motion sampled,
forward kinematics, ball centre to mesh − ρ (:mod:`tests.support.part_error`).

Three ways per blade: ``before`` (the error taken from the planned path, as issue 12 built
it), ``nc`` (the NC default now: the planned path's chord tolerance budgeted whole, no mesh
needed) and ``mesh`` (the planned path's own clearance from the mesh budgeted per dense pose,
what ``paths --nc`` does). Prints blocks, blocks above the bound, the maximum, the share of
blocks in 70–100 % of the bound (all blocks, and without each pass's last block: a
remainder) and the range.

    python bench/bench_interpolation_unseen.py [--max-error 0.01] [--only NAME]
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
from blisk_cam.core.machine.description import load_machine  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.post.blocks import NcOptions  # noqa: E402
from blisk_cam.core.post.export import nc_program  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.toolpath.types import MOVE_CUT  # noqa: E402
from tests.support.part_error import block_errors  # noqa: E402

D = math.radians
BLADE_A = dict(chord_hub=45.0, chord_tip=42.0, stagger_hub=D(25), stagger_tip=D(45),
               camber_hub=D(35), camber_tip=D(20), lean=D(-4))
BLADE_B = dict(chord_hub=55.0, chord_tip=48.0, stagger_hub=D(35), stagger_tip=D(55),
               camber_hub=D(45), camber_tip=D(10), lean=D(8), max_thickness_hub=4.0,
               max_thickness_tip=2.2, le_radius=0.25, te_radius=0.4)
SCAN = dict(scan_like=True, scan_noise=0.002, seed=3)
#: name: (blade parameters, radial tilt degrees, machine)
CASES = {
    "A 88deg ac": (BLADE_A, 88.0, "ac-trunnion"),
    "A scan 88deg ac": ({**BLADE_A, **SCAN}, 88.0, "ac-trunnion"),
    "B 75deg bc": (BLADE_B, 75.0, "bc-trunnion"),
    "B scan 70deg ac": ({**BLADE_B, **SCAN, "seed": 7}, 70.0, "ac-trunnion"),
    "B 88deg head-table": (BLADE_B, 88.0, "bc-head-table"),
    # the two blades the project was tuned on (bench/bench_interpolation.py), for comparison
    "demo 75deg ac": ("demo", 75.0, "ac-trunnion"),
    "Rotor 37 75deg ac": ("rotor37", 75.0, "ac-trunnion"),
}


def blade(params, tilt, resolution=0.7, cusp=3.0, chord=0.002):
    if params in ("demo", "rotor37"):
        from bench.bench_interpolation import demo_case, rotor37_case

        return demo_case() if params == "demo" else rotor37_case(cusp=3.0)
    d = make_demo_blisk(resolution=resolution, fillet=True, fillet_radius=10.0, **params)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_radius=6.0, cusp=cusp, chord=chord, axis_mode="radial",
                      radial_tilt=D(tilt))
    return mesh, plan_paths(mesh, req).path


def measure(path, machine, md, tol, part):
    """Post with constant-error (``part``: None = before, "chord", or the mesh) and measure
    every cut block against the mesh. Returns (errors (B,), last-of-run mask (B,), report)."""
    opts = NcOptions(interpolation="constant-error", max_error=tol)
    reps: list = []
    post = "linuxcnc" if machine.kinematics == "table-table" else "fanuc"  # same joints
    if part == "before":
        from blisk_cam.core.post import export as E

        orig = E.interpolate_program
        E.interpolate_program = lambda *a, **k: orig(*a, **{**k, "part": None, "mesh": None})
        try:
            _, blocks = nc_program(path, machine, post, opts, reports=reps)
        finally:
            E.interpolate_program = orig
    else:
        _, blocks = nc_program(path, machine, post, opts, reports=reps,
                               part=None if part == "chord" else md)
    full = blocks.expanded()
    pose = full.poses
    cut = full.kind[pose] == MOVE_CUT
    err, ends = block_errors(machine, float(path.tool.r), md, full.xyz[pose],
                             np.degrees(full.angles[pose]), cut,
                             allowance=float(path.allowance))
    last = ~cut[np.minimum(ends + 1, len(cut) - 1)] | (ends + 1 >= len(cut))
    return err, last, reps[0]


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--max-error", type=float, default=0.01)
    ap.add_argument("--only", choices=tuple(CASES))
    args = ap.parse_args(argv)
    tol = args.max_error
    for name, (params, tilt, mname) in CASES.items():
        if args.only and name != args.only:
            continue
        t = time.perf_counter()
        mesh, path = blade(params, tilt)
        md = MeshDistance(mesh)
        machine = load_machine(mname)
        print(f"== {name}: {mesh.n_faces} triangles, {len(path.curves)} passes, "
              f"{len(path.program)} program rows, Ø12 ball, radial tilt {tilt:g}°, {mname} "
              f"(planned in {time.perf_counter() - t:.1f} s)")
        for part in ("before", "chord", "mesh"):
            t = time.perf_counter()
            err, last, rep = measure(path, machine, md, tol, part)
            r = err / tol
            band = (r >= 0.7) & (r <= 1.0)
            print(f"  {part:6s}: {len(err)} cut blocks, {int(np.sum(err > tol))} above "
                  f"{1000 * tol:g} µm (max {1000 * err.max():.2f} µm), in 70–100 %: "
                  f"{100 * band.mean():.1f} % (without each pass's last block "
                  f"{100 * band[~last].mean():.1f} %), range {100 * r.min():.1f}–"
                  f"{100 * r.max():.1f} %  [{time.perf_counter() - t:.1f} s]")


if __name__ == "__main__":
    main()
