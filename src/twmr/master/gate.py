"""`Gate`: pause, resume, step and stop a run from another thread — the Python stepping API
(`twmr.Stepping`: `step(n)`, `simulate_until(t)`, as libcosim's execution steps) and the live
view's Pause / Step / Resume buttons.

The run's loop asks the gate how far it may go before each chunk of steps (`allowed`): as far
as it likes while running; while paused, the steps granted (`grant`), waiting for them. While
it waits it calls `hold` every `HOLD_EVERY` s, so that hardware in the loop is kept safe (the
drives at zero torque, their watchdogs fed: `Component.hold`). `stop()` ends the run at the
step it has reached, its results kept (status `stopped`). Nothing waits forever: a wait for the
run (`wait_for`) ends when the run has ended, whatever ended it.
"""
from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

#: how often a paused run calls its hold [s]
HOLD_EVERY = 0.05


class RunStopped(Exception):
    """The run was stopped through its gate (`Gate.stop`): its results up to there are kept."""


class Gate:
    """Where a run may go: `paused` (it waits at its present step for steps granted) or
    running; `stopped` ends it. The run reports each step it reaches (`reached`)."""

    def __init__(self, paused: bool = False):
        self._cond = threading.Condition()
        self._paused = paused
        self._limit = 0  # while paused: the step the run may reach
        self._stopped = False
        self._ended = False
        self._waiting = False  # the run waits at the gate
        self.position = 0  # the step the run has reached
        self.paused_s = 0.0  # wall time spent paused
        self.execution: Any = None  # the run (`twmr.master.execution.Execution`) it gates

    # -- the controller's side ---------------------------------------------------------------
    @property
    def paused(self) -> bool:
        return self._paused

    @property
    def ended(self) -> bool:
        return self._ended

    def pause(self) -> None:
        """Pause at the end of the chunk of steps under way (a paced run: the next step)."""
        with self._cond:
            self._paused, self._limit = True, self.position
            self._cond.notify_all()

    def resume(self) -> None:
        with self._cond:
            self._paused = False
            self._cond.notify_all()

    def grant(self, steps: int) -> int:
        """Pause after `steps` more base steps from where the run is (or has been granted to
        go); the step it will then be at."""
        with self._cond:
            self._limit = max(self._limit, self.position) + max(0, int(steps))
            self._paused = True
            self._cond.notify_all()
            return self._limit

    def grant_to(self, step: int) -> None:
        """Pause when the run reaches base step `step`."""
        with self._cond:
            self._limit, self._paused = max(self._limit, int(step)), True
            self._cond.notify_all()

    def stop(self) -> None:
        """End the run at the step it has reached (it stops between two steps)."""
        with self._cond:
            self._stopped = True
            self._cond.notify_all()

    def wait_for(self, step: int, timeout: float | None = None) -> bool:
        """Wait until the run waits at the gate at or past `step`, or has ended; whether it
        reached `step`."""
        deadline = None if timeout is None else time.monotonic() + timeout
        with self._cond:
            while not (self._ended or (self._waiting and self.position >= step)
                       or (self._waiting and self._limit <= self.position)):
                left = None if deadline is None else deadline - time.monotonic()
                if left is not None and left <= 0:
                    break
                self._cond.wait(left if left is not None else 1.0)
            return self.position >= step

    # -- the run's side ------------------------------------------------------------------------
    def allowed(self, n: int, hold: Callable[[], None] | None = None) -> int:
        """The step the run at step `n` may reach before it asks again (a large number while
        running); waits while paused with nothing granted, calling `hold` every `HOLD_EVERY`
        s. Raises `RunStopped` once stopped."""
        with self._cond:
            if self._stopped:
                raise RunStopped
            if not self._paused:
                return 1 << 62
            if self._limit > n:
                return self._limit
            began = time.monotonic()
            self._waiting = True
            self._cond.notify_all()  # a controller waiting for the pause
            while self._paused and self._limit <= n and not self._stopped:
                self._cond.wait(HOLD_EVERY)
                if hold is not None and self._paused and self._limit <= n:
                    self._cond.release()
                    try:
                        hold()
                    finally:
                        self._cond.acquire()
            self._waiting = False
            self.paused_s += time.monotonic() - began
            if self._stopped:
                raise RunStopped
            return self._limit if self._paused else 1 << 62

    def reached(self, n: int) -> None:
        with self._cond:
            self.position = n
            self._cond.notify_all()

    def end(self) -> None:
        """The run has ended (completed, failed or stopped)."""
        with self._cond:
            self._ended = True
            self._cond.notify_all()
