"""Benchmark the whole batch run the user waits for (issue 13); prints figures (no assertions).

    python bench/bench_pipeline.py [--triangles 1000000] [--chord 0.01] [--no-verify]
    python bench/bench_pipeline.py --verify-only --only rotor37 --verify-triangles 20000 \
        [--verify-repeat 3]

For the demo blade and Rotor 37 (subdivided), each at about ``--triangles`` triangles:

* the whole run as the CLI does it (on every core), through core functions (no bpy): read
  the binary STL from disk and weld it exactly as it is read (``mesh_io.read_stl_welded``,
  as the CLI), weld the rest (``TriMesh.from_arrays``), plan (``pipeline.plan_paths``:
  fit, passes, orient, link), write the paths JSON — wall time per stage and in total;
* the same run through the real command line (``python -m blisk_cam paths``, a new process:
  interpreter start and imports included), timed from outside, with its ``seconds_*`` stats
  and its peak memory (its resident high-water mark, MB);
* ``trimesh.intersections.mesh_multiplane`` for 50 planes of the same mesh in the same run,
  and the ratio whole run / trimesh (goal ≤ 1, issue 21);
* the plan's work — its CPU seconds on one thread — and the least the command line could take
  with that work spread perfectly over every core (its time outside the plan + work ÷
  cores), against trimesh: what no better threading of today's plan can go below;
* ``verify.verify_path`` with 1 and 2 threads vs the plan's own time (goal: verify ≤ plan),
  for a ball and a bull-nose (R6, corner 2) path on the blade at ``--verify-triangles``
  (default 200k: verify at 1M takes minutes; ``--no-verify`` skips it, ``--verify-only``
  runs only it; ``--verify-triangles 20000`` is Rotor 37 as stored, ~20k triangles);
* collision detection of 20k poses against ~2M obstacle triangles (bench_collision's case:
  the demo blade and ±2 neighbours) with 1 and 2 threads (``--no-collision`` skips it; it
  runs with ``--verify-only`` too).

The package's bytecode is compiled first (``compileall`` into its ``__pycache__``), as an
installed package (pip compiles on install) or any earlier run leaves it: where
``PYTHONDONTWRITEBYTECODE`` is set (as in the helpers' sessions) Python writes none, and
each CLI process compiled its ~70 modules from source, ~0.1 s of CPU in its startup
figure that a user's run does not have.

The process runs numpy's OpenBLAS on one thread, as ``python -m blisk_cam`` does
(``blisk_cam/cli/blas.py``; trimesh's planes too); ``OPENBLAS_NUM_THREADS`` set in the
environment wins, and the first line prints it.

Every figure is taken on each backend of ``--backends`` (default ``compiled,numpy``: the
compiled kernels, then ``BLISK_CAM_KERNELS=numpy``) in the same run, with the 1-minute load
average beside it (the machine may be shared: compare ratios within one run).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from blisk_cam.cli.blas import BLAS_THREADS_ENV, use_one_blas_thread  # noqa: E402

use_one_blas_thread()  # as `python -m blisk_cam` runs (before numpy loads OpenBLAS)

import numpy as np  # noqa: E402

from blisk_cam.core.errors import BliskCamError  # noqa: E402
from blisk_cam.core.geometry.axis import Axis  # noqa: E402
from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.geometry.mesh_io import read_mesh, read_stl_welded  # noqa: E402
from blisk_cam.core.kernels import backend  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.runtime import parallel  # noqa: E402
from blisk_cam.core.toolpath.paths_io import write_paths_json  # noqa: E402
from tests.support.blades import subdivided_blade  # noqa: E402
from tests.support.mesh_files import write_binary_stl  # noqa: E402

STAGES = ("seconds_fit", "seconds_passes", "seconds_orient", "seconds_link")
#: the backend the figures are taken on (set by :func:`on_backend`)
_BACKEND = {"name": "compiled"}


@contextlib.contextmanager
def on_backend(name):
    """Within the block the kernels of ``name`` ("compiled" or "numpy") run, in this
    process and in the CLI processes started from it."""
    _BACKEND["name"] = name
    with backend.numpy_only() if name == "numpy" else contextlib.nullcontext():
        yield


def compile_package() -> str:
    """Compile the package's modules to bytecode in their ``__pycache__`` (what a user's
    installation holds; the CLI processes then read it instead of compiling the sources,
    also where ``PYTHONDONTWRITEBYTECODE`` keeps Python from writing it). A line to print."""
    import compileall

    ok = compileall.compile_dir(str(ROOT / "blisk_cam"), quiet=1)
    env = os.environ.get("PYTHONDONTWRITEBYTECODE")
    return (f"bytecode of blisk_cam compiled first ({'ok' if ok else 'FAILED'}; "
            f"PYTHONDONTWRITEBYTECODE={env or 'unset'} here): the CLI starts as installed")


def load():
    """The 1-minute load average, for the figures' lines."""
    return f"load {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


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
    """load → weld → plan → write, as the CLI does (core functions only), on every core as
    the CLI's default ``--threads`` (outside ``runtime.parallel`` the kernels and the side
    threads would run on one: the figures before this run were taken so)."""
    with parallel(None):
        return _whole_run(stl, axis, c1, c2, chord, out)


