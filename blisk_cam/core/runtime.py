"""Threads and cancellation for long core work: the worker count of a run
(:func:`parallel`), chunked maps over a thread pool, work beside the
calling thread (:func:`alongside`, :func:`alongside_in_turn`), the cooperative cancel poll
(:func:`cancellable`, :func:`check_cancel`, :class:`Cancelled`), and long
work's progress generators run to their end (:func:`run_to_end`), and numpy's and scipy's
OpenBLAS held to one thread while our work runs in a process that loaded them before us
(:func:`one_blas_thread`: Blender).
"""

from __future__ import annotations

import contextlib
import contextvars
import ctypes
import os
import sys
import threading
from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait
from dataclasses import dataclass

__all__ = [
    "Progress",
    "Cancelled",
    "cancellable",
    "check_cancel",
    "alongside",
    "alongside_in_turn",
    "SideThread",
    "map_chunks",
    "map_tasks",
    "one_blas_thread",
    "on_one_blas_thread",
    "parallel",
    "requested_workers",
    "run_to_end",
    "scaled_progress",
    "workers",
]
# threads for chunked queries (set by :func:`parallel`); 1 = run in the calling thread
_WORKERS = contextvars.ContextVar("blisk_cam_geometry_workers", default=1)
# the count of the innermost :func:`parallel` block around this code (None: no block)
_REQUESTED = contextvars.ContextVar("blisk_cam_requested_workers", default=None)


def default_workers() -> int:
    """The cores this process may use (``os.sched_getaffinity`` where available)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return max(1, os.cpu_count() or 1)


@contextlib.contextmanager
def parallel(workers: int | None):
    """Within the block, chunked queries (:func:`map_chunks`: nearest primitives, pairs within
    a radius, swept-cutter distances) and the compiled kernels run on ``workers`` threads.
    None: the count of an enclosing block (the caller's choice, e.g. the command line's
    ``--threads``, wins over a library default), else every core. numpy and scipy's k-d tree
    release the GIL in their loops; each chunk is computed exactly as on one thread, so the
    results do not depend on ``workers``."""
    if workers is None:
        n = _REQUESTED.get() or default_workers()
    else:
        n = max(1, int(workers))
    token = _WORKERS.set(n)
    asked = _REQUESTED.set(n)
    try:
        yield n
    finally:
        _REQUESTED.reset(asked)
        _WORKERS.reset(token)


def requested_workers() -> int | None:
    """The thread count of the innermost :func:`parallel` block around the caller, None
    outside every block (a library default, e.g. collision detection's two threads, may
    then apply)."""
    return _REQUESTED.get()


def workers() -> int:
    """The threads :func:`parallel` allows here (1 outside it, and inside a task of
    :func:`map_tasks`): the compiled kernels' rayon pools take this many."""
    return _WORKERS.get()


# the caller's cancel hook (set by :func:`cancellable`): (is-set callable, what is running)
_CANCEL = contextvars.ContextVar("blisk_cam_geometry_cancel", default=None)


class Cancelled(Exception):
    """A long computation stopped because its caller's cancel hook was set (ESC, a new run):
    not an input error; nothing of the computation is returned."""


@contextlib.contextmanager
def cancellable(cancel, what: str = "the computation"):
    """Within the block, :func:`check_cancel` (called by :func:`map_chunks` and
    :func:`map_tasks` before every chunk and task) raises :class:`Cancelled` once ``cancel``
    is set. ``cancel``: None (never), a ``threading.Event`` or a callable returning True to
    stop (polled from the worker threads too, so it must be thread-safe)."""
    if cancel is None:
        yield
        return
    test = getattr(cancel, "is_set", None)
    if test is None:
        if not callable(cancel):
            raise TypeError(f"cancel must be a threading.Event or a callable returning True to "
                            f"stop, got {type(cancel).__name__}")
        test = cancel
    token = _CANCEL.set((test, what))
    try:
        yield
    finally:
        _CANCEL.reset(token)


