"""The operation life-cycle (core/process/operation.py): start checks before any stage runs,
stages run in order (then the extra ones) over one state, progress comes through, each stage's
time counts only the time inside it, and the result carries the times and the stock after.
Blade finishing is an operation of this shape (its outputs: test_paths_digest.py)."""

from __future__ import annotations

import pytest

from blisk_cam.core.errors import BliskCamError
from blisk_cam.core.process import operation as op_mod
from blisk_cam.core.process.blade_finish import BLADE_FINISH, PLAN_STAGES, PlanResult
from blisk_cam.core.process.operation import (
    Operation,
    OperationResult,
    Stage,
    iter_run_operation,
    run_operation,
)
from blisk_cam.core.runtime import Progress
from blisk_cam.core.toolpath.types import ToolPath


class FakeClock:
    """perf_counter stand-in: time moves only when a test says so."""

    def __init__(self):
        self.now = 0.0

    def __call__(self):
        return self.now


@pytest.fixture
def clock(monkeypatch):
    c = FakeClock()
    monkeypatch.setattr(op_mod.time, "perf_counter", c)
    return c


class Counting(Operation):
    """A toy operation: two stages that spend known (fake) time and report progress."""

    name = "counting"

    def __init__(self, clock, cost=(2.0, 3.0)):
        self.clock, self.cost = clock, cost

    def start(self, part, request, stock=None):
        if request is None:
            raise BliskCamError("counting: no request")
        return {"log": [], "part": part, "stock": stock}

    def _stage(self, k):
        def run(state):
            state["log"].append(f"s{k}")
            self.clock.now += self.cost[k] / 2
            yield Progress(0.5, f"stage {k} half")
            self.clock.now += self.cost[k] / 2

        return Stage(f"s{k}", run)

    def stages(self, state):
        return (self._stage(0), self._stage(1))

    def finish(self, state, seconds):
        return OperationResult(path=ToolPath(axis=None, cone1=None, cone2=None, tool=None,
                                             cusp=0.1, chord=0.01, curves=[]),
                               stock_after=("after", state["stock"]))


def test_stages_run_in_order_with_progress_and_times(clock):
    op = Counting(clock)
    extra_ran = []

    def extra(state):
        extra_ran.append(list(state["log"]))
        clock.now += 1.0
        return
        yield

    it = iter_run_operation(op, "part", "req", "stock0", extra=(Stage("extra", extra),))
    messages = []
    while True:
        try:
            p = next(it)
        except StopIteration as stop:
            result = stop.value
            break
        messages.append(p.message)
        clock.now += 100.0  # the caller's time between progress steps is not the stage's
    assert messages == ["stage 0 half", "stage 1 half"]
    assert extra_ran == [["s0", "s1"]]  # the extra stage ran last, on the same state
    assert result.seconds == {"s0": 2.0, "s1": 3.0, "extra": 1.0}
    assert result.path.stats["seconds_s0"] == 2.0 and result.path.stats["seconds_plan"] == 6.0
    assert result.stock_after == ("after", "stock0")


def test_bad_input_is_refused_before_any_stage(clock):
    op = Counting(clock)
    it = iter_run_operation(op, "part", None)
    with pytest.raises(BliskCamError, match="no request"):
        next(it)
    assert clock.now == 0.0


def test_run_operation_drives_to_the_end(clock):
    result = run_operation(Counting(clock, cost=(0.5, 0.25)), "part", "req")
    assert result.seconds == {"s0": 0.5, "s1": 0.25}
    assert result.stock_after == ("after", None)


def test_blade_finishing_is_an_operation():
    assert isinstance(BLADE_FINISH, Operation) and BLADE_FINISH.name == "blade_finish"
    assert issubclass(PlanResult, OperationResult)
    assert [s.name for s in PLAN_STAGES] == ["fit", "passes", "order", "orient", "link",
                                             "checks"]
