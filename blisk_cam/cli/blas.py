"""The command-line process's BLAS threads: one (numpy's OpenBLAS).

numpy's matrix products over many points ((n, 3) @ (3, 3): frames, rotations) go to
OpenBLAS, which starts a thread per core and lets them spin after each product. The work
itself gains nothing from them (three columns), but on a 2-core machine the spinning takes
the core that a kernel's second worker needs: verify of Rotor 37 (Ø12 ball) used 1.53 s of
CPU for 1.06 s on one thread, and 1 → 2 threads gained ×1.64 instead of ×1.80
(`bench/bench_pipeline.py --verify-only`). The products give the same bits on any number of
BLAS threads (each output row is one thread's). ``python -m blisk_cam`` asks for one BLAS
thread before numpy loads; ``OPENBLAS_NUM_THREADS`` in the environment, when set, is the
user's choice and is left alone. Blender's process has numpy loaded already: nothing is
changed there.
"""

from __future__ import annotations

import os

__all__ = ["use_one_blas_thread"]

#: the variable OpenBLAS reads once, when numpy loads it
BLAS_THREADS_ENV = "OPENBLAS_NUM_THREADS"


def use_one_blas_thread() -> bool:
    """Set ``OPENBLAS_NUM_THREADS=1`` for this process unless the environment names a count
    already; True when it was set. Must run before numpy is imported to take effect."""
    if BLAS_THREADS_ENV in os.environ:
        return False
    os.environ[BLAS_THREADS_ENV] = "1"
    return True
