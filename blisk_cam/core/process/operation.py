"""The life-cycle every operation follows: (part, request, stock) → progress → result.

Paper 003 (§5) makes a blisk in operations — roughing, semi-finishing, blade finishing, hub
and fillet finishing — each taking the part, the stock the previous one left, a tool and its
options. Here each operation is an :class:`Operation`: ``start`` checks the inputs and raises
before any long work (a :class:`~..errors.BliskCamError` naming the problem), ``stages`` lists
its steps in order, each a generator over the operation's own state that yields
:class:`~..runtime.Progress` (so a modal operator or the CLI can show progress and cancel
between yields), and ``finish`` makes the :class:`OperationResult`. :func:`iter_run_operation`
runs them and times every stage (wall seconds inside the stage only, not the caller's time
between progress steps); the times land in the result and in the path's stats as
``seconds_<stage>`` and ``seconds_plan`` (their sum).

Blade finishing (:mod:`.blade_finish`) is the first operation.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Generator, Iterable
from dataclasses import dataclass, field

from ..kernels.backend import backend_name
from ..runtime import Progress, run_to_end, workers
from ..toolpath.types import ToolPath

__all__ = ["Operation", "OperationResult", "Stage", "iter_run_operation", "run_operation",
           "timed"]


@dataclass(frozen=True)
class Stage:
    """One step of an operation: ``run(state)`` is a generator that may yield
    :class:`~..runtime.Progress` and updates the operation's state."""

    name: str
    run: Callable[[object], Generator[Progress, None, None]]


@dataclass
class OperationResult:
    """What an operation gives.

    Attributes
    ----------
    path : ToolPath — the operation's tool path (paths JSON, NC, verify read it)
    stock_after : the in-process stock after the operation, or None when the operation does
        not simulate material removal
    seconds : {stage name: wall seconds inside that stage}
    """

    path: ToolPath
    stock_after: object = None
    seconds: dict = field(default_factory=dict)


class Operation:
    """An operation of the process. Subclasses set ``name`` and implement the three steps."""

    name: str = "operation"

    def start(self, part, request, stock=None):
        """The operation's state for ``part`` (e.g. a TriMesh), ``request`` (tool and
        options) and ``stock`` (None: the operation does not read the stock). Raises a
        BliskCamError naming the problem when the inputs are bad, before any long work."""
        raise NotImplementedError

    def stages(self, state) -> tuple[Stage, ...]:
        """The stages, in the order they run."""
        raise NotImplementedError

    def finish(self, state, seconds: dict) -> OperationResult:
        """The result of the finished state; ``seconds`` are the stage times."""
        raise NotImplementedError


def timed(gen: Generator, times: dict, key: str):
    """``yield from gen``, adding to ``times[key]`` only the time spent inside ``gen`` (not
    the caller's time between progress steps); returns the generator's value."""
    times[key] = times.get(key, 0.0)
    t0 = time.perf_counter()
    while True:
        try:
            item = next(gen)
        except StopIteration as stop:
            times[key] += time.perf_counter() - t0
            return stop.value
        times[key] += time.perf_counter() - t0
        yield item
        t0 = time.perf_counter()


def iter_run_operation(operation: Operation, part, request, stock=None, *,
                       extra: Iterable[Stage] = ()):
    """Generator: runs ``operation`` on ``part`` with ``request`` (and ``stock``): its
    stages, then the ``extra`` ones (e.g. a collision check); yields Progress, returns the
    :class:`OperationResult`. The stage times are in ``result.seconds`` and in the path's
    stats (``seconds_<stage>``, ``seconds_plan`` their sum), with the kernels that ran
    (``kernels``: ``"compiled 0.1.0"`` or ``"numpy"``) and their ``threads``."""
    state = operation.start(part, request, stock)
    seconds: dict[str, float] = {}
    for stage in (*operation.stages(state), *extra):
        yield from timed(stage.run(state), seconds, stage.name)
    result = operation.finish(state, seconds)
    result.path.stats.update({f"seconds_{k}": v for k, v in seconds.items()})
    result.path.stats["seconds_plan"] = float(sum(seconds.values()))
    result.path.stats["kernels"] = backend_name()
    result.path.stats["threads"] = workers()  # the kernels' threads (results do not depend on it)
    result.seconds = dict(seconds)
    return result


def run_operation(operation: Operation, part, request, stock=None, *,
                  extra: Iterable[Stage] = ()) -> OperationResult:
    """Run :func:`iter_run_operation` to the end."""
    return run_to_end(iter_run_operation(operation, part, request, stock, extra=extra))
