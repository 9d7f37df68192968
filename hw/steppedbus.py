"""`SteppedBus`: a bus block's `CanBusModel` advanced by the block's own steps, in run time.

When no participant needs the wall clock (only FMI-LS-BUS terminals, no drive, no python-can
bus outside), the block submits the frames its participants sent at their times and advances
the model to the end of each step: no thread, no wall clock, the same events in every run. Its
state (`snapshot`/`restore`) is everything the model and the records hold, so an algorithm that
rolls steps back (`algorithm: adaptive`) can take a step again.
"""
from __future__ import annotations

import copy
import math
from typing import Any

import can

from twmr.hw.canbus import BusCore, Participant
from twmr.hw.cansim import BusEvent, CanBusModel


class SteppedBus(BusCore):
    """`model` for the bus block `name`, in run time [s]."""

    def __init__(self, name: str, model: CanBusModel):
        super().__init__(name, model, 0.0)

    def join(self, member: Participant, keeps_open: bool = True) -> str:
        """Add `member`; its name on the bus (made unique with '#2', '#3', ...)."""
        return self._add(member)

    def submit(self, sender: str, frame: can.Message, at: float | None = None) -> str:
        """Queue `frame` of `sender` at run time `at` [s]; '' or why the bus refuses it."""
        t = 0.0 if at is None else at
        problem = self.model.submit(sender, frame, t)
        if problem:
            self._record(BusEvent("bus_error", t, frame, sender, problem))
        return problem

    def advance(self, until: float) -> None:
        """Every event up to run time `until` [s], recorded and handed to the participants."""
        events = self.model.advance(until)
        with self._cond:
            for event in events:
                if event.kind != "bus_error" or not math.isnan(event.start):
                    self._record(event)  # refusals were recorded at submission
        self._dispatch(events, self._members)

    def next_time(self) -> float | None:
        """Run time [s] of the next event (None: nothing pending)."""
        return self.model.next_time()

    def snapshot(self) -> Any:
        """The model and the records, copied."""
        with self._cond:
            return copy.deepcopy((self.model, self.rows, self.counts, self._errors,
                                  self.failures))

    def restore(self, saved: Any) -> None:
        """Back to a `snapshot` (a copy of it: it can be restored again)."""
        with self._cond:
            self.model, self.rows, self.counts, self._errors, self.failures = \
                copy.deepcopy(saved)
