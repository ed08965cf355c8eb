"""A trial step of the passes runs its level work (the levels between passes A and B, their
samples, their distances to A) on a side thread while it makes pass B (issue 21,
``_Generator.cusp_between``): the same scallops, passes and caches as in the one-thread order;
on one thread, or on the numpy kernels, that order itself (no side thread); a failure while
making pass B waits for the side thread and goes up unchanged. The kept side thread of the
trials (``runtime.SideThread``) runs its calls on one thread, with one worker and the
caller's cancel hook."""

from __future__ import annotations

import contextlib
import itertools
import threading

import numpy as np
import pytest

from blisk_cam.core import runtime
from blisk_cam.core.geometry.mesh import TriMesh
from blisk_cam.core.kernels import backend
from blisk_cam.core.part.blisk import make_demo_blisk
from blisk_cam.core.paths import passes
from blisk_cam.core.paths.passes import _Generator
from blisk_cam.core.runtime import SideThread, alongside_in_turn, cancellable, parallel, workers
from tests.support.kernels import needs_compiled

compiled = needs_compiled(why="the trials run in the one-thread order")


@pytest.fixture(scope="module")
def demo():
    d = make_demo_blisk(resolution=0.5)
    return d, TriMesh.from_arrays(d.blade_vertices, d.blade_faces)


def _first_passes(demo, threads, k=6, numpy=False):
    """The generator after its first ``k`` passes (chord 0.01: several trials a pass), the
    threads the trials' level work ran on, and the measured scallops."""
    d, mesh = demo
    seen = []
    work = passes.trial_level_work

    def spy(*args):
        seen.append(threading.current_thread())
        return work(*args)

    kernels = backend.numpy_only() if numpy else contextlib.nullcontext()
    with pytest.MonkeyPatch.context() as mp, kernels, parallel(threads):
        mp.setattr(passes, "trial_level_work", spy)
        gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
        msgs = [p.message for p in itertools.islice(gen.run(), k)]
    return gen, seen, msgs


@compiled
def test_trials_on_two_threads_as_on_one(demo):
    one, seen1, msgs1 = _first_passes(demo, 1)
    two, seen2, msgs2 = _first_passes(demo, 2)
    assert seen1 == []  # one thread: the one-thread order, no side work
    # every trial of two threads ran its level work off the calling thread
    assert len(seen2) > 6 and all(t is not threading.main_thread() for t in seen2)
    assert msgs1 == msgs2  # the same ratios and scallops
    # the same caches: levels, samples (bit for bit), passes
    assert sorted(one._levels) == sorted(two._levels)
    assert sorted(one._level_samples) == sorted(two._level_samples) and len(one._level_samples) > 20
    for s, (p, n) in one._level_samples.items():
        q, m = two._level_samples[s]
        assert np.array_equal(p, q) and np.array_equal(n, m)
    for s in one._levels:
        for a, b in zip(one._levels[s], two._levels[s], strict=True):
            assert np.array_equal(a.points, b.points) and np.array_equal(a.edge, b.edge)
    assert sorted(one._passes) == sorted(two._passes)
    for s, curves in one._passes.items():
        for a, b in zip(curves, two._passes[s], strict=True):
            assert np.array_equal(a.tip, b.tip) and np.array_equal(a.axis, b.axis)


def test_numpy_kernels_keep_the_one_thread_order(demo):
    _, seen, msgs = _first_passes(demo, 2, k=2, numpy=True)
    assert seen == [] and len(msgs) == 2


@compiled
def test_error_making_pass_b_waits_for_the_side_thread(demo, monkeypatch):
    d, mesh = demo
    done = []
    work = passes.trial_level_work

    def slow(*args):
        out = work(*args)
        done.append(True)
        return out

    def boom(self, s):
        raise RuntimeError("no pass here")

    monkeypatch.setattr(passes, "trial_level_work", slow)
    with parallel(2):
        gen = _Generator(mesh, d.axis, d.hub_cone, d.tip_cone, 6.0, 0.05, 0.01)
        run = gen.run()
        next(run)  # the first two passes made
        trials = len(done)
        monkeypatch.setattr(_Generator, "make_pass", boom)
        with pytest.raises(RuntimeError, match="no pass here"):
            next(run)
    assert trials > 1 and len(done) == trials + 1  # the side thread had ended meanwhile


def test_side_thread_keeps_one_thread_and_hands_back_results_and_errors():
    seen = []

    def job(x):
        seen.append((threading.current_thread(), workers(), check_cancel_hook()))
        if x < 0:
            raise ValueError(f"bad {x}")
        return 2 * x

    stop = threading.Event()
    with cancellable(stop, "the test"), parallel(2), SideThread() as side:
        results = [side.alongside(lambda x=x: job(x)) for x in (1, 2)]
        assert [r() for r in results] == [2, 4]
        bad = side.alongside(lambda: job(-1))
        with pytest.raises(ValueError, match="bad -1"):
            bad()
        thread = seen[0][0]
    assert len(seen) == 3 and all(t is thread for t, _, _ in seen)  # one kept thread
    assert thread is not threading.current_thread() and not thread.is_alive()  # closed
    assert all(w == 1 and h for _, w, h in seen)  # one worker, the caller's cancel hook
    # on one thread: run where the result is asked for, when it is asked for
    seen.clear()
    with parallel(1), SideThread() as side:
        later = side.alongside(lambda: job(3))
        assert seen == []
        assert later() == 6 and seen[0][0] is threading.current_thread()


def test_alongside_in_turn_hands_back_each_result_as_soon_as_it_is_done():
    """The passes' tables: the sample tree first, its result handed back while the vertex-face
    table still builds after it, on the same thread; an error goes to its own result only."""
    seen = []
    release = threading.Event()

    def job(x):
        seen.append((x, threading.current_thread(), workers(), check_cancel_hook()))
        if x == 2:
            assert release.wait(10)  # still running when the first result is taken
        if x < 0:
            raise ValueError(f"bad {x}")
        return 2 * x

    stop = threading.Event()
    with cancellable(stop, "the test"), parallel(2):
        first, second, bad = alongside_in_turn(lambda: job(1), lambda: job(2), lambda: job(-1))
        assert first() == 2 and [x for x, *_ in seen] in ([1], [1, 2])  # job 2 not done
        release.set()
        assert second() == 4
        with pytest.raises(ValueError, match="bad -1"):
            bad()
    assert [x for x, *_ in seen] == [1, 2, -1]  # in the order given
    thread = seen[0][1]
    assert thread is not threading.current_thread() and all(t is thread for _, t, _, _ in seen)
    assert all(w == 1 and h for _, _, w, h in seen)  # one worker, the caller's cancel hook
    # on one thread: each runs where its result is asked for, when it is asked for
    seen.clear()
    with parallel(1):
        first, second = alongside_in_turn(lambda: job(3), lambda: job(4))
        assert seen == [] and second() == 8 and first() == 6
    assert [x for x, *_ in seen] == [4, 3] and seen[0][1] is threading.current_thread()


def check_cancel_hook():
    """Whether this thread sees a cancel hook (that of :func:`cancellable`)."""
    return runtime._CANCEL.get() is not None
