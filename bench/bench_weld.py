"""Benchmark the weld ``TriMesh.from_arrays`` as the CLI runs it (issue 13); prints figures.

    python bench/bench_weld.py [--triangles 1000000] [--repeat 5] [--blade demo|rotor37]

The blade (the demo blade, or Rotor 37 subdivided to about ``--triangles``) is written as a
binary STL and read back with ``mesh_io.read_mesh``, as ``python -m blisk_cam`` does: 3
corners per triangle, to be welded. Then ``TriMesh.from_arrays`` runs in fresh
subprocesses (a first call in a new process, as in the CLI: its arrays are new memory) and
``--repeat`` times in this process; wall and CPU seconds of each, and the mesh's counts.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.geometry.mesh_io import read_mesh  # noqa: E402
from tests.support.mesh_files import write_binary_stl  # noqa: E402

CHILD = """
import json, sys, time
sys.path.insert(0, {root!r})
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.geometry.mesh_io import read_mesh
V, F = read_mesh({stl!r})
t, c = time.perf_counter(), time.process_time()
TriMesh.from_arrays(V, F)
print(json.dumps([time.perf_counter() - t, time.process_time() - c]))
"""


def timed(V, F):
    t, c = time.perf_counter(), time.process_time()
    mesh = TriMesh.from_arrays(V, F)
    return time.perf_counter() - t, time.process_time() - c, mesh


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--fresh", type=int, default=3, help="runs in fresh subprocesses")
    ap.add_argument("--blade", choices=("demo", "rotor37"), default="demo")
    args = ap.parse_args()
    import bench_pipeline as bp

    if args.blade == "demo":
        V, F, *_ = bp.demo_blade(args.triangles)
    else:
        V, F, *_ = bp.rotor37_blade(args.triangles)
    with tempfile.TemporaryDirectory() as tmp:
        stl = str(Path(tmp) / "blade.stl")
        write_binary_stl(stl, V, F)
        V, F = read_mesh(stl)
        print(f"[{args.blade}] STL of {len(F):,} triangles, {len(V):,} corners")
        fresh = []
        for _ in range(args.fresh):
            out = subprocess.run([sys.executable, "-c", CHILD.format(root=str(ROOT), stl=stl)],
                                 capture_output=True, text=True, check=True).stdout
            fresh.append(json.loads(out.strip().splitlines()[-1]))
        runs, m = [], None
        for _ in range(args.repeat):
            m = None  # keep only the last mesh (and its caches) alive
            wall, cpu, m = timed(V, F)
            runs.append((wall, cpu))
    print(f"  mesh: {m.n_vertices:,} vertices, {m.n_faces:,} faces, welded "
          f"{m.welded_vertices:,}, flipped {m.flipped_faces:,}, dropped {m.dropped_faces:,}")
    for name, rows in (("fresh process", fresh), ("in process", runs)):
        wall = sorted(r[0] for r in rows)
        cpu = sorted(r[1] for r in rows)
        print(f"  from_arrays, {name:13s} (n={len(rows)}): wall min {wall[0]:.3f} s, "
              f"median {wall[len(wall) // 2]:.3f} s; CPU min {cpu[0]:.3f} s, "
              f"median {cpu[len(cpu) // 2]:.3f} s")


if __name__ == "__main__":
    main()
