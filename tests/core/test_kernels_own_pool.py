"""A kernel asked for one worker runs on the calling thread itself (its one-worker pool is
that thread): from many short-lived Python threads, and from a thread that then asks for two
workers, the answers are scipy's."""

from __future__ import annotations

import threading

import numpy as np
from scipy.spatial import cKDTree

from blisk_cam.core.kernels import knn
from tests.support.kernels import needs_compiled

compiled = needs_compiled()


@compiled
def test_one_worker_kernels_on_many_threads_answer_as_scipy():
    rng = np.random.default_rng(7)
    pts = rng.normal(size=(3000, 3))
    queries = rng.normal(size=(16, 200, 3))
    want = [cKDTree(pts).query(q, k=4)[1] for q in queries]
    got, errors = {}, []

    def run(i):
        try:
            tree = knn.point_tree(pts, 1)
            # one worker (the thread's own pool, this thread), then two (the shared pool,
            # waited for by a thread that is itself a worker of its own pool), then one again
            got[i] = [knn.nearest_k(tree, queries[i], 4, np.inf, w) for w in (1, 2, 1)]
        except BaseException as exc:  # reported below, not lost in the thread
            errors.append(exc)

    for start in (0, 8):  # two waves: each thread new, each making its own pool
        threads = [threading.Thread(target=run, args=(i,)) for i in range(start, start + 8)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=120)
    assert not errors, errors
    assert sorted(got) == list(range(16))
    for i, answers in got.items():
        for a in answers:
            np.testing.assert_array_equal(a, want[i])
