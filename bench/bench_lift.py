"""Where the passes stage spends its time: the lift (facet, intrusion, pose screens), the
cusp measure and the rest, on the demo blade (issue 13); prints figures (no assertions).

    python bench/bench_lift.py [--triangles 1000000] [--chord 0.01]

Runs ``generate_paths`` once (6 mm ball, cusp 0.05) with each of these generator methods
timed (wall, inclusive, summed over calls): ``facet_lift``, ``intrusion_lift`` (of which
``_lift_points``), ``_screened_shortfall``, ``measure_cusp``, the sample searches
(``_ProbeSamples.any_within``, ``_nearest_samples``) and the two k-d tree builds; plus the
number of passes built (trial passes included) and of searched ball centres.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_pipeline import demo_blade  # noqa: E402

from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.paths import passes as pathgen  # noqa: E402

TIMED = (
    (pathgen._Generator, "make_pass"),
    (pathgen._Generator, "facet_lift"),
    (pathgen._Generator, "intrusion_lift"),
    (pathgen._Generator, "_lift_points"),
    (pathgen._Generator, "_screened_shortfall"),
    (pathgen._Generator, "_nearest_samples"),
    (pathgen._Generator, "_probe_samples"),
    (pathgen._Generator, "_probe_tree"),
    (pathgen._ProbeSamples, "any_within"),
)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--chord", type=float, default=0.01)
    args = ap.parse_args()
    V, F, axis, c1, c2 = demo_blade(args.triangles)
    mesh = TriMesh.from_arrays(V, F)
    mesh.edges, mesh.face_normals, mesh.vertex_normals  # noqa: B018  (the fit stage's caches)
    secs, calls, rows = defaultdict(float), defaultdict(int), defaultdict(int)

    def timed(name, fn, count_rows):
        def wrapper(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                secs[name] += time.perf_counter() - t0
                calls[name] += 1
                if count_rows:
                    rows[name] += len(a[1])
        return wrapper

    for cls, name in TIMED:
        setattr(cls, name, timed(name, getattr(cls, name),
                                 name in ("any_within", "_nearest_samples")))
    pathgen.measure_cusp = timed("measure_cusp", pathgen.measure_cusp, False)
    t0 = time.perf_counter()
    path = pathgen.generate_paths(mesh, axis, c1, c2, tool_radius=6.0, cusp=0.05,
                                  chord=args.chord)
    total = time.perf_counter() - t0
    print(f"[demo] {len(mesh.F):,} triangles, chord {args.chord}: passes stage {total:.2f} s, "
          f"{path.stats['passes']} passes kept of {calls['make_pass']} built, "
          f"{path.n_poses:,} poses")
    for name in ("make_pass", "facet_lift", "intrusion_lift", "_lift_points",
                 "_screened_shortfall", "measure_cusp", "any_within", "_nearest_samples",
                 "_probe_samples", "_probe_tree"):
        extra = f", {rows[name]:,} centres" if name in rows else ""
        print(f"[demo]   {name:20s} {secs[name]:6.2f} s  ({calls[name]} calls{extra})")


if __name__ == "__main__":
    main()
