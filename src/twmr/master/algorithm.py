"""The `Algorithm` interface: how a built `System` advances in time (after libcosim's).

Execution owns the clock, pacing, observers and every stop path; an algorithm only advances the
components from one base step towards another and appends the recorded rows. Time is an integer
count of base steps n (t_n = start + n h). `FixedStep` (`twmr.master.schedule`) is the generated
Gauss-Seidel / Jacobi loop; a variable-step or rollback algorithm implements the same methods and
states what it needs through the capability flags.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

from twmr.scenario.system import System


class Algorithm(ABC):
    """Advances a system; created per run, prepared once before `initialize`."""

    #: the algorithm may restore earlier component states (every component must support it)
    needs_state_rollback: ClassVar[bool] = False
    #: the step reached may fall short of the step asked for (`advance` returns it)
    variable_step: ClassVar[bool] = False
    #: the generated source, if any, for tracebacks and `twmr check --schedule`
    source: str = ""

    @abstractmethod
    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        """Bind to `system`: the (instance, port) pairs to record every `decimation` steps, and
        whether a NaN/Inf in a read output stops the run (`NonFinite`)."""

    @abstractmethod
    def advance(self, n0: int, n1: int, rows: list[Any]) -> int:
        """Advance from base step n0 towards n1, appending recorded rows (t, values...) to
        `rows` (as tuples, or as 2-D float arrays of rows); return the step reached (n1 for a
        fixed-step algorithm)."""

    @abstractmethod
    def finish(self, n: int, rows: list[Any]) -> None:
        """The final communication point at step n: inputs written, feedthrough evaluated and
        the row recorded, without stepping."""

    def start(self) -> None:
        """Called once after every component is initialized, before the first `advance` (the
        compiled algorithm collects its kernels and compiles here)."""
        return

    def report(self) -> dict[str, object]:
        """Figures about the algorithm (e.g. compile time [s]), for the run's outcome."""
        return {}

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        """(instance, call, time [s]) where `exc` was raised inside `advance`, as far as known."""
        return "?", "a call", float("nan")


class NonFinite(Exception):
    """Raised inside `advance` when some read output is NaN or Inf at time `t` [s]."""

    def __init__(self, t: float):
        super().__init__(t)
        self.t = t


def make_algorithm(name: str, compiled: str | None = None) -> Algorithm:
    """The algorithm an experiment names ('gauss_seidel' | 'jacobi'), compiled with numba when
    every block offers a kernel: `compiled` 'auto' | 'on' | 'off' (None: `TWMR_COMPILED`, default
    'auto'; see `twmr.master.compiled`)."""
    from twmr.master.compiled import CompiledStep, compiled_mode
    from twmr.master.schedule import FixedStep

    mode = compiled_mode() if compiled is None else compiled
    if mode == "off":
        return FixedStep(name)
    return CompiledStep(name, mode)
