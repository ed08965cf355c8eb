"""The modal machinery shared by the long-running operators (Generate Paths, Check Collisions).

:class:`ModalJobOperator` is a mixin for a ``bpy.types.Operator`` whose work is a *job*: an
object built from the scene up front (arrays and names only, never bpy objects across steps)
and advanced step by step. Interactively (``invoke`` with a window) it runs modal on a timer:
each tick calls the operator's :meth:`~ModalJobOperator.tick`, the status bar and the cursor
progress show how far it is, ESC ends it through :meth:`~ModalJobOperator.escape` (by default:
cancelled, the previous result kept). In background mode or without a window ``invoke`` runs
``execute`` (synchronously). While a job runs, its scene's name is in the operator's
``running`` set, which its ``poll`` reads to refuse a second run.

:class:`ModalRunner` drives such an operator's modal methods without Blender's event loop
(background mode has none: timers never fire): the tests and ``bench/bench_panel.py`` step
the very code the timer runs.
"""

from __future__ import annotations

import threading
import types

import bpy

from ..core.runtime import one_blas_thread
from .common import report_exception

__all__ = ["ModalJobOperator", "ModalRunner", "ThreadJob", "ThreadJobOperator", "TimerEvent"]


class ThreadJob:
    """A job whose core work runs on one thread of its own (:meth:`start`, cancelled through
    :attr:`cancel`) or in the caller's (:meth:`run`). A subclass sets :attr:`thread_name`,
    does the work in :meth:`work` (its error is handed to the caller by :meth:`result`, never
    raised on the thread) and returns its outcome from :meth:`outcome`."""

    thread_name = "blisk_cam job"

    def __init__(self):
        self.cancel = threading.Event()
        self._error = None
        self._thread = None

    def work(self):
        raise NotImplementedError

    def outcome(self):
        raise NotImplementedError

    def _compute(self):
        try:
            with one_blas_thread():  # Blender's numpy: its OpenBLAS spins beside our kernels
                self.work()
        except BaseException as exc:  # handed to the caller by result()
            self._error = exc

    def start(self):
        """Start the work on its own thread (once)."""
        if self._thread is None:
            self._thread = threading.Thread(target=self._compute, name=self.thread_name,
                                            daemon=True)
            self._thread.start()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def stop(self):
        """Cancel the work and wait for its thread (it stops at its next cancel check)."""
        self.cancel.set()
        if self._thread is not None:
            self._thread.join()

    def run(self):
        """The work in the caller's thread; :meth:`result`."""
        self._compute()
        return self.result()

    def result(self):
        """The outcome (after the thread ended); raises the work's error."""
        if self._thread is not None:
            self._thread.join()
        if self._error is not None:
            raise self._error
        return self.outcome()


class ModalJobOperator:
    """Mixin for an operator running a job modal (see the module docstring).

    The operator class provides:

    * ``running`` — a module-level ``set`` of scene names (class attribute);
    * ``status_label`` — the status bar's prefix, e.g. ``"Blisk CAM collisions"``;
    * ``cancel_text`` — the warning reported when ESC cancels;
    * ``busy_text`` — the poll's message while the scene's run goes on;
    * :meth:`new_job` and :meth:`tick`; optionally :meth:`problem`, :meth:`escape` and
      :meth:`end_job`.
    """

    running: set = set()  # overridden by every operator class with its own set
    status_label = "Blisk CAM"
    cancel_text = "Cancelled; the previous result is kept"
    start_text = "starting"
    busy_text = "Running (ESC cancels)"
    #: seconds between two timer ticks
    timer_interval = 0.05

    # --- to provide --------------------------------------------------------------------
    @classmethod
    def problem(cls, context) -> str | None:
        """Why the operator cannot run on this scene besides a run going on, or None."""
        return None

    @classmethod
    def poll(cls, context):
        problem = cls.problem(context)
        if not problem and context.scene.name in cls.running:
            problem = cls.busy_text
        if problem:
            cls.poll_message_set(problem)
            return False
        return True

    def new_job(self, context):
        """The job for the scene (raises ``BliskCamError`` on bad input)."""
        raise NotImplementedError

    def tick(self, context):
        """Advance the job on a timer tick: None while it goes on, else the operator's
        return set (it has reported); the mixin then ends the run."""
        raise NotImplementedError

    def escape(self, context):
        """ESC: the return set after reporting (default: cancelled, previous result kept)."""
        self.report({"WARNING"}, self.cancel_text)
        return {"CANCELLED"}

    def end_job(self, context):
        """Called once when the run ends in any way (finished, ESC, error, Blender's cancel)."""

    # --- machinery ---------------------------------------------------------------------
    def invoke(self, context, event):
        if bpy.app.background or context.window is None:
            return self.execute(context)
        try:
            self._job = self.new_job(context)
        except Exception as exc:
            return report_exception(self, exc)
        wm = context.window_manager
        self._timer = wm.event_timer_add(self.timer_interval, window=context.window)
        wm.modal_handler_add(self)
        self.start(context)
        return {"RUNNING_MODAL"}

    def start(self, context):
        """Progress and running state of a new run (the timer and handler are Blender's)."""
        context.window_manager.progress_begin(0, 100)
        self.running.add(self._job.scene_name)
        self._status(context, self.start_text)

    def _status(self, context, text, *, escape="ESC to cancel"):
        if context.workspace is not None:
            context.workspace.status_text_set(f"{self.status_label}: {text} — {escape}")

    def _end(self, context):
        wm = context.window_manager
        if getattr(self, "_timer", None) is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)
        self.running.discard(self._job.scene_name)
        self.end_job(context)

    def modal(self, context, event):
        if event.type == "ESC":
            try:
                result = self.escape(context)
            finally:
                self._end(context)
            return result
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            result = self.tick(context)
        except Exception as exc:
            self._end(context)
            return report_exception(self, exc)
        if result is None:
            return {"RUNNING_MODAL"}
        self._end(context)
        return result

    def cancel(self, context):
        self._end(context)


