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

from .cli.main import main  # noqa: E402

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
sys.exit(main())
