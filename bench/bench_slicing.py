"""MeshConeSlicer against an older revision of it, on the levels a real run asks (issue 13).

For each blade (the demo, and Rotor 37 when the blades are there) subdivided to ``--faces``:
welds the mesh, runs the path planner once recording every ``slice`` level, then builds the
slicer of this tree and that of ``--against`` (slicing.py and mesh.py of that git revision)
on the same mesh and prints

- whether every LevelCurve (points, normals, edge, t, face, closed) is the same to the bit;
- the CPU time of the set-up (slicer + the generator's clipped morph field) and of all the
  recorded ``slice`` calls, old and new alternating call by call (ratios within one run are
  what counts on a shared machine).

    python bench/bench_slicing.py --against dfca822 --faces 1000000 --rounds 3
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import bench_pipeline as bp  # noqa: E402

from blisk_cam.core.geometry.mesh import TriMesh  # noqa: E402
from blisk_cam.core.paths import slicing  # noqa: E402
from blisk_cam.core.process.blade_finish import PathRequest, plan_paths  # noqa: E402


def old_slicing(rev: str):
    """slicing.py of ``rev`` as a module whose chaining is mesh.py of ``rev``."""
    tmp = Path(tempfile.mkdtemp())
    mods = {}
    for name in ("mesh", "slicing"):
        src = subprocess.run(["git", "show", f"{rev}:blisk_cam/core/{name}.py"], cwd=ROOT,
                             check=True, capture_output=True, text=True).stdout
        (tmp / f"{name}.py").write_text(src)
        spec = importlib.util.spec_from_file_location(f"blisk_cam.core._old_{name}",
                                                      tmp / f"{name}.py")
        mod = importlib.util.module_from_spec(spec)
        sys.modules[spec.name] = mod
        spec.loader.exec_module(mod)
        mods[name] = mod
    mods["slicing"].chain_graph_paths = mods["mesh"].chain_graph_paths
    return mods["slicing"]


def record_levels(mesh, axis, c1, c2):
    """Every s the planner slices at, in call order, and the slicer's arguments."""
    rec = {"s": [], "args": None}
    cls = slicing.MeshConeSlicer
    init0, slice0 = cls.__init__, cls.slice

    def init(self, mesh, axis, morph, **kw):
        rec["args"] = (axis, morph, kw)
        init0(self, mesh, axis, morph, **kw)

    def sl(self, s):
        rec["s"].append(float(s))
        return slice0(self, s)

    cls.__init__, cls.slice = init, sl
    try:
        plan_paths(mesh, PathRequest(axis=axis, cone1=c1, cone2=c2, tool_type="ball",
                                     tool_radius=6.0, cusp=0.05, chord=0.01))
    finally:
        cls.__init__, cls.slice = init0, slice0
    return rec


def same(a, b) -> bool:
    if len(a) != len(b):
        return False
    for x, y in zip(a, b, strict=True):
        if x.s != y.s or x.closed != y.closed:
            return False
        for f in ("points", "normals", "edge", "t", "face"):
            u, v = getattr(x, f), getattr(y, f)
            if u.dtype != v.dtype or u.shape != v.shape or u.tobytes() != v.tobytes():
                return False
    return True


def bench(name, V, F, axis, c1, c2, old, rounds):
    mesh = TriMesh.from_arrays(V, F)
    rec = record_levels(mesh, axis, c1, c2)
    axis, morph, kw = rec["args"]
    S = rec["s"]

    def build(mod):
        t0 = time.process_time()
        sl = mod.MeshConeSlicer(mesh, axis, morph, **kw)
        np.clip(sl.s, -1e6, 1e6)
        return sl, time.process_time() - t0

    t_init = {"old": 0.0, "new": 0.0}
    for r in range(rounds):
        pair = (("old", old), ("new", slicing)) if r % 2 == 0 else (("new", slicing), ("old", old))
        for k, mod in pair:
            t_init[k] += build(mod)[1]
    so, sn = build(old)[0], build(slicing)[0]
    bad = [s for s in S if not same(so.slice(s), sn.slice(s))]
    t = {"old": 0.0, "new": 0.0}
    for r in range(rounds):
        pair = (("old", so), ("new", sn)) if r % 2 == 0 else (("new", sn), ("old", so))
        for s in S:
            for k, sl in pair:
                t0 = time.process_time()
                sl.slice(s)
                t[k] += time.process_time() - t0
    print(f"{name}: {len(F)} faces, {len(S)} slice calls; identical: {not bad}"
          + (f" (differ at s = {bad[:3]})" if bad else ""))
    print(f"  set-up x{rounds}: old {t_init['old']:.3f} s, new {t_init['new']:.3f} s, "
          f"ratio {t_init['old'] / t_init['new']:.2f}")
    print(f"  slice  x{rounds}: old {t['old']:.3f} s, new {t['new']:.3f} s, "
          f"ratio {t['old'] / t['new']:.2f} ({1e3 * t['new'] / rounds / len(S):.2f} ms a call)")
    return not bad


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--against", required=True, help="git revision of the old slicer")
    ap.add_argument("--faces", type=int, default=1_000_000)
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args()
    old = old_slicing(a.against)
    ok = bench("demo", *bp.demo_blade(a.faces), old, a.rounds)
    ok &= bench("rotor37", *bp.rotor37_blade(a.faces), old, a.rounds)
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
