"""The `Algorithm` interface: how a built `System` advances in time (after libcosim's).

Execution owns the clock, pacing, observers and every stop path; an algorithm only advances the
components from one base step towards another and appends the recorded rows. Time is an integer
count of base steps n (t_n = start + n h). `FixedStep` (`twmr.master.schedule`) is the generated
Gauss-Seidel / Jacobi loop; a variable-step or rollback algorithm implements the same methods and
states what it needs through the capability flags.
"""
from __future__ import annotations

import logging
import os
from abc import ABC, abstractmethod
from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from twmr.core.errors import CosimError, Location, Problem, ScenarioError
from twmr.registry import ALGORITHMS, plugin, plugins
from twmr.scenario.system import System

log = logging.getLogger("twmr")


#: the modes of the compiled loop (`twmr.master.compiled`)
MODES = ("auto", "on", "off")


class CompileError(CosimError):
    """`TWMR_COMPILED=on` but the system cannot run compiled (a block without a kernel...)."""


def compiled_mode() -> str:
    """The selection from `TWMR_COMPILED` ('auto' unless set)."""
    mode = os.environ.get("TWMR_COMPILED", "auto").strip().lower() or "auto"
    if mode not in MODES:
        raise CompileError(f"TWMR_COMPILED is '{mode}', which is not a mode of the compiled "
                           f"loop. Fix: set it to one of {', '.join(MODES)}, or unset it.")
    return mode


class OptionError(ValueError):
    """An algorithm's option that does not fit: the option, what is wrong, the fix."""

    def __init__(self, key: str, what: str, fix: str):
        super().__init__(what)
        self.key, self.what, self.fix = key, what, fix


@dataclass(frozen=True)
class WithOptions:
    """A registered algorithm that reads experiment keys of its own: `make(compiled)` makes it,
    `options_schema` gives each key's JSON schema, `read_options(given, step, duration)` turns
    the given ones into what it runs with (defaults, checks across keys; `OptionError`)."""

    make: Callable[[str], Algorithm]
    options_schema: Mapping[str, Any] = field(default_factory=dict)
    read_options: Callable[[dict[str, Any], float, float], dict[str, Any]] | None = None

    def __call__(self, compiled: str = "auto") -> Algorithm:
        return self.make(compiled)


def options_schema(name: str) -> dict[str, Any]:
    """The experiment keys algorithm `name` reads beyond the common ones: key -> its JSON schema
    (the registered factory's `options_schema`; {} when it has none). Imports the algorithm."""
    schema = getattr(plugin(ALGORITHMS, name, "master algorithm"), "options_schema", None)
    return dict(schema) if isinstance(schema, dict) else {}


def read_options(name: str, given: dict[str, Any], step: float, duration: float
                 ) -> dict[str, Any]:
    """The experiment's options of algorithm `name` (checked by its schema already) as it runs
    them: its factory's `read_options(given, step, duration)` when it has one (checks across
    options, values in the run's terms), else `given`. `OptionError` for one that does not
    fit."""
    read = getattr(plugin(ALGORITHMS, name, "master algorithm"), "read_options", None)
    return dict(read(given, step, duration)) if callable(read) else dict(given)