class ThreadJobOperator(ModalJobOperator):
    """A :class:`ModalJobOperator` whose job is a :class:`ThreadJob`: the work runs on the
    job's thread (or in the caller's, for ``execute``), each tick shows its ``fraction``
    (and ``message``, when the job has one), ESC stops the thread, and :meth:`done` makes the
    outcome Blender's in Blender's thread. The operator provides :meth:`make_job` and
    :meth:`done`; ``progress_share`` is the part of the cursor's progress the thread's work
    fills (the rest is :meth:`done`'s)."""

    progress_share = 95

    def make_job(self, context) -> ThreadJob:
        """The job for the scene (raises ``BliskCamError`` on bad input)."""
        raise NotImplementedError

    def done(self, context, job) -> set:
        """The finished job's outcome put into Blender; the operator's return set."""
        raise NotImplementedError

    def execute(self, context):
        try:
            job = self.make_job(context)
            job.run()
            return self.done(context, job)
        except Exception as exc:
            return report_exception(self, exc)

    def new_job(self, context):
        return self.make_job(context)

    def tick(self, context):
        job = self._job
        job.start()
        if job.running:
            context.window_manager.progress_update(int(self.progress_share * job.fraction))
            self._status(context, f"{int(100 * job.fraction)} % "
                                  f"{getattr(job, 'message', '')}".rstrip())
            return None
        try:
            job.result()  # the thread's error, raised here as execute's run() raises it
            return self.done(context, job)
        except Exception as exc:
            return report_exception(self, exc)

    def escape(self, context):
        self._job.stop()
        self.report({"WARNING"}, self.cancel_text)
        return {"CANCELLED"}

    def end_job(self, context):
        self._job.cancel.set()  # a run ended by Blender or an error stops its thread too


class TimerEvent:
    """A stand-in for the ``bpy.types.Event`` a modal handler receives (``type`` only)."""

    def __init__(self, type_: str = "TIMER"):
        self.type = type_


class ModalRunner:
    """A modal-job operator's methods bound to a plain object, for runs without an event loop.

    ``ModalRunner(BLISKCAM_OT_x, job)`` holds what the operator keeps on ``self`` (``_job``,
    ``_timer`` = None) and every method the add-on defines for it (the operator class and
    its mixins, not ``bpy.types.Operator``'s), so ``runner.modal(context, TimerEvent())`` runs
    the real code of one timer tick; ``report`` collects into ``reports``. :meth:`start`
    does what ``invoke`` does after building the job, minus the timer.
    """

    def __init__(self, op_class, job):
        self._job, self._timer, self.reports = job, None, []
        self.op_class = op_class
        top = op_class.__module__.split(".")[0]
        for klass in reversed(op_class.__mro__):  # the add-on's classes, base first
            if klass.__module__.split(".")[0] != top:
                continue
            for name, value in vars(klass).items():
                if name.startswith("__"):
                    continue
                if isinstance(value, types.FunctionType):
                    setattr(self, name, value.__get__(self))
                else:  # class attributes; class/static methods bound as on the class
                    setattr(self, name, getattr(op_class, name))

    def report(self, kind, text):
        self.reports.append((set(kind), text))

    def step(self, context, type_: str = "TIMER"):
        """One event through ``modal``; its return set."""
        return self.modal(context, TimerEvent(type_))
