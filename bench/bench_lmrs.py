"""Benchmark LMRS (profile generatrices, paper 001 §4.2) against the LMC; prints figures.

    python bench/bench_lmrs.py [--triangles 1000000]

NASA Rotor 67 subdivided to about ``--triangles``: the morph field of every vertex and one
level's slice with (a) the json's straight hub cone (closed form, goal ≤ 50 ms per level) and
(b) the published hub line over the blade's axial extent ± 3 mm (an 81-segment profile).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_paths import timeit  # noqa: E402

from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.part.profiles import Profile, morph_between  # noqa: E402
from blisk_cam.core.paths.slicing import MeshConeSlicer  # noqa: E402
from tests.support.blades import blade_meta, subdivided_blade  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--triangles", type=int, default=1_000_000)
    args = ap.parse_args()
    meta = blade_meta("rotor67")
    cones = meta["cones"]
    z0, z1 = meta["blade_axial_extent_mm"]
    line = np.asarray(cones["hub"]["published_line_rz_mm"], float)
    inner = line[(line[:, 1] > z0 - 3) & (line[:, 1] < z1 + 3)]
    ends = [[np.interp(v, line[:, 1], line[:, 0]), v] for v in (z0 - 3, z1 + 3)]
    hub_profile = Profile(np.vstack([ends[0], inner, ends[1]]))
    hub_cone = Cone(*cones["hub"]["P1_rz_mm"], *cones["hub"]["P2_rz_mm"])
    tip = Cone(*cones["tip"]["P1_rz_mm"], *cones["tip"]["P2_rz_mm"])

    V, F, _, _ = subdivided_blade("rotor67", args.triangles)
    mesh = TriMesh.from_arrays(V, F)
    print(f"Rotor 67 subdivided: {len(mesh.F)} triangles, {len(mesh.V)} vertices")
    for name, g in (("straight hub cone (LMC)", hub_cone),
                    (f"hub profile, {len(hub_profile.points) - 1} segments (LMRS)", hub_profile)):
        morph = morph_between(g, tip)
        t_field, _ = timeit(lambda morph=morph: morph.ratio_of_points(mesh.V, Axis()), repeat=3)
        sl = MeshConeSlicer(mesh, Axis(), morph)
        sl.slice(0.5)  # warm-up
        t0 = time.perf_counter()
        n = 0
        for s in np.linspace(0.05, 0.95, 10):
            n += sum(len(c) for c in sl.slice(s))
        t_level = (time.perf_counter() - t0) / 10
        print(f"{name}: morph field of all vertices {t_field * 1e3:.0f} ms, "
              f"one level {t_level * 1e3:.1f} ms (goal ≤ 50 ms), {n / 10:.0f} points per level")


if __name__ == "__main__":
    main()