class Algorithm(ABC):
    """Advances a system; created per run, prepared once before `initialize`."""

    #: the algorithm may restore earlier component states (every component must support it)
    needs_state_rollback: ClassVar[bool] = False
    #: the step reached may fall short of the step asked for (`advance` returns it)
    variable_step: ClassVar[bool] = False
    #: the outputs a component leaves after `do_step` are passed on as they are, without
    #: another `evaluate` at t + h (Jacobi); told to the components (`RunContext`)
    outputs_as_stepped: bool = False
    #: measure the wall time spent in each block (`Options.timing`), set by the run before
    #: `prepare`
    timing: bool = False
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
        `rows` (as tuples, or as 2-D float arrays of rows, which the observers then hold:
        never changed after); return the step reached (n1 for a fixed-step algorithm)."""

    @abstractmethod
    def finish(self, n: int, rows: list[Any]) -> None:
        """The final communication point at step n: inputs written, feedthrough evaluated and
        the row recorded, without stepping."""

    def reparameterized(self, names: Collection[str]) -> None:  # noqa: B027 - a hook
        """Components `names` had parameters set between two steps (a scenario's `set` events):
        whatever the algorithm made from their parameters is made anew before the next step.
        The base: nothing is held (an algorithm that calls the components' methods)."""

    def start(self) -> None:
        """Called once after every component is initialized, before the first `advance` (the
        compiled algorithm collects its kernels and compiles here)."""
        return

    def refuse(self, system: System) -> Problem | None:
        """Why `system` cannot run under this algorithm, beyond state rollback (None: it can);
        `admit` raises it."""
        return None

    def report(self) -> dict[str, object]:
        """Figures about the algorithm (e.g. compile time [s]), for the run's outcome."""
        return {}

    def statistics(self, steps_done: int, finished: bool) -> dict[str, object]:
        """Counts per block and per algebraic loop after `steps_done` base steps (`finished`:
        the final point was reached), as `twmr.master.stats.document` (empty: not kept)."""
        return {}

    def notes(self, system: System) -> list[str]:
        """What the user should know before running `system` under this algorithm (said at
        `twmr check` and at the start of a run)."""
        return []

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        """(instance, call, time [s]) where `exc` was raised inside `advance`, as far as known."""
        return "?", "a call", float("nan")


class NonFinite(Exception):
    """Raised inside `advance` when some read output is NaN or Inf at time `t` [s]."""

    def __init__(self, t: float):
        super().__init__(t)
        self.t = t


def make_algorithm(name: str, compiled: str | None = None) -> Algorithm:
    """The algorithm registered as `name` in the `twmr.algorithms` entry-point group (built in:
    'gauss_seidel', 'jacobi', 'adaptive'): its factory called with `compiled` 'auto' | 'on' |
    'off' (None: `TWMR_COMPILED`, default 'auto'; see `twmr.master.compiled`). `CosimError`
    naming the known algorithms when `name` is not one."""
    if compiled is not None and compiled not in MODES:
        raise CosimError(f"compiled={compiled!r} is not a mode of the compiled loop. Fix: give "
                         f"one of {', '.join(MODES)} (or None: TWMR_COMPILED, else auto).")
    factory = plugin(ALGORITHMS, name, "master algorithm")
    algorithm = factory(compiled_mode() if compiled is None else compiled)
    if not isinstance(algorithm, Algorithm):
        raise CosimError(f"the master algorithm '{name}' ({plugins(ALGORITHMS)[name]}) made a "
                         f"{type(algorithm).__name__}, not an Algorithm. Fix: register a "
                         f"callable (compiled: str) -> Algorithm in the twmr.algorithms group.")
    return algorithm


def algorithm_for(system: System, compiled: str | None = None) -> Algorithm:
    """The algorithm `system`'s experiment names, checked against the system (`admit`);
    `ScenarioError` naming the scenario file when the name is unknown or the system unfit."""
    name = system.experiment.algorithm
    try:
        algorithm = make_algorithm(name, compiled)
    except ScenarioError:
        raise
    except CosimError as err:
        raise ScenarioError(Problem(Location(system.source, 0, "experiment.algorithm"),
                                    str(err))) from None
    admit(system, algorithm, name)
    return algorithm


def admit(system: System, algorithm: Algorithm, name: str = "") -> None:
    """Refuse a system `algorithm` cannot run: one that restores earlier states
    (`needs_state_rollback`) needs every component to save its state
    (`Component.can_get_and_set_state`), and the algorithm's own `refuse`. `ScenarioError`
    naming the blocks and the algorithm."""
    unfit = {n: c for n, c in system.components.items() if not c.can_get_and_set_state} \
        if algorithm.needs_state_rollback else {}
    if not unfit:
        problem = algorithm.refuse(system)
        if problem is not None:
            raise ScenarioError(problem)
        for note in algorithm.notes(system):
            log.warning("note: %s", note)
        return
    label = f"'{name}'" if name else type(algorithm).__name__
    why = "; ".join(f"'{n}' ({type(c).__name__}) cannot save and restore its state: "
                    f"{c.why_no_state()}" for n, c in unfit.items())
    raise ScenarioError(Problem(
        Location(system.source, 0, "experiment.algorithm"),
        f"the master algorithm {label} restores earlier component states (it needs state "
        f"rollback), but {why}.",
        f"use an algorithm without rollback (gauss_seidel or jacobi), or replace "
        f"{', '.join(map(repr, unfit))} by a block that can save its state (an FMU that "
        f"declares it)."))