def check_cancel(hook=None):
    """Raise :class:`Cancelled` if the cancel hook of :func:`cancellable` (or ``hook``, a
    value of it taken in another thread) is set."""
    hook = _CANCEL.get() if hook is None else hook
    if hook is not None and hook[0]():
        raise Cancelled(f"{hook[1]} was cancelled by the caller; no figures were produced")


def map_chunks(fn, k: int, chunk: int):
    """``[fn(s) for s in range(0, k, chunk)]``, on the threads of :func:`parallel` when
    there are several chunks; the cancel hook of :func:`cancellable` is checked before every
    chunk."""
    return _map(fn, range(0, k, chunk), carry_hook=False)


def map_tasks(fn, items):
    """``[fn(x) for x in items]``, on the threads of :func:`parallel` when there are several
    items (independent tasks, e.g. one per pass level). Inside a task :func:`map_chunks`
    runs in its thread only (the pool's threads start from the default context), so the
    tasks are the unit of parallelism; the cancel hook is checked before every task and
    reaches the tasks' own chunks."""
    return _map(fn, items, carry_hook=True)


def alongside(fn):
    """Start ``fn()`` on a thread of its own when :func:`parallel` allows several threads, so
    that a step running on one core (e.g. building surface samples) overlaps the caller's
    next steps; returns a function that waits for ``fn``'s result and returns it (or raises
    its exception). With one thread ``fn`` runs, in the calling thread, when the result is
    asked for — the order of the work is then the caller's. The thread has the caller's
    cancel hook and one worker (its own chunked queries stay on it); ``fn`` must not touch
    what the caller's steps change meanwhile."""
    return alongside_in_turn(fn)[0]


def alongside_in_turn(*fns):
    """:func:`alongside` for several functions run one after the other on one thread of
    their own, in the order given: returns one waiting function per ``fn``, each returning
    (or raising) as soon as its own ``fn`` is done, while the later ones still run — the
    result the caller needs first goes first, and the builds do not run at once. With one
    thread each ``fn`` runs, in the calling thread, when its result is asked for."""
    if _WORKERS.get() < 2:
        return list(fns)
    ctx = contextvars.copy_context()
    ctx.run(_WORKERS.set, 1)
    boxes = [{} for _ in fns]
    done = [threading.Event() for _ in fns]

    def run():
        for fn, box, ev in zip(fns, boxes, done, strict=True):
            try:
                box["value"] = ctx.run(fn)
            except BaseException as exc:  # handed to the caller by its result()
                box["error"] = exc
            finally:
                ev.set()

    thread = threading.Thread(target=run, name="blisk_cam-alongside", daemon=True)
    thread.start()

    def result_of(box, ev):
        def result():
            ev.wait()
            if "error" in box:
                raise box["error"]
            return box["value"]
        return result

    return [result_of(box, ev) for box, ev in zip(boxes, done, strict=True)]