def _whole_run(stl, axis, c1, c2, chord, out):
    t = {}
    t0 = time.perf_counter()
    got = read_stl_welded(stl)  # as the CLI: a binary STL welded exactly as it is read
    V, F, corners = (*read_mesh(stl), None) if got is None else got
    t["load"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    mesh = TriMesh.from_arrays(V, F, soup_corners=corners)
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


def plan_work(V, F, axis, c1, c2, chord):
    """CPU seconds of the plan alone on one thread (a new mesh of the same vertices and
    faces, so its caches are filled inside the timed call): the work the plan does, which
    no number of cores can spread below work ÷ cores."""
    mesh = TriMesh.from_arrays(V, F)
    req = PathRequest(axis=axis, cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                      cusp=0.05, chord=chord)
    with parallel(1):
        c0 = time.process_time()
        plan_paths(mesh, req)
        return time.process_time() - c0


def cli_run(stl, axis, c1, c2, chord, out):
    """The same plan through ``python -m blisk_cam paths`` in a new process (what the user
    waits for at the prompt): (wall time seen from outside, the JSON's stats with the
    process's peak resident memory added as ``peak_mb``)."""
    cone = [str(x) for c in (c1, c2) for x in (c.r1, c.z1, c.r2, c.z2)]
    cmd = [sys.executable, "-m", "blisk_cam", "paths", "--mesh", str(stl),
           "--axis", *(str(x) for x in (*axis.origin, *axis.direction)),
           "--cone1", *cone[:4], "--cone2", *cone[4:], "--tool", "ball", "--tool-diameter",
           "12", "--cusp", "0.05", "--chord", str(chord), "--out", str(out)]
    env = dict(os.environ)
    if _BACKEND["name"] == "numpy":
        env[backend.ENV] = "numpy"
    with tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=err, env=env)
        peak = _peak_memory_mb(proc)
        proc.wait()  # the exit seen at once (a poll every 50 ms added 0-50 ms to the wall)
        wall = time.perf_counter() - t0
        peak = peak()
        if proc.returncode != 0:
            err.seek(0)
            raise SystemExit(f"CLI failed ({proc.returncode}): {err.read()[-2000:]}")
    stats = json.loads(Path(out).read_text())["stats"]
    stats["peak_mb"] = peak
    return wall, stats


def _peak_memory_mb(proc, every=0.05):
    """Start reading ``proc``'s peak resident memory on a thread: the high-water mark of its
    own memory (VmHWM, /proc), read every ``every`` s until it exits. Returns a function
    that, once the caller has waited for ``proc``, gives it in MB (NaN where /proc is not
    there). Not ru_maxrss: on Linux a child started from this process inherits this
    process's resident size at the fork into that figure. The caller waits for the exit
    itself: the wall time then ends at the exit, not at the next read."""
    kb = []
    status = Path(f"/proc/{proc.pid}/status")
    done = threading.Event()

    def read():
        while not done.is_set():  # Popen returns after the exec: the CLI's own memory
            with contextlib.suppress(OSError, ValueError):
                kb.extend(float(x.split()[1]) for x in status.read_text().splitlines()
                          if x.startswith("VmHWM:"))
            done.wait(every)

    thread = threading.Thread(target=read, daemon=True)
    thread.start()

    def peak():
        done.set()
        thread.join()
        return max(kb) / 1024.0 if kb else float("nan")

    return peak


