"""Figures of the link re-routing (blisk_cam.core.collision.reroute) on a demo scene.

Scene (as tests/core/test_link_avoidance.py): one side of the demo blade (24 blades, ±1
neighbours, the whole blade as the obstacle), passes from the hub to mid-span, every link
through the clearance cylinder (``direct_link=0``), a Ø6 ball with a Ø6 shank to 47 mm and a
Ø24 holder to 107 mm. The automatic clearance cylinder lies inside the blades' span, so the
planned rapids back to the start of the next pass cross the blade.

Run: ``python bench/bench_link_reroute.py [--resolution 0.3] [--cusp 0.6] [--floor]``
(``--floor``: a floor plate 150 mm under the blisk that blocks every retract, so no route
exists); prints the figures as JSON (counts, and the seconds of the avoidance with and
without re-routing — a shared machine: compare within one run).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from blisk_cam.core.collision.avoid import run_collisions  # noqa: E402
from blisk_cam.core.collision.obstacles import split_faces  # noqa: E402
from blisk_cam.core.collision.options import CollisionOptions  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.toolpath.types import MOVE_CUT  # noqa: E402

HOLDER = ((12.0, 3.0), (47.0, 3.0), (47.0, 12.0), (107.0, 12.0))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=float, default=0.3)
    ap.add_argument("--cusp", type=float, default=0.6)
    ap.add_argument("--floor", action="store_true")
    a = ap.parse_args(argv)
    d = make_demo_blisk(resolution=a.resolution, fillet=False, blade_count=24)
    V, F = d.blade_vertices, d.blade_faces
    T = V[F]
    c = T.mean(axis=1)
    n = np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0])
    th = np.arctan2(c[:, 1], c[:, 0])
    side = n[:, 0] * -np.sin(th) + n[:, 1] * np.cos(th) > 0
    (Vs, Fs), _ = split_faces(V, F, side)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=a.cusp, chord=0.1, axis_mode="radial",
                      radial_tilt=math.radians(20), direct_link=0.0)
    path = plan_paths(TriMesh.from_arrays(Vs, Fs), req).path
    extra = []
    if a.floor:
        Vp = np.array([[-1e3, -1e3, -150.0], [1e3, -1e3, -150.0], [1e3, 1e3, -150.0],
                       [-1e3, 1e3, -150.0]])
        extra = [("floor", Vp, np.array([[0, 1, 2], [0, 2, 3]]))]
    out = {"blade_triangles": int(len(F)), "passes": len(path.curves),
           "program_rows": len(path.program)}
    for mode in ("check", "avoid"):
        opts = CollisionOptions(mode=mode, blade_count=24, neighbours=1, flute_length=12.0,
                                holder=HOLDER, safety=1.0)
        t0 = time.perf_counter()
        p, rep = run_collisions((V, F), path, extra, opts)
        dt = time.perf_counter() - t0
        s = rep.summary()
        P = p.program
        out[mode] = {
            "seconds": round(dt, 3),
            **{k: s[k] for k in ("checked_poses", "colliding_before", "corrected",
                                 "unresolved", "link_runs", "links_colliding",
                                 "links_rerouted", "links_unresolved",
                                 "link_poses_colliding", "link_poses_rerouted")},
            "unresolved_link_rows": int(np.sum((P.curve < 0) & (P.collision_status == 2))),
            "unresolved_cut_rows": int(np.sum((P.curve >= 0) & (P.collision_status == 2)
                                              & (P.move == MOVE_CUT))),
            "first_unresolved_link": (s["unresolved_links"][0] if s["unresolved_links"]
                                      else None),
        }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
