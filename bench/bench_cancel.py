"""How soon verify can stop: the longest stretch between two polls of the cancel hook
(``core.runtime.check_cancel``: before every chunk, task and step), and where it was; prints
figures (issue 28 row 7: Ctrl-C must act within 1 s).

    .venv/bpy45/bin/python bench/bench_cancel.py [--tool bull|ball] [--resolution 0.5]
        [--cusp 0.1] [--sigint 3]

Plans a path on the demo blade (Ø12, R2 for the bull nose), then runs ``verify_path`` with a
hook that records the time of every poll (and never asks to stop). ``--sigint S``: also runs
``paths --verify`` in a subprocess, sends SIGINT S seconds after verify started (its progress
line) and prints how long the process took to exit.
"""

from __future__ import annotations

import argparse
import math
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.part.blisk import make_demo_blisk  # noqa: E402
from blisk_cam.core.part.cones import Cone  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402
from blisk_cam.core.verify.measure import verify_path  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tool", default="bull", choices=("bull", "ball"))
    ap.add_argument("--resolution", type=float, default=0.5)
    ap.add_argument("--cusp", type=float, default=0.1)
    ap.add_argument("--sigint", type=float, default=0.0)
    a = ap.parse_args()
    d = make_demo_blisk(resolution=a.resolution, fillet=True, fillet_radius=10.0)
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    extra = {"tool_type": "bull", "corner_radius": 2.0} if a.tool == "bull" else {}
    req = PathRequest(axis=d.axis, cone1=Cone(170.0, -25.0, 185.0, 35.0), cone2=d.tip_cone,
                      tool_diameter=12.0, cusp=a.cusp, chord=0.05, axis_mode="radial",
                      radial_tilt=math.radians(75.0), **extra)
    path = plan_paths(mesh, req).path
    polls = []
    lock = threading.Lock()

    def hook():
        t = time.perf_counter()
        frames = [f for f in traceback.extract_stack()[:-1]
                  if Path(f.filename).name not in ("runtime.py", "bench_cancel.py",
                                                    "threading.py", "thread.py")]
        where = " < ".join(f"{Path(f.filename).name}:{f.lineno} {f.name}"
                           for f in frames[-3:][::-1])
        fr = sys._getframe(1)
        while fr is not None and fr.f_code.co_name != "_checked":
            fr = fr.f_back
        if fr is not None:  # a pool item: the function it runs
            fn = fr.f_locals.get("fn")
            code = getattr(fn, "__code__", None)
            where = (f"item {getattr(fn, '__qualname__', fn)} "
                     f"({Path(code.co_filename).name}:{code.co_firstlineno})" if code else where)
        with lock:
            polls.append((t, where))
        return False

    t0 = time.perf_counter()
    verify_path(mesh, path, cancel=hook)
    t1 = time.perf_counter()
    ts = np.array([t0] + [p[0] for p in polls] + [t1])
    gaps = np.diff(ts)
    print(f"{a.tool}: verify {t1 - t0:.2f} s, {len(polls)} polls, longest gap "
          f"{gaps.max():.3f} s; gaps > 0.5 s: {int(np.sum(gaps > 0.5))}")
    for k in np.argsort(gaps)[::-1][:5]:
        before = polls[k - 1][1] if k >= 1 else "start"
        nxt = polls[k][1] if k < len(polls) else "end"
        print(f"  {gaps[k]:.3f} s between [{before}] and [{nxt}]")
    if a.sigint > 0:
        with tempfile.TemporaryDirectory() as tmp:
            from tests.support.mesh_files import write_binary_stl

            stl = write_binary_stl(Path(tmp) / "b.stl", d.blade_vertices, d.blade_faces)
            cmd = [sys.executable, "-m", "blisk_cam", "paths", "--mesh", str(stl), "--cone1",
                   "170", "-25", "185", "35", "--cone2", *map(str, d.tip_cone.as_list()),
                   "--tool-diameter", "12", "--cusp", str(a.cusp), "--chord", "0.05",
                   "--axis-mode", "radial", "--radial-tilt", "75", "--verify",
                   "--out", str(Path(tmp) / "p.json")]
            if a.tool == "bull":
                cmd += ["--tool", "bull", "--corner-radius", "2"]
            p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.PIPE, text=True)
            for line in p.stderr:  # the progress lines: wait for verify to start
                if "verify" in line:
                    break
            time.sleep(a.sigint)
            ts = time.perf_counter()
            p.send_signal(signal.SIGINT)
            err = p.stderr.read()
            p.wait(timeout=300)
            print(f"SIGINT {a.sigint:g} s into verify: exited {time.perf_counter() - ts:.2f} s "
                  f"later with status {p.returncode}: {err.strip()[-120:]}")


if __name__ == "__main__":
    main()
