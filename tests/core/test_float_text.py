"""The paths JSON's float arrays written by the compiled kernel: the very bytes of the
numpy/json route (``json.dumps(a.tolist())``: Python's ``repr`` of each float, ties between
two shortest candidates to the even digit), and the whole file the same text."""

import contextlib
import json

import numpy as np
import pytest

from blisk_cam.core.kernels import backend
from blisk_cam.core.kernels.float_text import json_float_array
from blisk_cam.core.tool.cutter import Cutter
from blisk_cam.core.toolpath.paths_io import path_to_dict, paths_json_text
from tests.core.test_paths_io import _path

compiled = pytest.mark.skipif(json_float_array(np.zeros(0)) is None,
                              reason="the compiled kernels (with json_float_array) are not "
                                     "installed or numpy runs")

#: values whose text is tricky: signed zeros, both sides of the plain/exponent switch
#: (1e-4 | 1e-05, 1e15 | 1e+16), the extremes, and exact ties between two shortest candidates
#: (Python writes the even one: "987947971728212.2", "100.00003051757812")
SPECIAL = [0.0, -0.0, 1.0, 0.1, 0.30000000000000004, 1e-4, 9.999e-5, 1e-5, 1e15, 1e16,
           9999999999999998.0, 123456789012345678.0, 1e22, 5e-324, 2.0**-1022,
           1.7976931348623157e308, 1 / 3, 1234.5, 987947971728212.25, 100.000030517578125,
           9509689185.7265625, 241328668836.015625]


def _random_values(rng, n):
    """Random doubles of every kind: bit patterns, every exponent, few-bit dyadics (where
    ties live), mm coordinates."""
    bits = rng.integers(0, 2**64 - 1, size=n, dtype=np.uint64, endpoint=True).view(np.float64)
    # ldexp's exponent is a C int: int64 is refused where long is 32 bits (Windows, numpy 1.x)
    wide = np.ldexp(rng.random(n) + 1.0, rng.integers(-1074, 1024, size=n, dtype=np.int32))
    dyadic = np.ldexp(rng.integers(0, 2**53, size=n).astype(np.float64),
                      -rng.integers(0, 60, size=n, dtype=np.int32))
    mm = rng.normal(size=n) * 200.0
    x = np.concatenate([bits, wide, -dyadic, dyadic, mm])
    return x[np.isfinite(x)]


@compiled
def test_json_float_array_writes_the_bytes_of_json_dumps():
    rng = np.random.default_rng(21)
    x = np.concatenate([SPECIAL, -np.array(SPECIAL), _random_values(rng, 60_000)])
    assert json_float_array(x) == json.dumps(x.tolist())
    rows = x[: 3 * (len(x) // 3)].reshape(-1, 3)
    assert json_float_array(rows) == json.dumps(rows.tolist())
    for empty in (np.zeros(0), np.zeros((0, 3)), np.zeros((2, 0))):
        assert json_float_array(empty) == json.dumps(empty.tolist())
    # refused, for json.dumps to say so: not finite, or not 1-D / 2-D
    assert json_float_array(np.array([1.0, np.nan])) is None
    assert json_float_array(np.array([np.inf])) is None
    assert json_float_array(np.zeros((2, 2, 2))) is None


@pytest.mark.parametrize("kernels", ["installed", "numpy"])
def test_paths_json_text_is_json_dumps_of_the_dict(kernels):
    path = _path(Cutter.ball(6))
    path.curves[0].collision = {"status": np.zeros(len(path.curves[0].cc), np.int8),
                                "clearance": np.linspace(0.5, 2.0, len(path.curves[0].cc)),
                                "rotation": np.linspace(-0.1, 0.1, len(path.curves[0].cc))}
    path.curves[1].cc[0, 0] = 987947971728212.25  # a tie, in the middle of the file
    with backend.numpy_only() if kernels == "numpy" else contextlib.nullcontext():
        got = paths_json_text(path)
    assert got == json.dumps(path_to_dict(path), allow_nan=False)
    # a NUL in a string of the file (the kernel's placeholders are NUL-delimited): the same
    path.warnings = ["a\x000\x00b"]
    assert paths_json_text(path) == json.dumps(path_to_dict(path), allow_nan=False)
    path.curves[2].tip[1, 2] = np.nan  # JSON has no NaN: refused as json.dumps refuses it
    with pytest.raises(ValueError):
        paths_json_text(path)
