"""pytest in Windows CPython under Wine (scripts/wine/windows_check.sh --suite).

Wine 8's ucrtbase has no ``cexp`` (Windows has), and numpy's complex exp would abort the
process; here it is computed from the real functions (the test harness only, never the
add-on: its one complex exp, ``geometry.axis.angular_span``, runs unchanged on Windows).
"""

import os
import sys

import numpy as np

_exp = np.exp


def _exp_without_cexp(x, *args, **kwargs):
    x = np.asarray(x)
    if np.iscomplexobj(x) and not args and not kwargs:
        return _exp(x.real) * (np.cos(x.imag) + 1j * np.sin(x.imag))
    return _exp(x, *args, **kwargs)


np.exp = _exp_without_cexp
os.chdir(os.environ["BLISK_CAM_ROOT"])
sys.path.insert(0, os.environ["BLISK_CAM_ROOT"])
import pytest  # noqa: E402

sys.exit(pytest.main(sys.argv[1:]))
