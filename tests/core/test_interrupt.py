"""Issue 28 row 7: Ctrl-C acts at once in the threaded loops of verify (and every chunked
map of the core): when the calling thread is interrupted, the queued tasks are dropped and the
running ones stop at their next chunk, instead of the pool finishing every queued task first
(33-54 s after the signal on a bull-nose verify). Measured by counting the work done after
the signal, not by a clock."""

from __future__ import annotations

import signal
import threading
import time

import pytest

from blisk_cam.core.runtime import map_chunks, map_tasks, parallel


@pytest.mark.skipif(not hasattr(signal, "pthread_kill"),
                    reason="Windows: no signal can be sent to one thread (Ctrl-C there is a "
                           "console event, not a POSIX signal)")
def test_sigint_drops_queued_tasks_and_stops_running_chunks():
    main = threading.get_ident()
    lock = threading.Lock()
    started, chunks = [], []
    sent = threading.Event()

    def task(i):
        with lock:
            started.append((i, sent.is_set()))
        if i == 3:
            sent.set()
            signal.pthread_kill(main, signal.SIGINT)  # Ctrl-C, delivered to the main thread

        def chunk(s):
            with lock:
                chunks.append((i, sent.is_set()))
            time.sleep(0.002)  # some work per chunk

        map_chunks(chunk, 40, 1)
        return i

    with parallel(2), pytest.raises(KeyboardInterrupt):
        map_tasks(task, range(60))
    time.sleep(0.2)  # let the running tasks notice (they must not go on for 60 tasks)
    after = [i for i, late in started if late]
    late_chunks = [c for c in chunks if c[1]]
    # at most the tasks already running (2 threads) go on, for a few chunks (until the main
    # thread has the GIL to handle the signal); before: every queued task ran (~2300 chunks)
    assert len(after) <= 2, started
    assert len(late_chunks) <= 40, len(late_chunks)
