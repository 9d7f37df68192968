"""The typed system structure every loader produces and the builder reads: `ScenarioSpec`.

Data only, nothing created or checked against a component. Every value is a `Given`: the value
as written (a number, a list, a text such as '30 cm') and where it was given, a `Location` (the
file and line and the key path; the `--set` text for an override; the key path alone for a
dict). The YAML and dict loaders (`twmr.scenario.loaders`) make it, `--set` overrides
(`twmr.scenario.overrides`) replace values in it, and `twmr.scenario.build` turns it into a
`System`.

A component of kind `system` holds the structure of the scenario file it includes
(`ComponentSpec.system`); a file used as a subsystem names the ports it exposes (`inputs`,
`outputs`: `Exposure`). `twmr.scenario.flatten` turns the nesting into the flat, dotted-name
structure the builder reads.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Generic, TypeVar

from twmr.core.errors import Location

#: most inclusions one scenario may read, of scenario files or .ssd files (a file included twice
#: counts twice: 24 files that each include the next twice would read 2^24), and most files deep
MAX_INCLUSIONS, MAX_DEPTH = 1_000, 32

T = TypeVar("T")


@dataclass(frozen=True)
class Given(Generic[T]):
    """A value of the scenario and where it was given; `text` is what was written where YAML
    read a number or a boolean that does not print back as written (a String parameter takes
    the text: `channel: 01234567` is '01234567', not the octal number 342391)."""

    value: T
    where: Location
    text: str | None = None


@dataclass(frozen=True)
class ComponentSpec:
    """One instance: its name, its kind (a registered name, 'file.py:Class' relative to the
    scenario's folder, or 'package.module:Class'), parameter and initial values by name, and its
    step multiple (it steps every n base steps)."""

    name: str
    kind: Given[str]
    parameters: dict[str, Given[Any]]
    initial: dict[str, Given[Any]]
    step_multiple: Given[int]
    where: Location
    description: str = ""
    system: ScenarioSpec | None = None
    #: the vehicles it moves, by pose port (`body:`; `twmr.scenario.bodies`)
    body: dict[str, Given[Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class Exposure:
    """A port a subsystem file exposes under `name`: the inner end (`comp.port`, an element
    selection allowed) and the declared unit (one text for every element, a list per element,
    or None: the inner port's)."""

    name: str
    port: Given[str]
    unit: Given[Any] | None
    where: Location


#: the experiment keys every algorithm has; any other key is an option of the algorithm named
#: (checked by its own schema, `twmr.master.algorithm.options_schema`)
EXPERIMENT_KEYS = ("start", "stop", "step", "algorithm", "realtime", "fmu_terminate", "loops",
                   "loop_solver")


@dataclass(frozen=True)
class ExperimentSpec:
    """Start, stop and base step [s] as given (numbers, or text the builder reads as numbers),
    the algorithm's name, and pacing to the wall clock (None: decided by the components)."""

    start: Given[Any]
    stop: Given[Any]
    step: Given[Any]
    algorithm: Given[str]
    realtime: Given[bool | float | None]
    where: Location
    #: what an FMU's request to end the simulation does: 'error' or 'stop' (None: not given)
    fmu_terminate: Given[Any] | None = None
    #: algebraic loops: 'refuse' or 'solve', and the solver's options as a mapping (value None:
    #: not given)
    loops: Given[Any] | None = None
    loop_solver: Given[Any] | None = None
    #: the other keys: options of the algorithm (e.g. the adaptive master's rtol, max_step)
    options: Mapping[str, Given[Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class RecordingSpec:
    """Signal patterns to record (`comp.port`, wildcards allowed; None: every output) and the
    decimation (every n-th base step)."""

    signals: tuple[Given[str], ...] | None
    decimation: Given[int]
    where: Location


@dataclass(frozen=True)
class EventSpec:
    """An event during the run (`events:`): a fault on a port from `at` until `until` [s] (None:
    the end), `port` ('comp.port') frozen, biased, scaled, noisy, dropped out or stuck at
    `value`; or, with `set` ('comp.parameter'), the parameter set to `value` from `at` on. With
    `when` in place of `at`, either happens each time the condition becomes true."""

    at: Given[Any]
    until: Given[Any] | None
    port: Given[str] | None
    fault: Given[str] | None
    value: Given[Any] | None
    seed: Given[Any] | None
    where: Location
    set: Given[str] | None = None
    #: a condition ('comp.port[i] > c') in place of `at`, its hysteresis, and how long a fault
    #: it opens lasts [s] (None: to the end)
    when: Given[str] | None = None
    hysteresis: Given[Any] | None = None
    duration: Given[Any] | None = None
    #: what overrides call it (`events.<name>.at=5`)
    name: Given[str] | None = None


@dataclass(frozen=True)
class ScenarioSpec:
    """A whole scenario as loaded: components in the order written, wires
    ('src.output -> dst.input' texts), inputs left open, the experiment and what to record, and
    the ports it exposes when used as a subsystem (the experiment's stop and step are None in a
    subsystem file written without one).
    `base_dir` is the folder relative paths (FMUs, user block files) resolve against;
    `sections` locates the top-level keys ('components', 'connections', ...)."""

    source: str
    base_dir: Path
    components: dict[str, ComponentSpec]
    connections: tuple[Given[str], ...]
    open: tuple[Given[str], ...]
    experiment: ExperimentSpec
    record: RecordingSpec
    description: str = ""
    sections: dict[str, Location] = field(default_factory=dict)
    inputs: dict[str, Exposure] = field(default_factory=dict)
    outputs: dict[str, Exposure] = field(default_factory=dict)
    events: tuple[EventSpec, ...] = ()

    def at(self, section: str) -> Location:
        """Where a top-level section is (the file alone when it is not written)."""
        return self.sections.get(section, Location(self.source, 0, section))
