"""``python -m blisk_cam ...``: the batch command line (see :mod:`blisk_cam.cli`)."""

import sys

from .cli import main

sys.exit(main())
