"""The compiled kernels vs the numpy reference (issue 21); prints figures (no assertions).

    python bench/bench_kernels.py [--triangles 1000000] [--only demo|rotor37] [--threads N]

For the demo blade and Rotor 37 (subdivided) at about ``--triangles`` triangles, in one
process: the whole run as the CLI does it through core functions (read the binary STL,
weld, plan, write the paths JSON) once on each backend, with the stage times, whether the
two paths are the same, ``trimesh.intersections.mesh_multiplane`` for 50 planes and the
ratios whole run / trimesh (goal ≤ 1); then the kernels alone (forward step on the run's
polylines is inside ``passes``; the weld's exact-duplicate table on the STL's corners).
The backend names are printed; without the extension only the numpy figures are.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_pipeline import demo_blade, rotor37_blade, trimesh_multiplane  # noqa: E402

from blisk_cam.core.geometry import weld  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.geometry.mesh_io import read_mesh  # noqa: E402
from blisk_cam.core.kernels import backend  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.runtime import parallel  # noqa: E402
from blisk_cam.core.toolpath.paths_io import write_paths_json  # noqa: E402
from tests.support.mesh_files import write_binary_stl  # noqa: E402

STAGES = ("fit", "passes", "orient", "link")


def whole_run(stl, axis, c1, c2, chord, out, threads):
    t = {}
    t0 = time.perf_counter()
    V, F = read_mesh(stl)
    t["load"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    mesh = TriMesh.from_arrays(V, F)
    t["weld"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    req = PathRequest(axis=axis, cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                      cusp=0.05, chord=chord)
    with parallel(threads):
        res = plan_paths(mesh, req)
    t["plan"] = time.perf_counter() - t1
    for s in STAGES:
        t[s] = res.path.stats.get(f"seconds_{s}", float("nan"))
    t1 = time.perf_counter()
    write_paths_json(res.path, out)
    t["write"] = time.perf_counter() - t1
    t["total"] = time.perf_counter() - t0
    data = json.loads(Path(out).read_text())
    data.pop("stats", None)
    return t, res.path.stats["kernels"], data


def peak_rss_mb():
    try:
        import resource

        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    except ImportError:  # pragma: no cover - Windows
        return float("nan")


def bench_blade(name, V, F, axis, c1, c2, chord, threads, repeat=1):
    runs = {}
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / f"{name}.stl"
        write_binary_stl(stl, V, F)
        t_tm = trimesh_multiplane(V, F)
        order = ["compiled", "numpy"] if backend.extension() is not None else ["numpy"]
        for which in order * repeat:  # alternating; each figure the least of its runs
            ctx = backend.numpy_only() if which == "numpy" else _Nothing()
            with ctx:
                t, kname, data = whole_run(stl, axis, c1, c2, chord, Path(tmp) / "p.json",
                                           threads)
            if kname in runs:
                t = {k: min(v, runs[kname][0][k]) for k, v in t.items()}
                assert data == runs[kname][1], "the same backend gave two different paths"
            runs[kname] = (t, data)
            st = ", ".join(f"{k} {t[k]:.2f}" for k in ("load", "weld", *STAGES, "write"))
            ratio = ("" if t_tm is None
                     else f"; whole run / trimesh 50 planes {t['total'] / t_tm:.2f}")
            print(f"[{name}] {len(F):,} triangles, kernels {kname}: whole run "
                  f"{t['total']:.2f} s ({st}){ratio}", flush=True)
        cli_runs(name, stl, axis, c1, c2, chord, order)
        # the weld's exact-duplicate table alone, on the STL's corners
        Vs, _ = read_mesh(stl)
        cols = [np.ascontiguousarray(Vs[:, j]) + 0.0 for j in range(3)]
        for which in order:
            ctx = backend.numpy_only() if which == "numpy" else _Nothing()
            with ctx:
                t0 = time.perf_counter()
                weld._first_equal_point(cols)
                dt = time.perf_counter() - t0
            print(f"[{name}] weld exact-duplicate table, {len(Vs):,} corners, "
                  f"{backend.backend_name() if which != 'numpy' else 'numpy'}: {dt:.3f} s",
                  flush=True)
    if t_tm is not None:
        print(f"[{name}] trimesh mesh_multiplane, 50 planes: {t_tm:.2f} s")
    if len(runs) == 2:
        (tc, dc), (tn, dn) = runs.values()
        same = dc == dn
        print(f"[{name}] compiled / numpy whole run: {tc['total']:.2f} / {tn['total']:.2f} s "
              f"= x{tn['total'] / tc['total']:.2f} faster; passes x"
              f"{tn['passes'] / tc['passes']:.2f}; weld x{tn['weld'] / tc['weld']:.2f}; paths "
              f"JSON {'IDENTICAL' if same else 'DIFFERENT'} (stats aside)", flush=True)


def cli_runs(name, stl, axis, c1, c2, chord, order):
    """``python -m blisk_cam paths`` in a new process per backend (``BLISK_CAM_KERNELS``):
    wall time at the prompt and the process's peak memory (``/usr/bin/time``, where present)."""
    import shutil
    import subprocess

    cone = [str(x) for c in (c1, c2) for x in (c.r1, c.z1, c.r2, c.z2)]
    timer = shutil.which("time") and Path("/usr/bin/time").is_file()
    for which in order:
        env = dict(os.environ)
        env.pop(backend.ENV, None)
        if which == "numpy":
            env[backend.ENV] = "numpy"
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "p.json"
            cmd = [sys.executable, "-m", "blisk_cam", "paths", "--mesh", str(stl),
                   "--axis", *(str(x) for x in (*axis.origin, *axis.direction)),
                   "--cone1", *cone[:4], "--cone2", *cone[4:], "--tool", "ball",
                   "--tool-diameter", "12", "--cusp", "0.05", "--chord", str(chord),
                   "--out", str(out)]
            if timer:
                cmd = ["/usr/bin/time", "-f", "PEAK_KB %M", *cmd]
            t0 = time.perf_counter()
            done = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if done.returncode != 0:
                print(f"[{name}] CLI ({which}) failed: {done.stderr[-500:]}")
                continue
            kname = json.loads(out.read_text())["stats"].get("kernels", "?")
        peak = [ln.split()[1] for ln in done.stderr.splitlines() if ln.startswith("PEAK_KB")]
        mem = f", peak memory {int(peak[0]) / 1024:.0f} MB" if peak else ""
        print(f"[{name}] CLI `python -m blisk_cam paths` (new process), kernels {kname}: "
              f"{wall:.2f} s at the prompt{mem}", flush=True)


class _Nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--chord", type=float, default=0.01)
    ap.add_argument("--only", choices=("demo", "rotor37"))
    ap.add_argument("--threads", type=int, default=None, help="default: every core")
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs per backend, alternating; the least time of each is printed")
    args = ap.parse_args()
    print(f"kernels installed: {backend.backend_name()}; {os.cpu_count()} cores; load "
          f"{os.getloadavg()[0]:.1f} (other work on the machine slows every figure)", flush=True)
    if args.only != "rotor37":
        bench_blade("demo", *demo_blade(args.triangles), args.chord, args.threads, args.repeat)
    if args.only != "demo":
        bench_blade("rotor37", *rotor37_blade(args.triangles), args.chord, args.threads,
                    args.repeat)
    print(f"peak memory of this process (both backends, both blades): {peak_rss_mb():.0f} MB")


if __name__ == "__main__":
    main()
