"""The records a built scenario hands to the master: `System`, `Connection`, `Experiment`,
`RecordSpec`.

Data only. `twmr.scenario.build` makes them from a scenario file; the master steps them.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import Location


@dataclass(frozen=True)
class Connection:
    """One wire: source output elements -> destination input elements.

    Indices are 0-based element indices (None = the whole port). The unit conversion found at build
    time is folded in as dst = gain * src + offset (gain 1, offset 0 when the units agree)."""

    src: str
    src_port: str
    dst: str
    dst_port: str
    src_index: tuple[int, ...] | None = None
    dst_index: tuple[int, ...] | None = None
    gain: float = 1.0
    offset: float = 0.0
    location: Location = field(default_factory=Location)

    def __str__(self) -> str:
        def end(c: str, p: str, idx: tuple[int, ...] | None) -> str:
            sel = "" if idx is None else "[" + ",".join(str(i + 1) for i in idx) + "]"
            return f"{c}.{p}{sel}"

        return f"{end(self.src, self.src_port, self.src_index)} -> " \
               f"{end(self.dst, self.dst_port, self.dst_index)}"


@dataclass(frozen=True)
class LoopSolver:
    """How an algebraic loop is solved (`experiment.loop_solver`, `twmr.master.loops`): method
    'fixed_point' or 'newton', tolerance on each torn input's residual (|g(x) - x| at most
    tol max(1, |x|)), most iterations per communication point, relaxation factor."""

    method: str = "fixed_point"
    tol: float = 1e-9
    max_iter: int = 100
    relaxation: float = 1.0


@dataclass(frozen=True)
class Experiment:
    """Start and stop [s], base step h [s], algorithm ('gauss_seidel' | 'jacobi'), pacing to the
    wall clock (None: paced when a component needs it, see `System.paced`)."""

    start: float = 0.0
    stop: float = 1.0
    step: float = 1e-3
    algorithm: str = "gauss_seidel"
    realtime: bool | float | None = None
    #: the algorithm's own options as it reads them (e.g. the adaptive master's rtol, atol,
    #: min_step, max_step; `twmr.master.algorithm.read_options`)
    options: Mapping[str, Any] = field(default_factory=dict)
    #: an FMU that asks to end the simulation: 'error' fails the run, 'stop' ends it there
    #: normally (the rows up to that time are the result)
    fmu_terminate: str = "error"
    #: algebraic loops: 'refuse' (an error when the scenario is built) or 'solve'
    loops: str = "refuse"
    loop_solver: LoopSolver = field(default_factory=LoopSolver)

    @property
    def n_steps(self) -> int:
        """Number of base steps, rounded to the nearest integer."""
        return round((self.stop - self.start) / self.step)


@dataclass(frozen=True)
class RecordSpec:
    """Signals to record as (instance, port) pairs, every `decimation` base steps."""

    signals: tuple[tuple[str, str], ...] = ()
    decimation: int = 1


@dataclass
class System:
    """Components created and checked, wires resolved, execution order fixed."""

    components: dict[str, Component]
    connections: list[Connection]
    order: list[str]
    experiment: Experiment
    record: RecordSpec = field(default_factory=RecordSpec)
    step_multiples: dict[str, int] = field(default_factory=dict)
    source: str = "<scenario>"
    #: what compiling the loop generated for this system may cost [s] (its steps are faster
    #: than the driver's; `twmr.master.scenario_loop.own_loop`): raised by `twmr.built.Built`
    #: as the system's runs step
    own_loop_budget_s: float = 0.0
    #: the scenario's events as the results keep them (`twmr.scenario.events.Mark`)
    events: tuple[Any, ...] = ()
    #: parameters set during the run, by base step (`twmr.scenario.events.Change`)
    changes: tuple[Any, ...] = ()
    #: the condition events, watched between steps (`twmr.scenario.events.Watch`)
    watches: tuple[Any, ...] = ()
    #: the vehicles the scenario describes (`body:`), by pose port ('plant.pose'): in place of
    #: what their blocks say (`Component.bodies`)
    bodies: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def paced(self) -> bool:
        """Steps paced to the wall clock: as the experiment says (true or a factor), else when
        hardware is in the loop."""
        if self.experiment.realtime is not None:
            return self.experiment.realtime is not False
        return any(c.needs_realtime for c in self.components.values())

    @property
    def pace_factor(self) -> float:
        """Simulated seconds per wall-clock second of a paced run (`realtime: <factor>`; 1 for
        `true` and for hardware)."""
        given = self.experiment.realtime
        return 1.0 if given is None or isinstance(given, bool) else float(given)

    def multiple(self, name: str) -> int:
        """Step multiple of an instance (1 when not set)."""
        return self.step_multiples.get(name, 1)
