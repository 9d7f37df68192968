"""The `Observer` interface (after libcosim's): told when a run starts, handed the recorded rows
in chunks, told how it finished. Observers never reach into components."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np


@dataclass(frozen=True)
class RunStart:
    """What an observer knows when the run starts: recorded columns (time first) with units, the
    base step h [s], the number of base steps, the run's folder (None: nothing is written), the
    scenario's name and the recorded Binary ports ('n1.CanChannel.Tx_Data'), given at their
    ticks (`Observer.ticks`); `system`: the built system that runs (for views that draw it)."""

    columns: tuple[str, ...]
    units: tuple[str, ...]
    step: float
    n_steps: int
    folder: Path | None = None
    scenario: str = "<scenario>"
    metadata: dict[str, Any] = field(default_factory=dict)
    binary: tuple[str, ...] = ()
    system: Any = None


@dataclass
class Outcome:
    """How a run ended. status: 'completed' | 'failed' | 'interrupted'; `error` is the message
    of the failure ('' when completed); `wall_time` [s] is the stepping alone (from the first
    step to the end, set-up and initialization excluded), `realtime_factor` simulated time over
    it; `extra` holds pacing statistics and components' reports; `stopped_by` names the FMU that
    ended a completed run early (`experiment.fmu_terminate: stop`) and the time [s];
    `statistics` the master's counts per block and per algebraic loop (`twmr.master.stats`);
    `fired` the condition events as they happened."""

    status: str = "completed"
    error: str = ""
    n_steps: int = 0
    steps_done: int = 0
    wall_time: float = 0.0
    realtime_factor: float = 0.0
    extra: dict[str, Any] = field(default_factory=dict)
    statistics: dict[str, Any] = field(default_factory=dict)
    lateness_us: np.ndarray | None = None
    stopped_by: dict[str, Any] | None = None
    #: each firing of a condition event: its condition, action and target, the located
    #: crossing time and the time its action applied [s]
    fired: list[dict[str, Any]] = field(default_factory=list)


class Observer:
    """Base class: override what you need. Exceptions raised by `rows` stop the run (the
    components are terminated first); those raised by `finished` are reported after the stop."""

    def started(self, run: RunStart) -> None:
        """The run is about to take its first step."""

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        """Recorded rows, a float64 array (rows x columns, time first); `steps_done` base steps
        have been taken so far."""

    def ticks(self, events: list[tuple[float, int, bytes]], steps_done: int) -> None:
        """Ticks of recorded Binary ports since the last call, before the rows of the same
        chunk: (time [s], index into `RunStart.binary`, the bytes), in the order taken (an
        output's ticks inside a step keep their own times, so not always sorted by time)."""

    def fired(self, event: dict[str, Any]) -> None:
        """A condition event fired (as `Outcome.fired` keeps it: when, action, target, located
        and at [s])."""

    def finished(self, outcome: Outcome) -> None:
        """The run ended (every component is already terminated)."""
