"""Benchmark of the panel's Generate on NASA Rotor 37 with verify (and its colour map) on;
prints figures (no assertions). Needs the bpy wheel.

    python bench/bench_panel.py [--repeat 1] [--no-map] [--cusp 0.05] [--chord 0.05]

The blade (tests/data/blades/rotor37_blade_extended_open.stl) is put in a factory scene as a
Blender object with its hub and tip cones; every other setting is the panel's default. Two
runs per repetition:

* synchronous — ``bpy.ops.blisk_cam.generate_paths()`` (EXEC, what background mode, the CLI
  and the tests do): the paths and the colour map appear together at the end and the UI is
  blocked the whole time;
* interactive — the operator's modal code stepped by hand (``ModalRunner``: timers do not
  fire in background mode) on an emulated 50 ms timer, as Blender runs it after ``invoke``:
  time until the paths are in the scene (the objects: with verify on, their JSON is stored a
  tick later, from the verify worker), time until the colour map is there (shown as soon
  as the worker has measured the material left, before its scallops), time until the other
  figures are attached (the run's end), the worker's verify time, the tick attaching the
  figures, and the longest single tick (the longest the UI is frozen) while planning
  (reading the mesh, writing the paths included) and while polling the verify worker (a
  tick only checks the thread, or shows the colour map; it may wait for the GIL).

Times run from the start of the operator (reading the mesh included). The planning stages'
figure is wall time (``seconds_plan``); the process CPU until the paths are shown is printed
beside it: ``bench_plan_cpu.py`` prints CPU seconds, and on a loaded machine the wall time of
the same work is longer (the panel plans the same request on the same mesh as the core:
``tests/blender/test_generate_core.py``; its worker thread takes the core's CPU time). The
machine may be shared: compare the figures of one run with each other.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

TICK = 0.05  # s, the operator's timer interval


def scene_with_rotor37(args):
    import bpy

    from blisk_cam.blender import objects as blender_io
    from tests.support.blades import nasa_blade

    bpy.ops.wm.read_factory_settings(use_empty=True)
    V, F, c1, c2 = nasa_blade("rotor37")
    blade = blender_io.arrays_to_object("Rotor37", V, F)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1 = c1.as_list()
    s.cone2 = c2.as_list()
    s.verify, s.verify_map = True, not args.no_map
    s.cusp, s.chord = args.cusp, args.chord
    return len(F)


def run_sync():
    import bpy

    t0 = time.perf_counter()
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    return time.perf_counter() - t0


def run_interactive():
    """Seconds: paths shown, colour map there, figures attached, longest ticks…"""
    import bpy

    from blisk_cam.blender import path_objects as output
    from blisk_cam.operators import generate_paths as gen
    from blisk_cam.operators.modal_job import ModalRunner

    ctx = bpy.context
    t0, c0 = time.perf_counter(), time.process_time()
    runner = ModalRunner(gen.BLISKCAM_OT_generate_paths, gen.PathJob(ctx))  # invoke
    runner.start(ctx)
    first_tick = time.perf_counter() - t0
    t_paths = t_map = t_done = None
    plan_ticks, verify_ticks, show_tick = [], [], 0.0
    next_fire = time.perf_counter() + TICK
    while True:
        now = time.perf_counter()
        if now < next_fire:
            time.sleep(next_fire - now)  # the UI is free between timer events
        a = time.perf_counter()
        result = runner.step(ctx)
        b = time.perf_counter()
        next_fire = max(next_fire + TICK, b)
        if t_paths is None and runner._job.paths_seconds is not None:
            t_paths, show_tick = b - t0, b - a
            cpu_paths = time.process_time() - c0
        elif t_paths is None:
            plan_ticks.append(b - a)
        else:
            verify_ticks.append(b - a)
        if t_map is None and getattr(runner._job, "map_shown", False):
            t_map = b - t0
        if result != {"RUNNING_MODAL"}:
            assert result == {"FINISHED"}, runner.reports
            t_done = b - t0
            break
    objs = output.output_objects(output.find_output_collection(runner._job.blade_name))
    if t_map is None and objs["verify"] is not None:  # shown with the figures, at the end
        t_map = t_done
    return {"paths": t_paths, "map": t_map, "done": t_done,
            "has_map": objs["verify"] is not None,
            "invoke": first_tick, "plan_tick": max(plan_ticks), "show_tick": show_tick,
            "poll_tick": max(verify_ticks[:-1] or [0.0]),
            "attach_tick": verify_ticks[-1] if verify_ticks else 0.0,
            "worker": runner._job.verify_seconds,
            "plan": runner._job.plan.path.stats.get("seconds_plan", float("nan")),
            "cpu_paths": cpu_paths}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--no-map", action="store_true", help="verify without the colour map")
    ap.add_argument("--cusp", type=float, default=0.05, help="mm (panel default 0.05)")
    ap.add_argument("--chord", type=float, default=0.05, help="mm (panel default 0.05)")
    args = ap.parse_args()

    import bpy

    import blisk_cam

    blisk_cam.register()
    try:
        n = scene_with_rotor37(args)
        s = bpy.context.scene.blisk_cam
        print(f"Rotor 37: {n:,} triangles; tool {s.tool_type} Ø{2 * s.tool_radius:g}, cusp "
              f"{s.cusp:g} mm, chord {s.chord:g} mm, verify on, colour map "
              f"{'off' if args.no_map else 'on'}; bpy {bpy.app.version_string}")
        sync, inter = [], []
        for k in range(args.repeat):
            scene_with_rotor37(args)
            sync.append(run_sync())
            scene_with_rotor37(args)
            inter.append(run_interactive())
            x = inter[-1]
            print(f"run {k + 1}: synchronous {sync[-1]:6.2f} s (paths and map together, the UI "
                  f"blocked throughout) | interactive: paths shown {x['paths']:6.2f} s, colour "
                  f"map {x['map'] or float('nan'):6.2f} s"
                  f"{'' if x['has_map'] else ' (no map object!)'}, figures {x['done']:6.2f} s "
                  f"(verify worker {x['worker']:.2f} s)")
            print(f"       planning stages {x['plan']:.2f} s wall; process CPU until the paths "
                  f"are shown {x['cpu_paths']:.2f} s (every thread: compare with "
                  "bench_plan_cpu.py's CPU, not with the stages' wall)")
            print(f"       the panel's own share: paths shown − planning stages "
                  f"{x['paths'] - x['plan']:.2f} s, colour map − paths shown "
                  f"{x['map'] - x['paths']:.2f} s = {(x['map'] - x['paths']) / x['worker']:.2f} × "
                  "the verify worker's time")
            print(f"       UI frozen at most: invoke (read the mesh) {1e3 * x['invoke']:.0f} ms, "
                  f"a planning tick {1e3 * x['plan_tick']:.0f} ms, writing the paths "
                  f"{1e3 * x['show_tick']:.0f} ms, a tick polling the worker (or showing the map) "
                  f"{1e3 * x['poll_tick']:.0f} ms, attaching the figures "
                  f"{1e3 * x['attach_tick']:.0f} ms")
        med = statistics.median
        ms_ = med(sync)
        mp, mm = med([x["paths"] for x in inter]), med([x["map"] or 0.0 for x in inter])
        md = med([x["done"] for x in inter])
        print(f"median of {args.repeat}: synchronous {ms_:.2f} s; interactive paths shown "
              f"{mp:.2f} s ({mp / ms_:.2f} of synchronous), colour map {mm:.2f} s "
              f"({mm / ms_:.2f}), figures {md:.2f} s ({md / ms_:.2f}); longest tick while "
              f"verifying "
              f"{1e3 * med([x['poll_tick'] for x in inter]):.0f} ms")
    finally:
        blisk_cam.unregister()


if __name__ == "__main__":
    main()
