"""Issue 28 row 16: how deep on-surface links would cut, and how many linking sends through
the air (Ø12 ball, cusp 0.05, chord 0.01, default linking) on the demo, Rotor 37 and 67.

Prints per blade: the links re-routed and the depth they would have cut (the plan's own
figure), then an independent measure of the finished program: every non-cut move sampled
every 0.005 mm, ball centre to the mesh minus ρ (signed), the deepest, and the link stage's
time. Run: ``python bench/bench_link_gouge.py [chord]``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.distance import MeshDistance
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths
from blisk_cam.core.toolpath.types import MOVE_CUT
from tests.support.blades import nasa_blade

RHO = 6.0


def cases(chord):
    d = make_demo_blisk()
    yield "demo", TriMesh.from_arrays(d.blade_vertices, d.blade_faces), PathRequest(
        axis=d.axis, cone1=d.hub_cone, cone2=d.tip_cone, tool_radius=RHO, cusp=0.05, chord=chord)
    for name in ("rotor37", "rotor67"):
        V, F, c1, c2 = nasa_blade(name)
        yield name, TriMesh.from_arrays(V, F), PathRequest(
            axis=Axis(), cone1=c1, cone2=c2, tool_type="ball", tool_radius=RHO, cusp=0.05,
            chord=chord)


def swept_depth(md, prog, spacing=0.005):
    rows = np.flatnonzero(prog.move[1:] != MOVE_CUT) + 1
    worst, at = 0.0, None
    for j in rows:
        L = float(np.linalg.norm(prog.tip[j] - prog.tip[j - 1]))
        t = np.linspace(0.0, 1.0, max(2, int(np.ceil(L / spacing)) + 1))[:, None]
        T = prog.tip[j - 1] * (1 - t) + prog.tip[j] * t
        A = prog.axis[j - 1] * (1 - t) + prog.axis[j] * t
        A /= np.linalg.norm(A, axis=1)[:, None]
        d = float(np.max(RHO - md.query(T + RHO * A).signed_distance))
        if d > worst:
            worst, at = d, int(j)
    return worst, at, len(rows)


def main():
    chord = float(sys.argv[1]) if len(sys.argv) > 1 else 0.01
    for name, mesh, req in cases(chord):
        t0 = time.perf_counter()
        path = plan_paths(mesh, req).path
        st = path.stats
        depth, row, n = swept_depth(MeshDistance(mesh), path.program)
        print(f"{name}: chord {chord}: {st['links_rerouted']} links re-routed "
              f"(would cut {st['links_rerouted_depth']:.4f} mm, "
              f"{st['links_rerouted_still_cutting']} still cut through the air; "
              f"{st['clearance_routes_cutting']} clearance routes cut "
              f"{st['clearance_routes_depth']:.4f} mm); "
              f"non-cut moves {n}, deepest "
              f"{depth:.4f} mm at row {row}; link stage {st['seconds_link']:.2f} s, plan "
              f"{time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
