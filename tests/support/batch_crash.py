"""A task function for the batch tests: the first try of the task named ``CRASH_KEY`` ends
its worker process at once (``os._exit``, as a kill or an out-of-memory would); every other
run is the batch's own :func:`blisk_cam.batch.tasks.execute`. The marker file that says "tried
once" is named by the environment variable ``BLISK_BATCH_CRASH_MARK`` (a path in the test's
temporary folder), set before the cluster starts so the workers inherit it."""

from __future__ import annotations

import os

from blisk_cam.batch.tasks import execute

CRASH_KEY = "tube"


def crash_once(task):
    mark = os.environ.get("BLISK_BATCH_CRASH_MARK")
    if task.key == CRASH_KEY and mark and not os.path.exists(mark):
        with open(mark, "w") as fh:
            fh.write(str(os.getpid()))
        os._exit(17)
    return execute(task)
