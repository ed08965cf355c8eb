"""The compiled ``densify_by_normal_turn`` (``kernels/src/densify.rs``) against its numpy
reference in :mod:`blisk_cam.core.paths.sampling`: the same points, normals and segments to
the last bit, on numpy's loops of this host and, on a host with AVX-512, in a new process
with numpy's AVX-512 loops off (the loops of the recorded paths digests)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels import densify as compiled_densify
from blisk_cam.core.paths.sampling import densify_by_normal_turn
from tests.core.test_paths_digest import avx512_dispatch
from tests.support.kernels import needs_compiled

compiled = needs_compiled("densify_cosines", "densify_by_turn",
                          why="nothing to compare the numpy reference with")


def _turning(rng, k, sharp):
    """k points of a random walk (mm) with normals (not unit: ``unit`` runs on them) that
    turn slowly, with ``sharp`` of them turned by 60°–179.9° against their neighbour."""
    P = np.cumsum(rng.normal(0.0, 0.3, (k, 3)), axis=0)
    N = np.cumsum(rng.normal(0.0, 0.05, (k, 3)), axis=0) + [0.0, 0.0, 1.0]
    N *= rng.uniform(0.5, 2.0, (k, 1))
    for i in rng.choice(k, min(sharp, k), replace=False):
        ang = np.radians(rng.uniform(60.0, 179.9))
        u = N[i] / np.linalg.norm(N[i])
        w = np.cross(u, rng.normal(size=3))
        w /= np.linalg.norm(w)
        N[i] = np.cos(ang) * u + np.sin(ang) * w
    return P, N


def cases():
    """(name, points, normals, closed, max_turn): random polylines with sharp turns, open
    and closed; repeated normals (no turn: slerp's nearly-equal branch); turns of ~2e-8 rad
    split 1000-fold; one, two and three points."""
    rng = np.random.default_rng(21)
    out = []
    for k, sharp in ((500, 12), (2000, 40), (37, 5)):
        P, N = _turning(rng, k, sharp)
        for closed in (False, True):
            for max_turn in (0.01, 0.07, 0.6):
                out.append((f"walk{k}-{closed}-{max_turn}", P, N, closed, max_turn))
    P, N = _turning(rng, 50, 3)
    N[10:20] = N[10]  # equal normals: no turn
    out.append(("repeated", P, N, False, 0.01))
    a = np.array([0.0, 2e-8, 6e-8])  # turns of ~2e-8 rad: cos Ω one or two ulp below 1
    tiny = np.column_stack([np.cos(a), np.sin(a), np.zeros(3)])
    out.append(("tiny-turn", rng.normal(size=(3, 3)), tiny, False, 2e-11))
    out.append(("tiny-turn-closed", rng.normal(size=(3, 3)), tiny, True, 2e-11))
    P, N = _turning(rng, 60, 6)
    N[30] = np.nan  # NaN normals: no split there (numpy's NaN → int64 cast), NaN rows
    out.append(("nan", P, N, True, 0.05))
    out.append(("max-turn-0", P[:30], N[:30], False, 0.0))  # ∞ and NaN pieces: not split
    out.append(("max-turn-1e-300", P[:30], N[:30], False, 1e-300))  # beyond int64: not split
    for k in (1, 2, 3):
        P, N = _turning(rng, k, 1)
        for closed in (False, True):
            out.append((f"k{k}-{closed}", P, N, closed, 0.05))
    return out


def _bits(arrays):
    """dtype, shape and bytes of each array (every NaN made numpy's default one: NaNs carry
    their operands' sign and payload bits, which no caller reads)."""
    return [(a.dtype.str, a.shape, np.where(np.isnan(a), np.nan, a).tobytes().hex())
            for a in arrays]


def compare_all() -> dict:
    """Per case: whether the compiled result (None: the kernels declined) has the numpy
    reference's dtypes, shapes and bytes."""
    res = {}
    for name, P, N, closed, max_turn in cases():
        with np.errstate(all="ignore"):  # the NaN and max_turn = 0 cases
            got = compiled_densify.densify_by_normal_turn(P, N, closed, max_turn)
            with backend.numpy_only():
                ref = densify_by_normal_turn(P, N, closed, max_turn)
        res[name] = None if got is None else (_bits(got) == _bits(ref), len(ref[0]))
    return res


def _check(res):
    assert len(res) == len(cases())
    declined = sorted(n for n, r in res.items() if r is None)
    # only the one-point open polyline is left to numpy (nothing to densify)
    assert declined == ["k1-False"], declined
    assert all(r[0] for r in res.values() if r is not None), res
    # points were inserted in the sharp-turn cases (the slerp ran), none where nothing turns
    assert res["walk500-False-0.01"][1] > 600 and res["repeated"][1] > 50
    assert res["tiny-turn"][1] > 1000
    assert res["max-turn-0"][1] == res["max-turn-1e-300"][1] == 30


@compiled
def test_densify_compiled_is_numpys_bit_for_bit():
    """On this host's numpy loops (AVX-512 ones included: the arc cosines are numpy's)."""
    _check(compare_all())


_IN_NEW_PROCESS = """
import json
from tests.core.test_kernels_densify import compare_all
from tests.core.test_paths_digest import avx512_dispatch
assert not avx512_dispatch()
print(json.dumps(compare_all()))
"""


@compiled
def test_densify_compiled_is_numpys_bit_for_bit_without_avx512():
    """In a new process with numpy's AVX-512 loops off (the recorded digests' loops)."""
    targets = avx512_dispatch()
    if not targets:
        pytest.skip("no AVX-512 on this host: the test above ran numpy's only loops")
    env = dict(os.environ, NPY_DISABLE_CPU_FEATURES=" ".join(targets))
    root = Path(__file__).resolve().parents[2]
    got = subprocess.run([sys.executable, "-c", _IN_NEW_PROCESS], cwd=root, env=env,
                         capture_output=True, text=True, timeout=300)
    assert got.returncode == 0, got.stderr[-3000:]
    _check(json.loads(got.stdout.strip().splitlines()[-1]))


@compiled
def test_densify_anti_parallel_normals_fall_back_to_numpy():
    """A segment whose normals are opposite (slerp's turn through a perpendicular): the
    kernels decline and the public function gives the reference's result."""
    rng = np.random.default_rng(5)
    P, N = _turning(rng, 40, 0)
    N[19], N[20] = [0.0, 0.0, 2.0], [0.0, 0.0, -1.0]  # cos Ω = −1 exactly
    assert compiled_densify.densify_by_normal_turn(P, N, False, 0.1) is None
    got = densify_by_normal_turn(P, N, False, 0.1)
    with backend.numpy_only():
        ref = densify_by_normal_turn(P, N, False, 0.1)
    assert _bits(got) == _bits(ref)
    # the anti-parallel segment was split (the reference's perpendicular branch ran)
    assert np.count_nonzero(got[2] == 19) == int(np.ceil(np.pi / 0.1))
    # a turn of π cannot be split when max_turn ≥ π: nothing to slerp, the kernels run
    assert compiled_densify.densify_by_normal_turn(P, N, False, 3.5) is not None
