"""The paths JSON of two reference requests does not change when the code is only made faster.

The digests (``plan_paths`` → ``write_paths_json``, the ``stats`` key dropped: it holds
timings) were recorded on numpy 1.26 before the speed work of issue 13. Floats are rounded to
1e-7 mm (1e-7 of a radian or ratio) before hashing, so last-bit differences between numpy
versions vanish: numpy 1.26 and 2.x differ by up to 4e-11 here, and at 1e-9 nine of 90k
values fell on different sides of a rounding step. They are not all: on the demo blade a
few zero-speed poses (the contact at the ball's tip) sit on the edge of the local-gouge test,
and their FLAG_LOCAL_GOUGE bit differs between numpy 1.26 and 2.x (10 of 4348 poses, every
float equal to 1e-9), so numpy 2 has its own demo digest (also recorded before issue 13).
A failing digest means the path changed: if that is intended, say why in the commit and
record the new digest here.

numpy's AVX-512 loops (chosen at run time on a host that has them) change last bits, and on
the demo blade that moves a few contacts lying on a mesh edge from one face to its neighbour,
whose curvature then flips their local-gouge flag (measured on an AMD EPYC with AVX-512: 4
program poses, every float within 4e-12 mm). The digests are of numpy's loops without
AVX-512: on a host with it, the plan runs in a new process with those loops switched off
(``NPY_DISABLE_CPU_FEATURES``), so the test holds on either kind of host.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

from blisk_cam.core.geometry.axis import Axis
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.process.blade_finish import PLAN_STAGES, PathRequest, plan_paths
from blisk_cam.core.runtime import parallel
from blisk_cam.core.toolpath.paths_io import write_paths_json
from tests.support.blades import nasa_blade

#: sha256 of the paths JSON without "stats", floats rounded to 1e-7 (see :func:`digest`).
#: The demo digest was re-recorded when the planned rapids began to leave and reach the
#: clearance surface along the tool axis (within 60° of radial) instead of radially: the
#: radial descent swept the tool body sideways through the stock (a 14 mm rapid crash in the
#: stock simulation). Re-recorded when the program's first entry (and last exit) came under
#: the link check: the demo's entry down the tool axis swept the ball 0.41 mm into the
#: leaning leading edge; it now comes down radially, which the check finds clear. Recorded on
#: an AMD EPYC host without AVX-512, where numpy 1.26 and 2.x give one and the same demo
#: path; on a host with AVX-512 the test switches numpy's AVX-512 loops off (module
#: docstring), with them the demo's digest is 0fdf968f… (4 poses' FLAG_LOCAL_GOUGE bit).
#: Rotor 37 is the same everywhere.
DIGESTS = {
    "demo": "84a7ca7bb90ab3a0d9ea8ae6e6c6189ecc2ad44176a1a734745bd6487dddd564",
    "rotor37": "de899b694a041295af839e9afecf2e164d98f2760c2caac2949eb37952b8116f",
}

#: why the demo digest is Linux's alone: measured with the Windows wheel in Windows CPython
#: 3.11 (numpy 1.26.4) under Wine 8, the demo path's 76 558 floats that differ from Linux's
#: differ by at most 1.2e-11 mm (the maths library's last bits), but one zero-speed pose's
#: FLAG_LOCAL_GOUGE bit flips, as between hosts above. Rotor 37's digest held there.
DEMO_ELSEWHERE = ("the demo digest was recorded on Linux: elsewhere a zero-speed pose's "
                  "local-gouge bit may flip (Windows under Wine: floats within 1.2e-11 mm)")

STAGE_KEYS = tuple(f"seconds_{s.name}" for s in PLAN_STAGES) + ("seconds_plan",)


def _rounded(o):
    if isinstance(o, float):
        r = round(o, 7)
        return 0.0 if r == 0 else r  # no "-0.0"
    if isinstance(o, list):
        return [_rounded(x) for x in o]
    if isinstance(o, dict):
        return {k: _rounded(v) for k, v in o.items()}
    return o


def as_before_issue_14(data: dict) -> dict:
    """The paths JSON as the code wrote it before two intended changes of issue 14, so the
    recorded digests still prove that nothing else changed: the top-level ``"warnings"``
    (zero cutting speed) is new, and the program no longer starts with two identical rapid
    poses (the first row is written once now; put back here)."""
    data = dict(data)
    data.pop("warnings", None)
    prog = data.get("program")
    if prog:
        assert prog["move"][0] == "rapid"
        data["program"] = {k: [v[0], *v] for k, v in prog.items()}
    return data


def digest(path, tmp_path) -> str:
    """sha256 of the written paths JSON without ``stats`` (as before issue 14, see
    :func:`as_before_issue_14`), floats rounded to 1e-7."""
    f = write_paths_json(path, tmp_path / "paths.json")
    data = as_before_issue_14(json.loads(Path(f).read_text(encoding="utf-8")))
    data.pop("stats", None)
    text = json.dumps(_rounded(data), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()


def demo_case():
    """The demo blade with the defaults of ``python -m blisk_cam demo`` (6 mm ball, cusp and
    chord 0.05 mm, the demo's true hub/tip cones)."""
    d = make_demo_blisk()
    mesh = TriMesh.from_arrays(d.blade_vertices, d.blade_faces)
    return mesh, PathRequest(axis=d.axis, cone1=d.hub_cone, cone2=d.tip_cone, cusp=0.05,
                             chord=0.05)


def rotor37_case():
    """Rotor 37 (extended open STL) between its json cones: ball R6, cusp 0.05, chord 0.05."""
    V, F, c1, c2 = nasa_blade("rotor37")
    req = PathRequest(axis=Axis(), cone1=c1, cone2=c2, tool_type="ball", tool_radius=6.0,
                      cusp=0.05, chord=0.05)
    return TriMesh.from_arrays(V, F), req


def avx512_dispatch() -> list[str]:
    """numpy's AVX-512 dispatch targets that run on this host (numpy 1.x: AVX512F,
    AVX512_SKX, …; 2.x: X86_V4, AVX512_ICL, …); [] on a host without them."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as umath
    return [t for t in umath.__cpu_dispatch__
            if (t.startswith("AVX512") or t == "X86_V4") and umath.__cpu_features__.get(t)]


def planned(name, kernels):
    """The planned path of case ``name`` on the installed kernels or numpy's; ``kernels`` =
    "installed-2" the installed ones on two threads (the passes then run a trial's level work
    beside its pass, see ``_Generator.cusp_between``)."""
    with (backend.numpy_only() if kernels == "numpy" else contextlib.nullcontext(),
          parallel(2 if kernels == "installed-2" else 1)):
        mesh, req = {"demo": demo_case, "rotor37": rotor37_case}[name]()
        path = plan_paths(mesh, req).path
        assert path.stats["kernels"] == backend.backend_name()
    return path


_IN_NEW_PROCESS = """
import json, sys, tempfile
from pathlib import Path
from tests.core.test_paths_digest import avx512_dispatch, digest, planned
left = avx512_dispatch()
assert not left, f"numpy's AVX-512 loops still on: {left}"
path = planned(sys.argv[1], sys.argv[2])
with tempfile.TemporaryDirectory() as tmp:
    print(json.dumps({"digest": digest(path, Path(tmp)), "stats": path.stats}))
"""


def digest_and_stats(name, kernels, tmp_path):
    """(digest, stats) of case ``name``: here, or on a host with AVX-512 in a new process
    with numpy's AVX-512 loops off (the recorded digests are of the loops without it)."""
    targets = avx512_dispatch()
    if not targets:
        path = planned(name, kernels)
        return digest(path, tmp_path), path.stats
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(targets))
    root = Path(__file__).resolve().parents[2]
    got = subprocess.run([sys.executable, "-c", _IN_NEW_PROCESS, name, kernels], cwd=root,
                         env=env, capture_output=True, text=True, timeout=600)
    assert got.returncode == 0, got.stderr[-3000:]
    out = json.loads(got.stdout.strip().splitlines()[-1])
    return out["digest"], out["stats"]


@pytest.mark.parametrize("kernels", ["installed", "installed-2", "numpy"])
@pytest.mark.parametrize("name", sorted(DIGESTS))
def test_paths_json_digest_is_unchanged(name, kernels, tmp_path):
    """On the installed kernels and, when they are the compiled ones, on the numpy
    reference too (the same digest: the compiled kernels change no output), and on two
    threads (the same digest: the thread count changes no output)."""
    if kernels == "numpy" and backend.extension() is None:
        pytest.skip("the numpy kernels are the installed ones: run above")
    if name == "demo" and not sys.platform.startswith("linux"):
        pytest.skip(DEMO_ELSEWHERE)
    found, st = digest_and_stats(name, kernels, tmp_path)
    assert found == DIGESTS[name], found
    # the per-stage times are finite, non-negative, and add up to the plan's time
    for key in STAGE_KEYS + ("seconds",):
        assert isinstance(st[key], float) and math.isfinite(st[key]) and st[key] >= 0.0, key
    parts = sum(st[f"seconds_{s.name}"] for s in PLAN_STAGES)
    assert st["seconds_plan"] == pytest.approx(parts, abs=0.05 + 0.02 * st["seconds_plan"])
    assert st["seconds"] <= st["seconds_passes"] + 1e-3
