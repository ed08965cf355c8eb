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
  time until the paths are in the scene, time until the colour map is there, the worker's
  verify time, the tick attaching the figures, and the longest single tick (the longest the
  UI is frozen) while planning (reading the mesh, writing the paths included) and while
  polling the verify worker (a tick only checks the thread; it may wait for the GIL).

Times run from the start of the operator (reading the mesh included). The machine may be
shared: compare the figures of one run with each other.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

BLADES = ROOT / "tests" / "data" / "blades"
TICK = 0.05  # s, the operator's timer interval


def scene_with_rotor37(args):
    import bpy

    from blisk_cam import blender_io
    from blisk_cam.core.mesh_io import read_mesh

    bpy.ops.wm.read_factory_settings(use_empty=True)
    V, F = read_mesh(BLADES / "rotor37_blade_extended_open.stl")[:2]
    cones = json.loads((BLADES / "rotor37_blade.json").read_text())["cones"]
    blade = blender_io.arrays_to_object("Rotor37", V, F)
    s = bpy.context.scene.blisk_cam
    s.blade = blade
    s.cone1 = (*cones["hub"]["P1_rz_mm"], *cones["hub"]["P2_rz_mm"])
    s.cone2 = (*cones["tip"]["P1_rz_mm"], *cones["tip"]["P2_rz_mm"])
    s.verify, s.verify_map = True, not args.no_map
    s.cusp, s.chord = args.cusp, args.chord
    return len(F)


def run_sync():
    import bpy

    t0 = time.perf_counter()
    assert bpy.ops.blisk_cam.generate_paths() == {"FINISHED"}
    return time.perf_counter() - t0


def run_interactive():
    """(paths shown, colour map there, longest tick planning, longest tick verifying), s."""
    import bpy

    from blisk_cam import output
    from blisk_cam.operators import generate_paths as gen
    from blisk_cam.operators.modal_job import ModalRunner

    ctx = bpy.context
    t0 = time.perf_counter()
    runner = ModalRunner(gen.BLISKCAM_OT_generate_paths, gen.PathJob(ctx))  # invoke
    runner.start(ctx)
    first_tick = time.perf_counter() - t0
    t_paths = t_map = None
    plan_ticks, verify_ticks = [first_tick], []
    next_fire = time.perf_counter() + TICK
    while True:
        now = time.perf_counter()
        if now < next_fire:
            time.sleep(next_fire - now)  # the UI is free between timer events
        a = time.perf_counter()
        result = runner.step(ctx)
        b = time.perf_counter()
        next_fire = max(next_fire + TICK, b)
        (plan_ticks if t_paths is None else verify_ticks).append(b - a)
        if t_paths is None and runner._job.written_json is not None:
            t_paths = b - t0
        if result != {"RUNNING_MODAL"}:
            assert result == {"FINISHED"}, runner.reports
            t_map = b - t0
            break
    objs = output.output_objects(output.find_output_collection(runner._job.blade_name))
    has_map = objs["verify"] is not None
    return (t_paths, t_map, max(plan_ticks), max(verify_ticks[:-1] or [0.0]), has_map,
            runner._job.verify_seconds, verify_ticks[-1] if verify_ticks else 0.0)


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
            tp, tm, mp, mv, has_map, tv, ta = inter[-1]
            print(f"run {k + 1}: synchronous {sync[-1]:6.2f} s (paths and map together, UI "
                  f"blocked throughout) | interactive: paths shown {tp:6.2f} s, colour map "
                  f"{tm:6.2f} s{'' if has_map else ' (no map object!)'} (worker {tv:.2f} s, "
                  f"attaching {1e3 * ta:.0f} ms); longest tick planning {1e3 * mp:5.0f} ms, "
                  f"polling the worker {1e3 * mv:5.0f} ms")
        med = statistics.median
        print(f"median of {args.repeat}: synchronous {med(sync):.2f} s; interactive paths "
              f"shown {med([x[0] for x in inter]):.2f} s "
              f"({med([x[0] for x in inter]) / med(sync):.2f} of synchronous), colour map "
              f"{med([x[1] for x in inter]):.2f} s; longest UI freeze while verifying "
              f"{1e3 * med([x[3] for x in inter]):.0f} ms")
    finally:
        blisk_cam.unregister()


if __name__ == "__main__":
    main()
