"""``python -m blisk_cam ...``: the command line (see :mod:`blisk_cam.cli`)."""

import sys

from .cli.allocator import use_one_heap
from .cli.blas import use_one_blas_thread

use_one_heap()  # before numpy's and the kernels' threads start (see cli/allocator.py)
use_one_blas_thread()  # before numpy loads OpenBLAS (see cli/blas.py)

import importlib.util  # noqa: E402 - imported by ``-m`` already (runpy)

# the core needs numpy and scipy: scipy is found, not imported (its modules are imported where
# they are used: a paths run on the compiled kernels needs none of scipy.spatial's ~60 ms)
try:
    import numpy  # noqa: F401
    if importlib.util.find_spec("scipy") is None:
        raise ImportError("No module named 'scipy'", name="scipy")
except ImportError as exc:
    print(
        f"blisk_cam: error: this Python ({sys.executable}, {sys.version.split()[0]}) lacks "
        f"{exc.name}: run the command with the project's environment (.venv/bpy45/bin/python "
        "after 'make demo' or 'make test'), Blender's own Python (blender -b --python "
        "scripts/blender_cli.py -- ...), or pip install numpy scipy",
        file=sys.stderr,
    )
    sys.exit(1)

import gc  # noqa: E402
import os  # noqa: E402

from .cli.main import THREADED_COMMANDS, main  # noqa: E402


def leave(code: int):
    """Exit with ``code``. After a command that computes in this process (``paths``, ``nc``,
    ...: every output written and closed by now) the process ends at once (``os._exit``)
    once stdout and stderr are flushed: the interpreter's shutdown — a last collection,
    the modules torn down, the command's objects freed one by one — is skipped, and the
    operating system takes the memory back whole (a 1M-triangle paths run: ~0.02 s less
    CPU between the summary and the exit, 0.040 -> 0.020 s; Rotor 37 0.042 -> 0.024 s).
    The interpreter's own exit stays where its shutdown does work: under Blender (bpy
    unregisters its classes, saves nothing half-done), Dask (``batch``: its cluster's
    processes), a profiler or a tracer (``python -m cProfile``, coverage: they write their
    figures at exit), and when flushing fails (a closed pipe: reported as Python does)."""
    command = sys.argv[1] if len(sys.argv) > 1 else None
    watched = sys.getprofile() is not None or sys.gettrace() is not None or (
        hasattr(sys, "monitoring")  # Python 3.12+: cProfile and coverage use sys.monitoring
        and any(sys.monitoring.get_tool(i) is not None for i in range(6)))
    if (command not in THREADED_COMMANDS or watched or "bpy" in sys.modules
            or "distributed" in sys.modules):
        sys.exit(code)
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except (OSError, ValueError):
        sys.exit(code)
    os._exit(code)


# The objects made so far (the modules, their functions and classes) live until the exit: moved
# out of the collector's generations, no collection walks them again, during the run nor in
# the interpreter's shutdown. What the command leaves is NOT frozen: under bpy 4.5 (the demo
# command) Blender's objects left uncollected at exit hang the process. The youngest
# generation is collected after
# 50,000 net new containers instead of 700: the command's arrays are freed by their counts,
# not by the collector, and a 1M-triangle paths run spent ~0.025 s in ~100 collections that
# found ~600 objects.
gc.freeze()
gc.set_threshold(50_000, *gc.get_threshold()[1:])
leave(main())