class SideThread:
    """One thread kept for work beside the calling thread, call after call: :meth:`alongside`
    is :func:`alongside` without a new thread per call (~0.1 ms to start, and the compiled
    kernels make a one-worker pool for each new thread that calls them, ~0.15 ms, kept until
    the process ends). The thread starts on the first call that runs beside; :meth:`close`
    ends it (a context manager closes on exit)."""

    def __init__(self):
        self._pool = None

    def alongside(self, fn):
        """As :func:`alongside`: ``fn()`` on the kept thread when :func:`parallel` allows
        several threads (the caller's cancel hook, one worker), else in the calling thread
        when the result is asked for; returns the function that waits for the result (or
        raises ``fn``'s exception). One call at a time runs; later ones queue."""
        if _WORKERS.get() < 2:
            return fn
        if self._pool is None:
            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="blisk_cam-side")
        ctx = contextvars.copy_context()
        ctx.run(_WORKERS.set, 1)
        return self._pool.submit(ctx.run, fn).result

    def close(self):
        """End the thread (after the work queued on it)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _map(fn, items, *, carry_hook: bool):
    """``[fn(x) for x in items]`` on up to :func:`parallel` threads, the cancel hook checked
    before every item (and, with ``carry_hook``, set in the pool thread's context while the
    item runs, so its own chunks check it too). When an item raises (``Cancelled`` or an
    error), or the calling thread is interrupted (Ctrl-C: ``KeyboardInterrupt`` while it
    waits), the items not started yet are dropped, not run, and the running items stop at
    their next chunk (the hook they carry is set too) — the caller does not wait for the
    whole queue."""
    items = list(items)
    n = min(_WORKERS.get(), len(items))
    hook = _CANCEL.get()
    if n <= 1:
        if hook is not None:
            return [_checked(fn, x, hook, carry_hook) for x in items]
        return [fn(x) for x in items]
    # once an item has raised (or the caller was interrupted), the items a pool thread starts
    # afterwards return at once without running: a thread that finishes its item could
    # otherwise start, poll and fail every queued item before this thread wakes up
    failed = threading.Event()
    what = hook[1] if hook is not None else "the computation"

    def stop():
        return failed.is_set() or (hook is not None and bool(hook[0]()))

    inner_hook = (stop, what)

    def guarded(x):
        if failed.is_set():
            return None  # never read: an earlier item's exception is raised below
        try:
            return _checked(fn, x, inner_hook, carry_hook)
        except BaseException:
            failed.set()
            raise

    ex = ThreadPoolExecutor(max_workers=n)
    futures = []
    try:
        futures = [ex.submit(guarded, x) for x in items]
        _, pending = wait(futures, return_when=FIRST_EXCEPTION)
        for f in pending:  # an item raised: the items not started are not run (the pool
            f.cancel()  # starts them in order, so the failed one comes first below)
        return [f.result() for f in futures]
    except BaseException:  # an item's error, or Ctrl-C in this thread while it waited
        failed.set()
        for f in futures:
            f.cancel()
        raise
    finally:
        # after a failure the running items end at their next poll; the queue is dropped
        ex.shutdown(wait=not failed.is_set(), cancel_futures=True)


def _checked(fn, x, hook, carry_hook):
    """``fn(x)`` after polling ``hook``; with ``carry_hook`` the hook is this thread's cancel
    hook while ``fn`` runs (its chunks poll it)."""
    check_cancel(hook)
    if not carry_hook:
        return fn(x)
    token = _CANCEL.set(hook)
    try:
        return fn(x)
    finally:
        _CANCEL.reset(token)


@dataclass
class Progress:
    """A progress report of long work (yielded by the stages of an operation): ``fraction``
    of the work done, 0–1, and a ``message`` for the user."""

    fraction: float
    message: str


def run_to_end(gen, report=None):
    """Run a generator of progress reports (the ``iter_…`` functions of long work) to its
    end and return its return value; ``report``, when given, is called with each item it
    yields (a :class:`Progress` or a fraction)."""
    while True:
        try:
            item = next(gen)
        except StopIteration as stop:
            return stop.value
        if report is not None:
            report(item)


def scaled_progress(gen, lo: float, hi: float, prefix: str):
    """``yield from gen`` (a generator of :class:`Progress`) with its fractions mapped to
    [``lo``, ``hi``] and its messages prefixed by ``prefix``; returns its return value (a
    stage of a longer run: one operation of a job, one layer of a semi-finishing)."""
    while True:
        try:
            pr = next(gen)
        except StopIteration as stop:
            return stop.value
        yield Progress(lo + (hi - lo) * float(pr.fraction), f"{prefix}: {pr.message}")


# ------------------------------------------------------------------------ OpenBLAS threads
#: what OpenBLAS calls its thread-count functions in numpy's (ILP64: ``64_``) and scipy's
#: (``scipy_`` prefix) wheels and in an unsuffixed build; (set, get) pairs
_BLAS_THREAD_FUNCTIONS = tuple(
    (f"{pre}openblas_set_num_threads{suf}", f"{pre}openblas_get_num_threads{suf}")
    for pre in ("", "scipy_") for suf in ("64_", "")
)
_BLAS_LOCK = threading.Lock()
_BLAS_USERS = 0  # the one_blas_thread blocks open now, in every thread
_BLAS_SAVED: list = []  # (set function, its count before the first block)


def _loaded_openblas() -> list[str]:
    """The OpenBLAS libraries this process has loaded: Linux reads them from its memory map;
    elsewhere the copies that numpy's and scipy's wheels bundle (``numpy.libs``,
    ``numpy/.dylibs``, …) of the packages already imported."""
    if sys.platform.startswith("linux"):
        try:
            with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
                paths = {line.split(None, 5)[-1].strip() for line in fh if "openblas" in line}
        except OSError:
            return []
        return sorted(p for p in paths if p.startswith("/") and "openblas" in os.path.basename(p))
    found = []
    for name in ("numpy", "scipy"):
        mod = sys.modules.get(name)
        if mod is None or not getattr(mod, "__file__", None):
            continue
        pkg = os.path.dirname(os.path.abspath(mod.__file__))
        for folder in (pkg + ".libs", os.path.join(pkg, ".libs"), os.path.join(pkg, ".dylibs")):
            with contextlib.suppress(OSError):
                found += [os.path.join(folder, f) for f in sorted(os.listdir(folder))
                          if "openblas" in f.lower() and f.lower().endswith((".dll", ".dylib"))]
    return found


def _blas_thread_controls() -> list:
    """(set, get) ctypes functions of every loaded OpenBLAS that has them."""
    controls = []
    for path in _loaded_openblas():
        try:
            lib = ctypes.CDLL(path)  # loaded already: the same library, not a second copy
        except OSError:
            continue
        for set_name, get_name in _BLAS_THREAD_FUNCTIONS:
            setter, getter = getattr(lib, set_name, None), getattr(lib, get_name, None)
            if setter is not None and getter is not None:
                setter.argtypes, setter.restype = [ctypes.c_int], None
                getter.argtypes, getter.restype = [], ctypes.c_int
                controls.append((setter, getter))
                break
    return controls


@contextlib.contextmanager
def one_blas_thread():
    """Within the block (and any other thread's block open with it), the OpenBLAS that numpy
    and scipy loaded runs on one thread; the counts before the first block come back when
    the last one ends.

    Why: numpy's products over many points ((n, 3) @ (3,), frames and rotations) go to
    OpenBLAS, which runs a thread per core and lets them spin after each product; the work
    gains nothing from them, and the spinning takes the cores the compiled kernels' workers
    need (a panel plan of Rotor 37: 0.93 s of CPU against 0.67 s on one BLAS thread, the
    same wall time on an idle machine — a busy one loses the difference). The products
    give the same bits on any thread count (each output row is one thread's).
    ``python -m blisk_cam`` sets ``OPENBLAS_NUM_THREADS=1`` before numpy loads
    (``cli/blas.py``); Blender has loaded numpy before the add-on, so its operators' workers
    take this block. ``OPENBLAS_NUM_THREADS`` set in the environment is the user's choice:
    nothing is changed then, nor where no OpenBLAS is found (macOS's Accelerate)."""
    global _BLAS_USERS, _BLAS_SAVED
    if "OPENBLAS_NUM_THREADS" in os.environ:
        yield
        return
    with _BLAS_LOCK:
        if _BLAS_USERS == 0:
            _BLAS_SAVED = [(setter, getter()) for setter, getter in _blas_thread_controls()]
            for setter, _ in _BLAS_SAVED:
                setter(1)
        _BLAS_USERS += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS_USERS -= 1
            if _BLAS_USERS == 0:
                for setter, before in _BLAS_SAVED:
                    setter(before)
                _BLAS_SAVED = []


def on_one_blas_thread(fn):
    """``fn`` run inside :func:`one_blas_thread` (a worker thread's target)."""

    def run(*args, **kwargs):
        with one_blas_thread():
            return fn(*args, **kwargs)

    return run
