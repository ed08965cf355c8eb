"""runtime.one_blas_thread: numpy's and scipy's OpenBLAS on one thread inside the block (any
thread's), the counts before it back when the last block ends, nothing touched when the user
set ``OPENBLAS_NUM_THREADS``, and the same product bits on one thread as on several. The
counts are read back through OpenBLAS's own get function."""

import threading

import numpy as np
import pytest
import scipy.linalg  # noqa: F401 - scipy's OpenBLAS loaded, as in a planning process

from blisk_cam.core import runtime

CONTROLS = runtime._blas_thread_controls()
needs_openblas = pytest.mark.skipif(not CONTROLS, reason="no OpenBLAS loaded by numpy/scipy")


@pytest.fixture
def two_blas_threads(monkeypatch):
    """Every loaded OpenBLAS set to 2 threads (restored after the test), the variable unset."""
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    before = [get() for _, get in CONTROLS]
    for set_, _ in CONTROLS:
        set_(2)
    yield
    for (set_, _), n in zip(CONTROLS, before, strict=True):
        set_(n)


def counts():
    return [get() for _, get in CONTROLS]


@needs_openblas
def test_numpy_and_scipy_openblas_are_found():
    paths = runtime._loaded_openblas()
    assert len(CONTROLS) >= 1 and len(paths) >= len(CONTROLS)


@needs_openblas
def test_one_thread_inside_and_the_count_back_after(two_blas_threads):
    assert counts() == [2] * len(CONTROLS)
    with runtime.one_blas_thread():
        assert counts() == [1] * len(CONTROLS)
        with runtime.one_blas_thread():  # nested: still one, and not restored by the inner
            pass
        assert counts() == [1] * len(CONTROLS)
    assert counts() == [2] * len(CONTROLS)


@needs_openblas
def test_overlapping_blocks_of_two_threads_restore_when_the_last_ends(two_blas_threads):
    entered, leave = threading.Event(), threading.Event()

    def worker():
        with runtime.one_blas_thread():
            entered.set()
            leave.wait(10)

    t = threading.Thread(target=worker)
    with runtime.one_blas_thread():
        t.start()
        assert entered.wait(10)
    # this thread's block ended first: the worker's still holds one thread
    assert counts() == [1] * len(CONTROLS)
    leave.set()
    t.join(10)
    assert counts() == [2] * len(CONTROLS)


@needs_openblas
def test_the_users_variable_is_left_alone(monkeypatch, two_blas_threads):
    monkeypatch.setenv("OPENBLAS_NUM_THREADS", "2")
    with runtime.one_blas_thread():
        assert counts() == [2] * len(CONTROLS)


@needs_openblas
def test_the_products_have_the_same_bits_on_one_thread(two_blas_threads):
    rng = np.random.default_rng(7)
    p = rng.normal(size=(200_000, 3)) * 300.0
    m, d = rng.normal(size=(3, 3)), rng.normal(size=3)
    many = (p @ m, p @ d)
    with runtime.one_blas_thread():
        one = (p @ m, p @ d)
    for a, b in zip(many, one, strict=True):
        assert np.array_equal(a.view(np.uint64), b.view(np.uint64))


def test_on_one_blas_thread_runs_the_function_inside_the_block(monkeypatch):
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    seen = []
    got = runtime.on_one_blas_thread(lambda x: seen.append(runtime._BLAS_USERS) or x + 1)(41)
    assert got == 42 and seen == [1] and runtime._BLAS_USERS == 0