def bench_verify(name, V, F, axis, c1, c2, chord, threads=(1, 2), tools=("ball", "bull"),
                 bull_lead_tilt=(0.0, 0.0), repeat=1):
    """Plan a ball and a bull-nose path (R6 corner 2, lead/tilt in degrees) on the mesh, then
    verify each with 1 and 2 threads, ``repeat`` rounds of every thread count in turn (the
    fastest wall time of each count is its figure: this machine's speed drifts between runs);
    the figures of every run must be the same."""
    from dataclasses import replace

    from blisk_cam.core.verify.measure import verify_path

    result = {}
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
        bk = _BACKEND["name"]
        every = []
        for _ in range(max(1, int(repeat))):
            for n in threads:
                t0, c0 = time.perf_counter(), time.process_time()
                rep = verify_path(mesh, path, workers=n)
                cpu = time.process_time() - c0
                every.append((n, time.perf_counter() - t0, rep, cpu))
                print(f"[{name}, {bk}] verify {req.tool_type}, {n} thread(s): "
                      f"{every[-1][1]:.2f} s wall, {cpu:.2f} s CPU ({load()})", flush=True)
        runs = [min((r for r in every if r[0] == n), key=lambda r: r[1]) for n in threads]
        same = all(r.summary() | {"timings": 0} == every[0][2].summary() | {"timings": 0}
                   for _, _, r, _ in every)
        txt = ", ".join(f"{n} thread{'s' if n > 1 else ''} {dt:.2f} s" for n, dt, _, _ in runs)
        # verify's work (its CPU on one thread) spread perfectly over the most threads asked
        work = min((r[3] for r in every if r[0] == 1), default=float("nan"))
        floor = work / max(threads) / plan
        txt += "" if same else " (FIGURES DIFFER between thread counts)"
        steps = ", ".join(f"{k} {v:.2f}" for k, v in runs[-1][2].timings.items() if k != "total")
        print(f"[{name}, {bk}] verify {req.tool_type}, {len(F):,} triangles, "
              f"{path.n_poses:,} poses: {txt}; speed-up 1 -> {runs[-1][0]} threads "
              f"x{runs[0][1] / runs[-1][1]:.2f}; plan {plan:.2f} s; verify/plan "
              f"{runs[-1][1] / plan:.2f} (goal: ball <= 0.5, bull <= 1; its floor, the "
              f"one-thread work / {max(threads)} / plan, {floor:.2f}); steps "
              f"({runs[-1][0]} threads) {steps} ({load()})", flush=True)
        result[(name, req.tool_type, bk)] = rep_of = runs[-1][2].summary()
        rep_of.pop("timings")
    return result


def bench_blade(name, V, F, axis, c1, c2, chord, backends=("compiled",)):
    """The whole run on each backend, then trimesh's 50 planes and the ratios."""
    with tempfile.TemporaryDirectory() as tmp:
        stl = Path(tmp) / f"{name}.stl"
        write_binary_stl(stl, V, F)
        t_tm = trimesh_multiplane(V, F)
        runs = {}
        for bk in backends:
            with on_backend(bk):
                t, mesh, path = whole_run(stl, axis, c1, c2, chord, Path(tmp) / "paths.json")
                cli_wall, cli = cli_run(stl, axis, c1, c2, chord, Path(tmp) / "cli.json")
                runs[bk] = (t, cli_wall)
                _blade_lines(f"{name}, {bk}", F, chord, t, path, cli_wall, cli, t_tm)
                _floor_line(f"{name}, {bk}", plan_work(mesh.V, mesh.F, axis, c1, c2, chord),
                            cli_wall, cli, t_tm)
    if t_tm is not None:
        print(f"[{name}] trimesh mesh_multiplane, 50 planes: {t_tm:.2f} s; " + "; ".join(
            f"{bk}: whole run / trimesh {t['total'] / t_tm:.2f}, CLI / trimesh {w / t_tm:.2f}"
            for bk, (t, w) in runs.items()) + " (goal <= 1)", flush=True)
    if len(runs) > 1:
        (b0, (t0, w0)), (b1, (t1, w1)) = list(runs.items())[:2]
        print(f"[{name}] whole run {b1} / {b0}: x{t1['total'] / t0['total']:.2f} "
              f"(CLI x{w1 / w0:.2f})", flush=True)
    return mesh


