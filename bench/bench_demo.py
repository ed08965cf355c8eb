"""Benchmark the demo-blisk generator; prints figures (no assertions).

    python bench/bench_demo.py [--max-resolution 4.5] [--trimesh]

For each resolution: blade triangles and vertices, generation time (clean and scan-like),
and the largest distance of the hub/tip boundary rows from their cones. Goal: ≥ 2M triangles
(resolution 4.5) in a few seconds on the 2-core machine. ``--trimesh`` also times
``TriMesh.from_arrays`` (weld, orient) on each blade.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.geometry.axis import meridional  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.blisk_params import blade_triangle_count  # noqa: E402


def cone_error(b) -> float:
    hub = b.blade_uv[:, 1] == 0.0
    tip = b.blade_uv[:, 1] == 1.0
    rh, zh = meridional(b.blade_vertices[hub], b.axis)
    rt, zt = meridional(b.blade_vertices[tip], b.axis)
    return max(
        float(np.abs(b.hub_cone.signed_distance(rh, zh)).max()),
        float(np.abs(b.tip_cone.signed_distance(rt, zt)).max()),
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--max-resolution", type=float, default=4.5)
    ap.add_argument("--trimesh", action="store_true")
    args = ap.parse_args()
    make_demo_blisk(resolution=0.2)  # warm-up (imports, caches)
    for res in (0.316, 1.0, 2.0, args.max_resolution):
        for scan in (False, True):
            t0 = time.perf_counter()
            b = make_demo_blisk(resolution=res, scan_like=scan)
            dt = time.perf_counter() - t0
            line = (
                f"[demo] resolution {res:5.3g} {'scan ' if scan else 'clean'}: "
                f"{len(b.blade_faces):>10,} triangles ({blade_triangle_count(res):,} nominal), "
                f"{len(b.blade_vertices):>9,} vertices, hub {len(b.hub_faces):,} triangles, "
                f"{dt:6.2f} s, boundary off the cones ≤ {cone_error(b):.1e} mm"
            )
            if args.trimesh:
                t0 = time.perf_counter()
                m = TriMesh.from_arrays(b.blade_vertices, b.blade_faces)
                line += (
                    f", TriMesh {time.perf_counter() - t0:.2f} s "
                    f"(flipped {m.flipped_faces}, loops {len(m.boundary_loops())})"
                )
            print(line, flush=True)
            del b


if __name__ == "__main__":
    main()
