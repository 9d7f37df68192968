"""`RunContext`: what a run tells a component before `setup` (`Component.prepare`) — where it
may write, the base step, pacing, which of its ports the run uses, and what the run's algorithm
does that a component must know of, as capabilities, never as an algorithm's name."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Options:
    """How a run goes, beside what its scenario says: `compiled` 'auto' | 'on' | 'off', the
    compiled step loop (None: the `TWMR_COMPILED` environment variable, else 'auto'); `timing`:
    measure the wall time spent in each block (summary.json `statistics`, `twmr run -v`);
    `fmu_log`: show every message the FMUs log (errors and warnings always show)."""

    compiled: str | None = None
    timing: bool = False
    fmu_log: bool = False


@dataclass(frozen=True)
class RunContext:
    """`folder`: where the component may write files of its own (None: the run writes nothing);
    `step`: the base step h [s]; `paced`: steps follow the wall clock. `wired` holds the
    (instance, input) pairs driven by a wire and `read` the (instance, output) pairs the run
    reads (wired or recorded); None: every port.

    What the algorithm does: `outputs_as_stepped` — the outputs a component leaves after
    `do_step` are passed on as they are, without another `evaluate` at t + h (Jacobi); an FMU
    then reads its feedthrough outputs after the step too. `steps_retaken` — a step may be
    taken again from an earlier saved state (rollback), so nothing a step does may be final
    before the run moves on (a bus block keeps its frame log until the end).

    `fmu_log`: every message an FMU logs is shown (`Options.fmu_log`)."""

    folder: Path | None
    step: float
    paced: bool
    wired: frozenset[tuple[str, str]] | None = None
    read: frozenset[tuple[str, str]] | None = None
    outputs_as_stepped: bool = False
    steps_retaken: bool = False
    fmu_log: bool = False

    def wired_inputs(self, instance: str) -> set[str] | None:
        """Inputs of `instance` written by the master at each step (None: all of them)."""
        return None if self.wired is None else {p for n, p in self.wired if n == instance}

    def read_outputs(self, instance: str) -> set[str] | None:
        """Outputs of `instance` the run reads (None: all of them)."""
        return None if self.read is None else {p for n, p in self.read if n == instance}