def _blade_lines(name, F, chord, t, path, cli_wall, cli, t_tm):
    st = path.stats
    stages = ", ".join(f"{k[8:]} {st.get(k, float('nan')):.2f}" for k in STAGES)
    print(f"[{name}] {len(F):,} triangles, 6 mm ball, cusp 0.05, chord {chord}: whole run "
          f"{t['total']:.2f} s = load {t['load']:.2f} + weld {t['weld']:.2f} + plan "
          f"{t['plan']:.2f} ({stages}) + write {t['write']:.2f} s; "
          f"{path.n_poses:,} poses ({load()})", flush=True)
    top = ("startup", "load", "weld", "plan", "verify")  # plan: the sum of its stages
    parts = [f"{k} {cli['seconds_' + k]:.2f}" for k in top if "seconds_" + k in cli]
    rest = cli_wall - sum(cli.get("seconds_" + k, 0.0) for k in top)
    print(f"[{name}] CLI `python -m blisk_cam paths` (new process): {cli_wall:.2f} s at the "
          f"prompt = {' + '.join(parts)} + write and exit {rest:.2f} s "
          f"(stats seconds_wall {cli.get('seconds_wall', float('nan')):.2f}); peak memory "
          f"{cli['peak_mb']:.0f} MB (its resident high-water mark, read every 50 ms)", flush=True)
    if t_tm is None:
        print(f"[{name}] trimesh not installed: no mesh_multiplane comparison")


def _floor_line(name, work, cli_wall, cli, t_tm):
    """The least the CLI can take with the plan's work spread perfectly over every core:
    its time outside the plan (start, read, weld, write, exit) + work ÷ cores."""
    cores = os.cpu_count() or 1
    outside = cli_wall - cli.get("seconds_plan", float("nan"))
    floor = outside + work / cores
    txt = f" = {floor / t_tm:.2f} x trimesh" if t_tm else ""
    print(f"[{name}] the plan's work: {work:.2f} s of CPU on one thread; on {cores} cores "
          f"the CLI takes at least {outside:.2f} s outside the plan + {work:.2f} / {cores} = "
          f"{floor:.2f} s{txt} (its floor at a perfect use of every core)", flush=True)


