"""Benchmark of blisk_cam.core.collision: clearance of ~20k poses against ~2M obstacle
triangles (the demo blade and its ±2 neighbours), a plain per-pose KD-tree vertex check
(paper 004 Eqs. 7–9: point–axis distance of the mesh vertices near the tool) for comparison,
and avoidance (paper 004 §3) on the demo.

Detection poses: ball-end (Ø6) poses on the target blade — CC points at random blade
vertices, the axis leaned 20° away from the blisk axis from the vertex normal, the tip from
the contact; a Ø6 shank to 47 mm and a Ø24 holder to 107 mm (a narrow channel: many poses
collide). ``build`` is Obstacles.build + CollisionScene (the triangle tree), ``detect`` the
check of every pose; ``total`` what the user waits for.

Avoidance on the demo: the demo blisk (default resolution, 100k triangles, 24 blades, no
fillet), a Ø6 ball path between the hub and mid-span (radial axis, 20° tilt), the same
narrow holder, ±2 neighbours: ``run_collisions`` in mode "avoid" (obstacles, tree, detect,
rotate, lift, smooth, re-check), the path planning not counted.

Wall times depend on what else runs (the machine may be shared): the CPU seconds of the
process and the load average are printed beside them; compare ratios within one run.

Threads and backends: ``detect_by_threads`` times the check on 1 and 2 threads (medians of
``--repeat`` runs, wall and process CPU) and prints the speed-up 1 → 2 threads, for the
backend that runs (``kernels``: ``compiled 0.x`` or ``numpy``) and, with ``--both``, for the
numpy kernels too (the ratio compiled ÷ numpy beside). ``build_and_detect`` (and with
``--both`` ``build_and_detect_numpy``): the build (obstacles, triangle tree) and the first
check on the new scene, wall and CPU seconds, on 1 and 2 threads.

Run: ``python bench/bench_collision.py [--resolution 2.0] [--poses 20000]
[--baseline-poses 500] [--workers 2] [--mild] [--no-avoid] [--repeat 1] [--both]``; prints
the figures as JSON (not a timed test).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from blisk_cam.core.collision.obstacles import Obstacles  # noqa: E402
from blisk_cam.core.collision.scene import CollisionScene  # noqa: E402
from blisk_cam.core.kernels import backend  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.tool.assembly import ToolAssembly  # noqa: E402
from blisk_cam.core.tool.cutter import Cutter  # noqa: E402

HOLDER = ((12.0, 3.0), (47.0, 3.0), (47.0, 12.0), (107.0, 12.0))
#: --mild: a short stick-out (Ø6 shank to 22 mm): few poses collide
MILD = ((12.0, 3.0), (22.0, 3.0))


def vertex_normals(V, F):
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    vn = np.zeros_like(V)
    for i in range(3):
        np.add.at(vn, F[:, i], fn)
    return vn / np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]


def baseline(ob: Obstacles, assembly: ToolAssembly, cutter: Cutter, tips, axes):
    """Per pose: mesh vertices within the tool's bounding capsule pieces (cKDTree
    query_ball_point), then each vertex's distance to the axis minus the part radius at its
    height (paper 004 Eq. 7), the flute skipped on the target blade. Returns (m,) clearances
    (capped like the exact check)."""
    V = np.vstack([m.V for m in ob.meshes])
    owner = np.concatenate([np.full(len(m.V), i) for i, m in enumerate(ob.meshes)])
    tree = cKDTree(V)
    cap = assembly.safety + 5.0
    top = assembly.top
    zs = np.arange(0.0, top + 1e-9, 10.0)
    reach = math.hypot(5.0, assembly.max_radius) + cap
    out = np.full(len(tips), cap)
    fl = assembly.flute_length
    for i, (t, a) in enumerate(zip(tips, axes, strict=True)):
        idx = tree.query_ball_point(t + zs[:, None] * a, r=reach)
        j = np.unique(np.concatenate([np.asarray(x, dtype=np.int64) for x in idx]))
        if len(j) == 0:
            continue
        rel = V[j] - t
        z = rel @ a
        rho = np.sqrt(np.maximum(np.einsum("ij,ij->i", rel, rel) - z * z, 0.0))
        r = np.where(z >= fl, assembly.radius_at(z), cutter.max_radius)
        ok = (z >= 0) & (z <= top) & ((z >= fl) | (owner[j] != 0))
        if np.any(ok):
            out[i] = min(cap, float(np.min(rho[ok] - r[ok])))
    return out


class _Clock:
    """Wall and process-CPU seconds of a block."""

    def __enter__(self):
        self.t, self.c = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc):
        self.wall = time.perf_counter() - self.t
        self.cpu = time.process_time() - self.c


def detect_by_threads(sc, tips, axes, repeat: int) -> dict:
    """Median wall and CPU seconds of the check on 1 and 2 threads, and the speed-up."""
    out = {}
    for w in (1, 2):
        runs = []
        for _ in range(max(1, repeat)):
            with _Clock() as ck:
                sc.detect(tips, axes, workers=w)
            runs.append((ck.wall, ck.cpu))
        out[f"detect_{w}_thread_s"] = round(float(np.median([r[0] for r in runs])), 3)
        out[f"detect_{w}_thread_cpu_s"] = round(float(np.median([r[1] for r in runs])), 3)
    out["speedup_1_to_2_threads"] = round(out["detect_1_thread_s"] / out["detect_2_thread_s"], 2)
    return out


def build_detect_by_threads(V, F, axis, cutter, asm, tips, axes, repeat: int) -> dict:
    """Median wall and CPU seconds of the scene's build (Obstacles.build and the triangle
    tree) and of the first check on it, on 1 and 2 threads (``runtime.parallel`` for the
    build, ``workers`` for the check): what Check Collisions waits for."""
    from blisk_cam.core.runtime import parallel

    out = {}
    for w in (1, 2):
        runs = []
        for _ in range(max(1, repeat)):
            with parallel(w):
                with _Clock() as cb:
                    ob = Obstacles.build(V, F, axis, 24, 2, check_extra=False)
                    sc = CollisionScene(ob, cutter, asm)
                with _Clock() as cd:
                    sc.detect(tips, axes, workers=w)
            runs.append((cb.wall, cb.cpu, cd.wall, cd.cpu))
        med = np.median(np.array(runs), axis=0)
        for k, x in zip(("build_s", "build_cpu_s", "detect_s", "detect_cpu_s"), med,
                        strict=True):
            out[f"{k.split('_')[0]}_{w}_thread_{'_'.join(k.split('_')[1:])}"] = round(float(x), 3)
    return out


def avoid_on_demo(repeat: int = 1) -> dict:
    """Avoidance on the demo (module docstring): best of ``repeat`` runs."""
    from blisk_cam.core.collision.avoid import run_collisions
    from blisk_cam.core.collision.options import CollisionOptions
    from blisk_cam.core.geometry.mesh import TriMesh
    from blisk_cam.core.part.cones import Cone
    from blisk_cam.core.process.blade_finish import PathRequest, plan_paths

    d = make_demo_blisk(fillet=False, blade_count=24)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    h, t = d.hub_cone, d.tip_cone
    mid = Cone(0.5 * (h.r1 + t.r1), h.z1, 0.5 * (h.r2 + t.r2), h.z2)
    req = PathRequest(axis=d.axis, cone1=h, cone2=mid, tool_type="ball", tool_radius=3.0,
                      cusp=0.3, chord=0.05, axis_mode="radial", radial_tilt=math.radians(20))
    path = plan_paths(mesh, req).path
    opts = CollisionOptions(mode="avoid", blade_count=24, neighbours=2, flute_length=12.0,
                            holder=HOLDER, safety=1.0)
    best = None
    for _ in range(max(1, repeat)):
        with _Clock() as ck:
            _, rep = run_collisions(mesh, path, [], opts)
        if best is None or ck.wall < best.wall:
            best = ck
    return {"avoid_triangles": int(len(mesh.F)), "avoid_checked_poses": rep.n_checked,
            "avoid_colliding_before": rep.n_colliding_before,
            "avoid_corrected": rep.n_corrected, "avoid_unresolved": rep.n_unresolved,
            "avoid_s": round(best.wall, 3), "avoid_cpu_s": round(best.cpu, 3)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--resolution", type=float, default=2.0, help="demo blade resolution")
    ap.add_argument("--poses", type=int, default=20000)
    ap.add_argument("--baseline-poses", type=int, default=500)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--mild", action="store_true", help="slim holder: few collisions")
    ap.add_argument("--no-avoid", action="store_true", help="skip avoidance on the demo")
    ap.add_argument("--repeat", type=int, default=1, help="best of N runs (build, detect, "
                    "avoid); medians of N for the threads figures")
    ap.add_argument("--both", action="store_true", help="the threads figures of the numpy "
                    "kernels too")
    args = ap.parse_args()

    t0 = time.perf_counter()
    d = make_demo_blisk(resolution=args.resolution, fillet=False, blade_count=24)
    V, F = d.blade_vertices, d.blade_faces
    t_demo = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    vn = vertex_normals(V, F)
    pick = rng.choice(len(V), size=args.poses, replace=len(V) < args.poses)
    cc, n = V[pick], vn[pick]
    radial = cc - np.outer(cc @ d.axis.d, d.axis.d)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    radial -= np.einsum("ij,ij->i", radial, n)[:, None] * n
    a = n + math.tan(math.radians(20.0)) * radial / np.maximum(
        np.linalg.norm(radial, axis=1), 1e-12)[:, None]
    a /= np.linalg.norm(a, axis=1)[:, None]
    cutter = Cutter.ball(3.0)
    tips = cutter.cl_points(cc, n, a)
    asm = ToolAssembly(12.0, MILD if args.mild else HOLDER, 1.0)

    load0 = os.getloadavg()[0]
    build = detect = None
    for _ in range(max(1, args.repeat)):
        with _Clock() as cb:
            ob = Obstacles.build(V, F, d.axis, 24, 2, check_extra=False)
            sc = CollisionScene(ob, cutter, asm)
        with _Clock() as cd:
            det = sc.detect(tips, a, workers=args.workers)
        if build is None or cb.wall + cd.wall < build.wall + detect.wall:
            build, detect = cb, cd
    total = build.wall + detect.wall

    nb = min(args.baseline_poses, args.poses)
    t0 = time.perf_counter()
    base = baseline(ob, asm, cutter, tips[:nb], a[:nb])
    t_base = time.perf_counter() - t0
    t_base_all = t_base * args.poses / nb
    exact = det.clearance[:nb]
    out = {
        "kernels": backend.backend_name(),
        "assembly": asm.describe(),
        "obstacle_triangles": ob.n_triangles,
        "tree_triangles": int(ob.meshes[0].n_triangles),
        "poses": args.poses,
        "workers": args.workers,
        "load_average_1min": round(load0, 2),
        "demo_s": round(t_demo, 3),
        "build_s": round(build.wall, 3),
        "build_cpu_s": round(build.cpu, 3),
        "detect_s": round(detect.wall, 3),
        "detect_cpu_s": round(detect.cpu, 3),
        "total_s": round(total, 3),
        "detect_per_pose_us": round(1e6 * detect.wall / args.poses, 2),
        "colliding": int(det.colliding.sum()),
        "min_clearance": float(det.clearance.min()),
        "baseline_poses": nb,
        "baseline_s": round(t_base, 3),
        "baseline_s_extrapolated": round(t_base_all, 2),
        "speed_ratio_detect_vs_baseline": round(t_base_all / detect.wall, 1),
        "speed_ratio_total_vs_baseline": round(t_base_all / total, 1),
        "baseline_minus_exact_max_mm": float(np.max(base - exact)),
        "baseline_minus_exact_min_mm": float(np.min(base - exact)),
        "baseline_missed_collisions": int(np.sum((exact < 1.0) & (base >= 1.0))),
    }
    out["threads"] = detect_by_threads(sc, tips, a, args.repeat)
    out["build_and_detect"] = build_detect_by_threads(V, F, d.axis, cutter, asm, tips, a,
                                                      args.repeat)
    out["load_average_1min_after"] = round(os.getloadavg()[0], 2)
    if args.both and backend.extension() is not None:
        with backend.numpy_only():
            out["threads_numpy"] = detect_by_threads(sc, tips, a, args.repeat)
            out["build_and_detect_numpy"] = build_detect_by_threads(V, F, d.axis, cutter, asm,
                                                                    tips, a, args.repeat)
        out["detect_compiled_over_numpy_1_thread"] = round(
            out["threads"]["detect_1_thread_s"] / out["threads_numpy"]["detect_1_thread_s"], 3)
    if not args.no_avoid:
        out.update(avoid_on_demo(args.repeat))
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
