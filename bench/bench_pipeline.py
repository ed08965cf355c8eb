"""Benchmark the whole batch run the user waits for (issue 13); prints figures (no assertions).

    python bench/bench_pipeline.py [--triangles 1000000] [--chord 0.01] [--no-verify]
    python bench/bench_pipeline.py --verify-only --only rotor37 --verify-triangles 20000

For the demo blade and Rotor 37 (subdivided), each at about ``--triangles`` triangles:

* the whole run as the CLI does it, through core functions (no bpy): read the binary STL
  from disk, weld (``TriMesh.from_arrays``), plan (``pipeline.plan_paths``: fit, passes,
  orient, link), write the paths JSON — wall time per stage and in total;
* the same run through the real command line (``python -m blisk_cam paths``, a new process:
  interpreter start and imports included), timed from outside, with its ``seconds_*`` stats;
* ``trimesh.intersections.mesh_multiplane`` for 50 planes of the same mesh in the same run,
  and the ratio whole run / trimesh (goal ≤ 2);
* ``verify.verify_path`` with 1 and 2 threads vs the plan's own time (goal: verify ≤ plan),
  for a ball and a bull-nose (R6, corner 2) path on the blade at ``--verify-triangles``
  (default 200k: verify at 1M takes minutes; ``--no-verify`` skips it, ``--verify-only``
  runs only it; ``--verify-triangles 20000`` is Rotor 37 as stored, ~20k triangles).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.core.errors import BliskCamError  # noqa: E402
from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.geometry.mesh_io import read_mesh  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.toolpath.paths_io import write_paths_json  # noqa: E402
from tests.support.blades import subdivided_blade  # noqa: E402
from tests.support.mesh_files import write_binary_stl  # noqa: E402

STAGES = ("seconds_fit", "seconds_passes", "seconds_orient", "seconds_link")


def demo_blade(target):
    res = float(np.sqrt(target / 100_000.0))  # resolution 1 ≈ 100k blade triangles
    d = make_demo_blisk(resolution=res)
    return d.blade_vertices, d.blade_faces, d.axis, d.hub_cone, d.tip_cone


def rotor37_blade(target):
    """Rotor 37 subdivided to about ``target`` triangles: V, F, axis, hub and tip cones."""
    V, F, c1, c2 = subdivided_blade("rotor37", target)
    return V, F, Axis(), c1, c2


def trimesh_multiplane(V, F, k=50):
    try:
        import trimesh
        from trimesh.intersections import mesh_multiplane
    except ImportError:
        return None
    tm = trimesh.Trimesh(V, F, process=False)
    z5, z95 = np.percentile(V[:, 2], [5, 95])
    z = np.linspace(float(z5), float(z95), k)
    t0 = time.perf_counter()
    mesh_multiplane(tm, [0, 0, 0], [0, 0, 1], z)
    return time.perf_counter() - t0


def whole_run(stl, axis, c1, c2, chord, out):
    """load → weld → plan → write, as the CLI does (core functions only)."""
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
    res = plan_paths(mesh, req)
    t["plan"] = time.perf_counter() - t1
    t1 = time.perf_counter()
    write_paths_json(res.path, out)
    t["write"] = time.perf_counter() - t1
    t["total"] = time.perf_counter() - t0
    return t, mesh, res.path


def cli_run(stl, axis, c1, c2, chord, out):
    """The same plan through ``python -m blisk_cam paths`` in a new process (what the user
    waits for at the prompt): (wall time seen from outside, the JSON's stats)."""
    cone = [str(x) for c in (c1, c2) for x in (c.r1, c.z1, c.r2, c.z2)]
    cmd = [sys.executable, "-m", "blisk_cam", "paths", "--mesh", str(stl),
           "--axis", *(str(x) for x in (*axis.origin, *axis.direction)),
           "--cone1", *cone[:4], "--cone2", *cone[4:], "--tool", "ball", "--tool-diameter",
           "12", "--cusp", "0.05", "--chord", str(chord), "--out", str(out)]
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"CLI failed ({done.returncode}): {done.stderr[-2000:]}")
    return wall, json.loads(Path(out).read_text())["stats"]


