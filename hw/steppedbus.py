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

from twmr.hw.canbus import BusCore, Participant, register, unregister
from twmr.hw.cansim import BusEvent, CanBusModel


class SteppedBus(BusCore):
    """`model` for the bus block `name`, in run time [s]; reached as `channel` (python-can
    interface `twmr`) until `close`."""

    in_run_time = True

    def __init__(self, name: str, model: CanBusModel, channel: str = ""):
        super().__init__(name, model, 0.0)
        self.channel = channel
        #: run time the bus has been advanced to [s]: what a frame submitted without a time is
        #: stamped with (it goes on the wire in the block's next step)
        self.clock = 0.0
        if channel:
            register(channel, self)

    def bus_time(self) -> float:
        return self.clock

    def join(self, member: Participant, keeps_open: bool = True) -> str:
        """Add `member`; its name on the bus (made unique with '#2', '#3', ...)."""
        with self._cond:
            return self._add(member)

    def leave(self, name: str, flush: float = 0.5) -> None:
        """`name` leaves; what it queued stays queued (the block's steps put it on the wire)."""
        with self._cond:
            self._members.pop(name, None)

    def handed(self, name: str, timeout: float) -> bool:
        """Frames go on the wire as the block steps, never on the wall clock: nothing to wait
        for."""
        return True

    def close(self) -> None:
        """No participant reaches the bus any more."""
        if self.channel:
            unregister(self.channel, self)

    def submit(self, sender: str, frame: can.Message, at: float | None = None) -> str:
        """Queue `frame` of `sender` at run time `at` [s] (default: `clock`); '' or why the
        bus refuses it."""
        t = self.clock if at is None else at
        problem = self.model.submit(sender, frame, t)
        if problem:
            self._record(BusEvent("bus_error", t, frame, sender, problem))
        return problem

    def advance(self, until: float) -> None:
        """Every event up to run time `until` [s], recorded and handed to the participants."""
        events = self.model.advance(until)
        with self._cond:
            self.clock = max(self.clock, until)
            for event in events:
                if event.kind != "bus_error" or not math.isnan(event.start):
                    self._record(event)  # refusals were recorded at submission
            members = dict(self._members)
        self._dispatch(events, members)

    def next_time(self) -> float | None:
        """Run time [s] of the next event (None: nothing pending)."""
        return self.model.next_time()

    def snapshot(self) -> Any:
        """The model and the records, copied."""
        with self._cond:
            return copy.deepcopy((self.model, self.rows, self.counts, self._errors,
                                  self.failures, self.clock))

    def restore(self, saved: Any) -> None:
        """Back to a `snapshot` (a copy of it: it can be restored again)."""
        with self._cond:
            self.model, self.rows, self.counts, self._errors, self.failures, self.clock = \
                copy.deepcopy(saved)