def bench_collision(n_poses=20000, threads=(1, 2)):
    """Detection of ``n_poses`` poses against ~2M triangles (bench_collision's case) with
    each thread count: wall seconds and the speed-up; the colliding poses must agree."""
    from bench.bench_collision import HOLDER, vertex_normals
    from blisk_cam.core.collision.obstacles import Obstacles
    from blisk_cam.core.collision.scene import CollisionScene
    from blisk_cam.core.tool.assembly import ToolAssembly
    from blisk_cam.core.tool.cutter import Cutter

    d = make_demo_blisk(resolution=2.0, fillet=False, blade_count=24)
    V, F = d.blade_vertices, d.blade_faces
    rng = np.random.default_rng(0)
    vn = vertex_normals(V, F)
    pick = rng.choice(len(V), size=n_poses, replace=len(V) < n_poses)
    cc, n = V[pick], vn[pick]
    radial = cc - np.outer(cc @ d.axis.d, d.axis.d)
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    radial -= np.einsum("ij,ij->i", radial, n)[:, None] * n
    a = n + np.tan(np.radians(20.0)) * radial / np.maximum(
        np.linalg.norm(radial, axis=1), 1e-12)[:, None]
    a /= np.linalg.norm(a, axis=1)[:, None]
    cutter = Cutter.ball(3.0)
    tips = cutter.cl_points(cc, n, a)
    ob = Obstacles.build(V, F, d.axis, 24, 2, check_extra=False)
    sc = CollisionScene(ob, cutter, ToolAssembly(12.0, HOLDER, 1.0))
    bk = _BACKEND["name"]
    out = []
    for nt in threads:
        t0, c0 = time.perf_counter(), time.process_time()
        det = sc.detect(tips, a, workers=nt)
        out.append((nt, time.perf_counter() - t0, det.colliding.copy()))
        print(f"[collision, {bk}] {n_poses:,} poses x {ob.n_triangles:,} triangles, {nt} "
              f"thread(s): detect {out[-1][1]:.2f} s wall, {time.process_time() - c0:.2f} s "
              f"CPU, {int(det.colliding.sum()):,} colliding ({load()})", flush=True)
    same = all(np.array_equal(c, out[0][2]) for _, _, c in out)
    print(f"[collision, {bk}] speed-up 1 -> {out[-1][0]} threads x{out[0][1] / out[-1][1]:.2f}"
          f"{'' if same else ' (COLLISION STATUS DIFFERS between thread counts)'}; goal "
          f"<= 0.3 s", flush=True)
    return out[-1][2]


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
    ap.add_argument("--verify-repeat", type=int, default=1, metavar="K",
                    help="verify K times per thread count, in turn; the fastest counts")
    ap.add_argument("--tools", default="ball,bull",
                    help="verify tools: ball, bull, or both as ball,bull (the default)")
    ap.add_argument("--bull-lead-tilt", default="0,0",
                    help="lead,tilt of the bull-nose path in degrees (Rotor 37 as stored: 10,5; "
                         "subdivided to 200k its hub region is too tight for a lead)")
    ap.add_argument("--backends", default="compiled,numpy",
                    help="kernels to measure, in order: compiled, numpy or both")
    ap.add_argument("--no-collision", action="store_true")
    ap.add_argument("--collision-poses", type=int, default=20000)
    args = ap.parse_args()
    backends = tuple(args.backends.split(","))
    if not backends or not set(backends) <= {"compiled", "numpy"}:
        ap.error(f"--backends takes compiled, numpy or compiled,numpy, got {args.backends!r}")
    if "compiled" in backends and backend.extension() is None:
        print("compiled kernels not installed (make kernels): the numpy backend only")
        backends = ("numpy",)
    print(f"backends: {', '.join(backends)}; {load()}; BLAS threads "
          f"{os.environ.get(BLAS_THREADS_ENV)} (as the CLI: blisk_cam/cli/blas.py)", flush=True)
    if not args.verify_only:
        print(compile_package(), flush=True)
    threads = tuple(int(x) for x in args.threads.split(","))
    tools = tuple(args.tools.split(","))
    if not tools or not set(tools) <= {"ball", "bull"}:
        ap.error(f"--tools takes ball, bull or ball,bull, got {args.tools!r}")
    blt = tuple(args.bull_lead_tilt.split(","))
    reports = {}

    def verify_on_backends(name, blade):
        for bk in backends:
            with on_backend(bk):
                reports.update(bench_verify(name, *blade, args.chord, threads, tools, blt,
                                            args.verify_repeat))

    if args.only != "rotor37":
        if not args.verify_only:
            V, F, axis, c1, c2 = demo_blade(args.triangles)
            bench_blade("demo", V, F, axis, c1, c2, args.chord, backends)
        if not args.no_verify:
            verify_on_backends("demo", demo_blade(args.verify_triangles))
    if args.only != "demo":
        if not args.verify_only:
            bench_blade("rotor37 subdivided", *rotor37_blade(args.triangles), args.chord,
                        backends)
        if not args.no_verify:
            verify_on_backends("rotor37", rotor37_blade(args.verify_triangles))
    if len(backends) > 1:
        for (name, tool, bk), rep in reports.items():
            if bk == backends[0] and (name, tool, backends[1]) in reports:
                other = reports[(name, tool, backends[1])]
                diff = [k for k in rep if json.dumps(rep[k], default=str)
                        != json.dumps(other.get(k), default=str)]
                print(f"[{name}] verify {tool}: report figures on {' and '.join(backends)} "
                      + ("identical" if not diff else "differ in " + ", ".join(
                          f"{k} ({rep[k]} / {other.get(k)})" for k in diff)), flush=True)
    if not args.no_collision:
        status = []
        for bk in backends:
            with on_backend(bk):
                status.append(bench_collision(args.collision_poses, threads))
        if len(status) > 1:
            print(f"[collision] collision status per pose "
                  f"{'the same' if np.array_equal(*status[:2]) else 'DIFFERS'} on both "
                  "backends", flush=True)


if __name__ == "__main__":
    main()