def bench_verify(name, V, F, axis, c1, c2, chord, threads=(1, 2), tools=("ball", "bull"),
                 bull_lead_tilt=(0.0, 0.0)):
    """Plan a ball and a bull-nose path (R6 corner 2, lead/tilt in degrees) on the mesh, then
    verify each with 1 and 2 threads; the figures of every run must be the same."""
    from dataclasses import replace

    from blisk_cam.core.verify.measure import verify_path

    mesh = TriMesh.from_arrays(V, F)
    ball = PathRequest(axis=axis, cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                       cusp=0.05, chord=chord)
    lead, tilt = (np.radians(float(x)) for x in bull_lead_tilt)
    bull = replace(ball, tool_type="bull", corner_radius=2.0, lead=lead, tilt=tilt)
    for req in (r for r in (ball, bull) if r.tool_type in tools):
        try:
            path = plan_paths(mesh, req).path
        except BliskCamError as exc:  # e.g. the demo's hub fillet is tighter than a bull
            print(f"[{name}] verify {req.tool_type}: not planned ({exc})", flush=True)
            continue
        plan = path.stats["seconds_plan"]
        runs = []
        for n in threads:
            t0, c0 = time.perf_counter(), time.process_time()
            rep = verify_path(mesh, path, workers=n)
            runs.append((n, time.perf_counter() - t0, rep))
            print(f"[{name}] verify {req.tool_type}, {n} thread(s): {runs[-1][1]:.2f} s wall, "
                  f"{time.process_time() - c0:.2f} s CPU", flush=True)
        same = all(r.summary() | {"timings": 0} == runs[0][2].summary() | {"timings": 0}
                   for _, _, r in runs)
        txt = ", ".join(f"{n} thread{'s' if n > 1 else ''} {dt:.2f} s" for n, dt, _ in runs)
        txt += "" if same else " (FIGURES DIFFER between thread counts)"
        steps = ", ".join(f"{k} {v:.2f}" for k, v in runs[-1][2].timings.items() if k != "total")
        print(f"[{name}] verify {req.tool_type}, {len(F):,} triangles, {path.n_poses:,} poses: "
              f"{txt}; speed-up x{runs[0][1] / runs[-1][1]:.2f}; plan {plan:.2f} s; "
              f"verify/plan {runs[-1][1] / plan:.2f} (goal <= 1); steps ({runs[-1][0]} threads) "
              f"{steps}", flush=True)


def bench_blade(name, V, F, axis, c1, c2, chord):
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / f"{name}.stl"
        write_binary_stl(stl, V, F)
        t_tm = trimesh_multiplane(V, F)
        t, mesh, path = whole_run(stl, axis, c1, c2, chord, Path(tmp) / "paths.json")
        cli_wall, cli = cli_run(stl, axis, c1, c2, chord, Path(tmp) / "cli.json")
    st = path.stats
    stages = ", ".join(f"{k[8:]} {st.get(k, float('nan')):.2f}" for k in STAGES)
    print(f"[{name}] {len(F):,} triangles, 6 mm ball, cusp 0.05, chord {chord}: whole run "
          f"{t['total']:.2f} s = load {t['load']:.2f} + weld {t['weld']:.2f} + plan "
          f"{t['plan']:.2f} ({stages}) + write {t['write']:.2f} s; "
          f"{path.n_poses:,} poses", flush=True)
    top = ("startup", "load", "weld", "plan", "verify")  # plan: the sum of its stages
    parts = [f"{k} {cli['seconds_' + k]:.2f}" for k in top if "seconds_" + k in cli]
    rest = cli_wall - sum(cli.get("seconds_" + k, 0.0) for k in top)
    print(f"[{name}] CLI `python -m blisk_cam paths` (new process): {cli_wall:.2f} s at the "
          f"prompt = {' + '.join(parts)} + write and exit {rest:.2f} s "
          f"(stats seconds_wall {cli.get('seconds_wall', float('nan')):.2f})", flush=True)
    if t_tm is None:
        print(f"[{name}] trimesh not installed: no mesh_multiplane comparison")
    else:
        print(f"[{name}] trimesh mesh_multiplane, 50 planes: {t_tm:.2f} s; whole run / trimesh "
              f"= {t['total'] / t_tm:.2f}, CLI at the prompt / trimesh = {cli_wall / t_tm:.2f} "
              "(goal ≤ 2)", flush=True)
    return mesh


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--triangles", type=int, default=1_000_000)
    ap.add_argument("--chord", type=float, default=0.01)
    ap.add_argument("--no-verify", action="store_true")
    ap.add_argument("--verify-triangles", type=int, default=200_000,
                    help="blade size for the verify comparison (verify at 1M takes minutes)")
    ap.add_argument("--only", choices=("demo", "rotor37"))
    ap.add_argument("--verify-only", action="store_true",
                    help="skip the whole-run figures, measure verify only")
    ap.add_argument("--threads", default="1,2", help="verify threads to compare, e.g. 1,2")
    ap.add_argument("--tools", default="ball,bull",
                    help="verify tools: ball, bull, or both as ball,bull (the default)")
    ap.add_argument("--bull-lead-tilt", default="0,0",
                    help="lead,tilt of the bull-nose path in degrees (Rotor 37 as stored: 10,5; "
                         "subdivided to 200k its hub region is too tight for a lead)")
    args = ap.parse_args()
    threads = tuple(int(x) for x in args.threads.split(","))
    tools = tuple(args.tools.split(","))
    if not tools or not set(tools) <= {"ball", "bull"}:
        ap.error(f"--tools takes ball, bull or ball,bull, got {args.tools!r}")
    blt = tuple(args.bull_lead_tilt.split(","))
    if args.only != "rotor37":
        if not args.verify_only:
            V, F, axis, c1, c2 = demo_blade(args.triangles)
            bench_blade("demo", V, F, axis, c1, c2, args.chord)
        if not args.no_verify:
            V, F, axis, c1, c2 = demo_blade(args.verify_triangles)
            bench_verify("demo", V, F, axis, c1, c2, args.chord, threads, tools, blt)
    if args.only != "demo":
        if not args.verify_only:
            bench_blade("rotor37 subdivided", *rotor37_blade(args.triangles), args.chord)
        if not args.no_verify:
            bench_verify("rotor37", *rotor37_blade(args.verify_triangles), args.chord,
                         threads, tools, blt)


if __name__ == "__main__":
    main()
