"""``python -m blisk_cam ...``: the command line (see :mod:`blisk_cam.cli`)."""

import sys

from .cli.allocator import use_one_heap
from .cli.blas import use_one_blas_thread

use_one_heap()  # before numpy's and the kernels' threads start (see cli/allocator.py)
use_one_blas_thread()  # before numpy loads OpenBLAS (see cli/blas.py)

try:
    import numpy  # noqa: F401 - the core needs numpy and scipy
    import scipy  # noqa: F401
except ImportError as exc:
    print(
        f"blisk_cam: error: this Python ({sys.executable}, {sys.version.split()[0]}) lacks "
        f"{exc.name}: run the command with the project's environment (.venv/bpy45/bin/python "
        "after 'make demo' or 'make test'), Blender's own Python (blender -b --python "
        "scripts/blender_cli.py -- ...), or pip install numpy scipy",
        file=sys.stderr,
    )
    sys.exit(1)

from .cli.main import main  # noqa: E402

sys.exit(main())
