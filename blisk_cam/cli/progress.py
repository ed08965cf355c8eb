"""Progress of the long stages of a command on stderr: percentage lines
(``blisk_cam: plan  40% pass 12 at s = 0.4…``), at most one per stage every half second and
each time a stage starts or ends; ``--quiet`` silences them. stdout keeps the results only."""

from __future__ import annotations

import sys
import time

from .flags import PROG

__all__ = ["StageProgress"]


class StageProgress:
    """Percentage lines for named stages. ``report(stage, fraction, message)`` while a stage
    runs (throttled to one line per ``every`` seconds; a new stage and 100 % always print);
    ``done(stage, seconds)`` when it ends. ``quiet``: prints nothing."""

    def __init__(self, quiet: bool = False, stream=None, every: float = 0.5):
        self.quiet = bool(quiet)
        self.stream = stream
        self.every = float(every)
        self._stage = None
        self._pct = -1
        self._t = -1e9

    def _print(self, text: str):
        print(f"{PROG}: {text}", file=self.stream or sys.stderr, flush=True)

    def report(self, stage: str, fraction: float, message: str = ""):
        if self.quiet:
            return
        pct = max(0, min(100, int(100.0 * float(fraction))))
        now = time.monotonic()
        new = stage != self._stage
        if not new:
            if pct < self._pct:  # a stage's sub-steps restart at 0: keep the count rising
                pct = self._pct
            if pct == self._pct and now - self._t < 5 * self.every:
                return
            if pct < 100 and now - self._t < self.every:
                return
        self._stage, self._pct, self._t = stage, pct, now
        self._print(f"{stage} {pct:3d}%" + (f" {message}" if message else ""))

    def done(self, stage: str, seconds: float | None = None):
        if self.quiet:
            return
        self._stage = None
        self._pct = -1
        tail = f" ({seconds:.1f} s)" if seconds is not None else ""
        self._print(f"{stage} 100%{tail}")

    def step(self, stage: str):
        """A callable for core progress: ``Progress`` → :meth:`report` of ``stage``."""
        return lambda p: self.report(stage, p.fraction, p.message)
