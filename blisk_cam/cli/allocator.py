"""The command-line process's memory allocator: one heap for every thread (glibc).

glibc's malloc gives each thread that allocates its own heap (an "arena"). The compiled
kernels' worker threads (rayon) allocate their buffers there; what they free stays in
their heap, where the main thread's next arrays cannot use it, so planning on two threads
held up to ~100 MB more at its peak than on one (Rotor 37 subdivided to 1.29M triangles:
809–949 MiB against 845 MiB; with one heap 790 MiB on two threads, the same CPU time).
``python -m blisk_cam`` asks for one heap before any thread starts; elsewhere (another
libc, Blender's process, the tests) nothing is changed.
"""

from __future__ import annotations

import os
import sys

__all__ = ["use_one_heap"]

#: mallopt's parameter number of the arena limit (glibc's malloc.h)
_M_ARENA_MAX = -8


def use_one_heap() -> bool:
    """Limit glibc's malloc to one arena (``mallopt(M_ARENA_MAX, 1)``), to be called before
    the process starts threads; True when it was set, False on another libc or platform
    (nothing is changed). ``MALLOC_ARENA_MAX`` in the environment, when set, is the user's
    choice and is left alone."""
    if not sys.platform.startswith("linux") or "MALLOC_ARENA_MAX" in os.environ:
        return False
    try:
        if not os.confstr("CS_GNU_LIBC_VERSION"):
            return False
        import ctypes

        return bool(ctypes.CDLL(None).mallopt(_M_ARENA_MAX, 1))
    except (ValueError, OSError, AttributeError):  # not glibc
        return False
