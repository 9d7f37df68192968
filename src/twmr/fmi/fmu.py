"""`FmuComponent`: an FMU (FMI 2.0 or 3.0, co-simulation or model exchange) as a component,
through fmpy.

Ports come from the modelDescription (`twmr.fmi.description`). Every variable type goes through
its own FMI call (fmi3GetFloat32, fmi3SetUInt64, ...), one call per type for all the values of a
step. Per step the FMU sees only the traffic a hand-written loop would make: the wired inputs are
set (the open ones once, at initialization), and only the outputs the run reads (wired or
recorded) are got, each once: direct-feedthrough outputs in `evaluate`, the others after the step.

Model exchange is integrated here with events (`twmr.fmi.exchange`). The FMU's log is captured
through the logger callback (`twmr.fmi.log`); every failed FMI call raises `FmuError` naming the
instance, the FMU, the call and the time, with the FMU's last log lines.
"""
from __future__ import annotations

import functools
import logging
import math
import operator
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from twmr.core.component import Component
from twmr.core.errors import ComponentError, FmuError, FmuTerminated
from twmr.core.run import RunContext
from twmr.fmi import guard, unpacked
from twmr.fmi.clocks import EventMode
from twmr.fmi.description import FmuPort, aliases_of, ports_of, read_description
from twmr.fmi.direct import accessor, direct_calls, stepper, supports
from twmr.fmi.exchange import SOLVERS, Integrator, Terminated
from twmr.fmi.log import FmuLog
from twmr.fmi.sources import DEFAULT_TIMEOUT, runnable
from twmr.fmi.states import KEEP, FmuStates, StateGone

if TYPE_CHECKING:
    from twmr.core.kernel import Kernel

__all__ = ["FmuComponent", "FmuPort", "ports_of", "read_description"]

log = logging.getLogger(__name__)

#: FMI 2.0 call suffix per FMI type
_FMI2_CALL = {"Real": "Real", "Integer": "Integer", "Enumeration": "Integer",
              "Boolean": "Boolean", "String": "String"}


#: FMI status codes above Warning (the names after fmi2 / fmi3)
_FMI_STATUS = {2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}


def _call_suffix(fmi_type: str, fmi3: bool) -> str:
    if not fmi3:
        return _FMI2_CALL[fmi_type]
    return "Int64" if fmi_type == "Enumeration" else fmi_type


def _text_getter(get: Callable[..., list[Any]]) -> Callable[..., list[str]]:
    """fmpy's getString, with the bytes some versions return decoded (UTF-8)."""
    def get_text(*args: Any) -> list[str]:
        return [v.decode("utf-8", "replace") if isinstance(v, bytes) else v for v in get(*args)]

    return get_text


def _shown(get: Callable[..., list[Any]], factor: float, offset: float
           ) -> Callable[..., list[float]]:
    """A getter of aliases in a display unit of their own: factor * value + offset."""
    def get_shown(*args: Any) -> list[float]:
        return [factor * v + offset for v in get(*args)]

    return get_shown


#: how an FMI 2.0 co-simulation FMU asks to end the simulation
_FMI2_DISCARDED = "(fmi2DoStep returned fmi2Discard and fmi2Terminated is true)"


def _tunable(md: Any, ports: list[FmuPort]) -> frozenset[str]:
    """The parameter ports whose FMU variables are all of variability tunable."""
    by_name = {v.name: v for v in md.modelVariables}
    found = set()
    for p in ports:
        if p.kind != "parameter":
            continue
        behind = [by_name[p.name]] if p.name in by_name else [
            v for n, v in by_name.items() if n.startswith(f"{p.name}[")]
        if behind and all(v.variability == "tunable" for v in behind):
            found.add(p.name)
    return frozenset(found)


class FmuComponent(Component):
    """An FMU stepped through fmpy; ports from its modelDescription."""

    kind = "fmu"
    #: a port without unit here means the FMU declares none (wiring it to a unit is warned about)
    generic_units = False
    construction_parameters = ("path", "interface", "solver", "rtol", "atol", "max_step",
                               "solver_step", "isolate", "timeout", "compile", "compile_timeout",
                               "built_by")
    #: beside the ports, a saved state holds the time, the inputs `evaluate` set and (event
    #: mode) the clocks' next ticks and the next time event
    state_attributes = ("_t", "_sent", "_clock_due", "_time_event")

    def __init__(self, name: str = "", path: str | Path = "", interface: str = "auto",
                 solver: str | None = None, rtol: float | None = None,
                 atol: float | None = None, max_step: float | None = None,
                 solver_step: float | None = None, **parameters: Any):
        """`interface`: auto (co-simulation when the FMU has it) | co_simulation |
        model_exchange. Model exchange only (given for co-simulation, they are refused):
        `solver` cvode (default) or rk4; `rtol`, `atol`
        (None: rtol × each state's nominal) and `max_step` [s] (0: no limit) for cvode;
        `solver_step` [s] for rk4."""
        label = name or "fmu"
        self.source_path = Path(path)
        self.md = read_description(self.source_path, label)
        if interface not in ("auto", "co_simulation", "model_exchange"):
            raise FmuError(label, None, f"interface '{interface}' is unknown. Fix: use auto, "
                           f"co_simulation or model_exchange.")
        self.me = interface == "model_exchange" or (interface == "auto" and
                                                     self.md.coSimulation is None)
        if (self.me and self.md.modelExchange is None) or (not self.me and
                                                           self.md.coSimulation is None):
            raise FmuError(label, None, f"'{self.source_path.name}' has no {interface} "
                           f"interface.")
        given = [k for k, v in (("solver", solver), ("rtol", rtol), ("atol", atol),
                                ("max_step", max_step), ("solver_step", solver_step))
                 if v is not None]
        if given and not self.me:
            raise FmuError(label, None, f"{', '.join(given)} given, but "
                           f"'{self.source_path.name}' runs as co-simulation, which brings its "
                           f"own solver (these options would change nothing). Fix: remove them, "
                           f"or set interface: model_exchange, if the FMU has it, to integrate "
                           f"it with {' or '.join(SOLVERS)}.")
        solver = "cvode" if solver is None else solver
        rtol = 1e-6 if rtol is None else rtol
        max_step = 0.0 if max_step is None else max_step
        solver_step = 1e-3 if solver_step is None else solver_step
        if solver not in SOLVERS:
            raise FmuError(label, None, f"solver '{solver}' is unknown. Fix: use one of "
                           f"{', '.join(SOLVERS)}.")
        for key, value in (("rtol", rtol), ("max_step", max_step), ("solver_step", solver_step)):
            if not isinstance(value, (int, float)) or value < 0 or value != value or \
                    (key != "max_step" and value == 0):
                raise FmuError(label, None, f"{key} = {value!r} must be a positive number.")
        self.solver, self.rtol, self.max_step = solver, float(rtol), float(max_step)
        self.atol = None if atol is None else float(atol)
        self.solver_step = float(solver_step)
        self.fmi3 = self.md.fmiVersion.startswith("3.")
        iface = self.md.modelExchange if self.me else self.md.coSimulation
        self.can_get_and_set_state = bool(iface.canGetAndSetFMUstate)
        self._serializes = bool(iface.canSerializeFMUstate)
        self._states: FmuStates | None = None
        self._sent: tuple[Any, ...] | None = None
        self._guarded = False  # between guard.enter() in setup and guard.leave() in terminate
        self.run_folder: Path | None = None  # where the run keeps its rows (for guard messages)
        try:
            self.ports, self._variables = ports_of(self.md, parameters)
        except ValueError as err:
            raise FmuError(label, None, f"'{self.source_path.name}': {err} in its "
                           f"modelDescription.xml. Fix: correct the FMU's model description "
                           f"(or ask its vendor).") from None
        self.sizing_parameters = frozenset(v.name for v in self.md.modelVariables
                                           if v.causality == "structuralParameter" and
                                           getattr(v, "alias", None) is None)
        self.aliases = aliases_of(self.md)
        #: parameters the FMU lets change between communication points (variability tunable)
        self.tunable = _tunable(self.md, self.ports) if not self.me else frozenset()
        self._initialized = False
        self.path = runnable(self.source_path, self.md, label)
        self.log = FmuLog(label)
        # FMUs built by pythonfmu itself (generationTool "PythonFMU x"; not twmr's Python exports,
        # which carry a binary of ours) run in this interpreter with pythonfmu's binary, whose
        # fmi2Instantiate releases a reference to the slave module's dict it does not own (0.6.4
        # to 0.7.0): the heap gets corrupted and a later free or collection crashes. They keep
        # fmpy's default callbacks, are never terminated nor freed, and their log is not captured
        self._pythonfmu = (self.md.generationTool or "").startswith("PythonFMU")
        self._fmu: Any = None
        self._unzipped: str | None = None
        self._integrator: Integrator | None = None
        self._t = 0.0
        self._given: set[str] = set()
        self._wired: set[str] | None = None
        self._read: set[str] | None = None
        self._after_step_all = False  # set by prepare: Jacobi
        # FMI 3.0 co-simulation with event mode: clocks, clocked variables, early return
        self.event_mode = self.fmi3 and not self.me and bool(self.md.coSimulation.hasEventMode)
        clocks = [p.name for p in self.ports if p.clock]
        if clocks and self.me:
            raise FmuError(label, None, f"'{self.source_path.name}' has clocks "
                           f"({', '.join(clocks[:5])}), which this importer runs in "
                           f"co-simulation only. Fix: remove interface: model_exchange.")
        self._events: EventMode | None = None
        self._clock_due: tuple[tuple[str, float], ...] = ()
        self._time_event = math.inf
        #: Binary ports that carry LS-BUS operations -> their terminal (checked at every tick)
        self.bus_data: dict[str, str] = {}
        self.terminals = self._bus_terminals(label) if self.fmi3 else {}
        super().__init__(name)
        self.variables = dict(self._variables)
        for var in self.variables.values():
            self.__dict__[var.name] = var.start
        for key, value in parameters.items():
            self.set_parameter(key, value)

    def clock_of(self, port: str) -> str | None:
        """A terminal member's clock, else the first clock the model description says clocks
        `port` (None: none)."""
        found = super().clock_of(port)
        if found is not None:
            return found
        clocks = {p.vrs[0]: p.name for p in self.ports if p.clock}
        clocked = next((p.clocked_by for p in self.ports if p.name == port), ())
        return next((clocks[vr] for vr in clocked if vr in clocks), None)

    def _bus_terminals(self, label: str) -> dict[str, dict[str, str]]:
        """The FMU's LS-BUS network terminals (member -> port), their members checked to be
        ports of the kind a bus terminal needs; a beta version's note is logged."""
        from twmr.fmi.lsbus.terminals import bus_terminals

        ports = {p.name: p for p in self.ports}
        need = {"Tx_Data": ("output", "Binary"), "Rx_Data": ("input", "Binary"),
                "Tx_Clock": ("output", "Clock"), "Rx_Clock": ("input", "Clock")}
        found: dict[str, dict[str, str]] = {}
        terminals = bus_terminals(self.source_path, label)
        for note in dict.fromkeys(n for t in terminals for n in t.notes):  # one per cause
            log.warning("note: component '%s': %s", label, note)
        for t in terminals:
            for member, (kind, type_) in need.items():
                p = ports.get(t.members[member])
                if p is None or p.kind != kind or p.fmi_type != type_:
                    raise FmuError(label, None, f"'{self.source_path.name}': bus terminal "
                                   f"'{t.name}' member {member} is '{t.members[member]}', which "
                                   f"is not an {kind} {type_} "
                                   f"port of the FMU (a clock the importer schedules counts as "
                                   f"an output). Fix: correct the FMU's terminalsAndIcons.xml.")
            self.bus_data[t.members["Tx_Data"]] = t.name
            found[t.name] = dict(t.members)
        return found

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> Component:
        path = construction.get("path")
        if not path:
            raise FmuError(name, None, "a component of kind 'fmu' needs `path:` under "
                           "`parameters:`. Fix: give the FMU file, e.g. path: fmus/plant.fmu")
        p = Path(str(path))
        rest = {k: v for k, v in construction.items() if k != "path"}
        full = p if p.is_absolute() else base_dir / p
        built_by = rest.pop("built_by", "")
        if built_by and not full.exists():
            raise FmuError(name, None, f"FMU file '{full}' not found: it is built by a command "
                           f"(built_by:). Fix: run it once, from the scenario's folder: "
                           f"{built_by}")
        isolate = rest.pop("isolate", False)
        if not isinstance(isolate, bool):
            raise FmuError(name, None, f"isolate: {isolate!r} is not true or false. Fix: write "
                           f"isolate: true to run the FMU in a worker process of its own.")
        full = cls._built(name, full, rest.pop("compile", False),
                          rest.pop("compile_timeout", DEFAULT_TIMEOUT))
        if isolate:
            from twmr.fmi.isolated import IsolatedFmu

            return IsolatedFmu(name, full, **rest)
        rest.pop("timeout", None)
        return cls(name, full, **rest)

    @staticmethod
    def _built(name: str, path: Path, compile: Any, timeout: Any) -> Path:
        """`path`, or with `compile: true` the FMU built from its sources when it has no binary
        for this platform (the same file name, in a scratch folder of this process)."""
        if not isinstance(compile, bool):
            raise FmuError(name, None, f"compile: {compile!r} is not true or false. Fix: write "
                           f"compile: true to build a source-only FMU when it is loaded.")
        if isinstance(timeout, bool) or not isinstance(timeout, (int, float)) or \
                not 0 < timeout < math.inf:
            raise FmuError(name, None, f"compile_timeout: {timeout!r} is not a positive number "
                           f"of seconds. Fix: give the longest the build may take, e.g. "
                           f"compile_timeout: {DEFAULT_TIMEOUT:g}")
        if not compile:
            return path
        return runnable(path, read_description(path, name), name, True, float(timeout))

    def set_parameter(self, name: str, value: Any) -> None:
        if name in self.aliases:
            raise ValueError(f"'{name}' is an alias of '{self.aliases[name]}' in the FMU (one "
                             f"variable under two names, read only as '{name}'); set "
                             f"'{self.aliases[name]}'")
        if getattr(self, "_initialized", False):  # during the run (a set event)
            if name not in self.tunable:
                raise ValueError(f"'{name}' is not a tunable parameter of the FMU: it takes "
                                 f"it only before it is initialized")
            super().set_parameter(name, value)
            self._write([p for p in self.ports if p.name == name])
            return
        super().set_parameter(name, value)
        self._given.add(name)
        if name in self.sizing_parameters:
            self._resize()

    def unknown_parameter(self, name: str) -> tuple[str, str] | None:
        """A parameter a twmr export fixed in the FMU's code (its description says "Compiled
        with name = value"): what it was fixed to, and the export command that changes it."""
        md = self.md
        if not str(md.generationTool or "").startswith("twmr-cosim"):
            return None
        fixed = re.search(r"Compiled with (.*)\.\s*$", str(md.description or ""))
        values = dict(re.findall(r"(\w+) = ([^,]+)", fixed.group(1))) if fixed else {}
        if name not in values:
            return None
        version = "3" if self.fmi3 else "2"
        return (f"'{name}' is not a parameter of this FMU: twmr export fixed it to "
                f"{values[name]} in the FMU's code.",
                f"export the block again with the value you want: twmr export "
                f"{md.modelName} --fmi {version} --set {name}=<value> --out "
                f"{self.source_path}")

    def _resize(self) -> None:
        """Ports again with the structural parameters' present values; a port whose size changed
        gets its new descriptor and start value."""
        given = {n: self.__dict__[n] for n in self.sizing_parameters}
        try:
            self.ports, variables = ports_of(self.md, given)
        except ValueError as err:
            raise ValueError(f"{err} (in the FMU's modelDescription.xml)") from None
        for key, var in variables.items():
            if var.size != self.variables[key].size:
                self.variables[key] = var
                self.__dict__[key] = var.start

    # -- FMI calls --------------------------------------------------------------------------
    def _call(self, what: str, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as exc:  # noqa: BLE001 - fmpy's FMICallException and OSError alike
            raise self._error(what, exc) from exc

    def _accessors(self, fmi_type: str) -> tuple[Callable[..., Any], Callable[..., Any]]:
        suffix = _call_suffix(fmi_type, self.fmi3)
        return getattr(self._fmu, f"get{suffix}"), getattr(self._fmu, f"set{suffix}")

    def prepare(self, run: RunContext) -> None:
        self.run_folder = run.folder
        self._wired = run.wired_inputs(self.name)
        self._read = run.read_outputs(self.name)
        # outputs passed on as they are after the step (Jacobi): the feedthrough ones too are
        # got after doStep (at t + h with the inputs held, as the native blocks leave them)
        self._after_step_all = run.outputs_as_stepped
        self.log.show_all = run.fmu_log

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self._t = start
        if not self._guarded:
            guard.enter()
            self._guarded = True
        iface = self.md.modelExchange if self.me else self.md.coSimulation
        shared = not self._pythonfmu and not iface.canBeInstantiatedOnlyOncePerProcess
        self._unzipped = self._call("extract", unpacked.take, self.path, shared)
        iface = self.md.modelExchange if self.me else self.md.coSimulation
        args = dict(guid=self.md.guid, unzipDirectory=self._unzipped,
                    modelIdentifier=iface.modelIdentifier, instanceName=self.name)
        version = "fmi3" if self.fmi3 else "fmi2"
        what = f"{version}Instantiate" + (("ModelExchange" if self.me else "CoSimulation")
                                           if self.fmi3 else "")
        if self.fmi3:
            from fmpy.fmi3 import FMU3Model, FMU3Slave

            fmu = self._load(FMU3Model if self.me else FMU3Slave, args)
            self._instantiate3(fmu, what)
        else:
            from fmpy.fmi2 import FMU2Model, FMU2Slave

            fmu = self._load(FMU2Model if self.me else FMU2Slave, args)
            callbacks = None if self._pythonfmu else self.log.fmi2_callbacks()
            self._call(what, lambda: fmu.instantiate(callbacks=callbacks,
                                                    loggingOn=not self._pythonfmu))
        self._fmu = fmu  # instantiated: from here on terminate() frees it
        if self.can_get_and_set_state:
            self._states = FmuStates(fmu, self.fmi3, self._serializes, self._call)
        if not self.fmi3:
            self._call("fmi2SetupExperiment", fmu.setupExperiment,
                       self.rtol if self.me else None, start)

    def _instantiate3(self, fmu: Any, what: str) -> None:
        """Instantiate an FMI 3.0 FMU, in event mode where its description offers it. An FMU
        without clocks whose binary refuses the event mode its XML declares (the Reference
        FMUs' Roberts) is instantiated again without it, as fmpy does: it then handles its
        own events inside doStep, and the run says so once."""
        def instantiate(event_mode: bool) -> None:
            events = {"eventModeUsed": True, "earlyReturnAllowed": True} if event_mode else {}
            fmu.instantiate(loggingOn=True, logMessage=self.log.fmi3_logger(), **events)

        if not self.event_mode:
            self._call(what, lambda: instantiate(False))
            return
        try:
            instantiate(True)
        except Exception as exc:  # noqa: BLE001 - fmpy raises Exception for a NULL instance
            if any(p.clock or p.clocked_by for p in self.ports):
                raise self._error(what, exc) from exc
            self._call(what, lambda: instantiate(False))
            self.event_mode = False
            log.warning("note: component '%s': FMU '%s' declares hasEventMode but refused to "
                        "be instantiated in event mode; it runs without it and handles its own "
                        "events inside each step (as fmpy runs it).", self.name, self.path.name)

    def _load(self, cls: Any, args: dict[str, Any]) -> Any:
        """fmpy's FMU object (its shared library loaded); the working directory kept, which
        fmpy leaves in the library's folder when loading fails."""
        cwd = os.getcwd()
        try:
            return cls(**args)
        except Exception as exc:  # noqa: BLE001 - fmpy raises Exception or AttributeError
            text = str(exc).strip().rstrip(".")
            reason = (f"it lacks the FMI function {text.rsplit(': ', 1)[-1]}"
                      if "undefined symbol" in text else text.rsplit(": ", 1)[-1])
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}': its shared library for "
                           f"this platform cannot be loaded ({reason}). Fix: get a build of the "
                           f"FMU for this platform from its vendor (this binary is damaged, "
                           f"built for another system, or lacks the FMI functions).") from None
        finally:
            if os.getcwd() != cwd:
                os.chdir(cwd)

    def initialize(self) -> None:
        f = self._fmu
        structural = [p for p in self.ports if p.name in self.sizing_parameters and
                      p.name in self._given]
        if structural:
            self._call("fmi3EnterConfigurationMode", f.enterConfigurationMode)
            self._write(structural)
            self._call("fmi3ExitConfigurationMode", f.exitConfigurationMode)
        if self.fmi3:
            self._call("fmi3EnterInitializationMode", f.enterInitializationMode,
                       self.rtol if self.me else None, self.start_time)
        else:
            self._call("fmi2EnterInitializationMode", f.enterInitializationMode)
        # the inputs (open ones keep these values), and the parameters and start values the
        # scenario gave: the others are the FMU's own
        self._write([p for p in self.ports if (p.kind == "input" or
                     (p.name in self._given and p.name not in self.sizing_parameters)) and
                     not p.clock and not p.clocked_by])
        self._call("ExitInitializationMode", f.exitInitializationMode)
        inputs = [p for p in self.ports if p.kind == "input" and not p.clock and
                  not p.clocked_by and (self._wired is None or p.name in self._wired)]
        outputs = [p for p in self.ports if p.kind in ("output", "state") and not p.clock and
                   not p.clocked_by]
        read = [p for p in outputs if self._read is None or p.name in self._read]
        feedthrough = {p.name for p in read if getattr(self.variables[p.name], "depends_on", ())}
        if self.me:
            self._integrator = Integrator(f, self.md, self.fmi3, self.solver, self.rtol,
                                          self.atol, self.max_step, self.solver_step, self._call)
            self._integrator.hold = self.hold_events
            try:
                self._integrator.start(self.start_time)
            except Terminated:
                raise self._terminated(self.start_time, "during its initial event "
                                       "iteration") from None
            self._set_cont = self._plan([p for p in inputs if not p.discrete], 1)
            self._set_disc = self._plan([p for p in inputs if p.discrete], 1)
            self._last_disc = self._values_of(self._set_disc)
            self._last_cont = self._values_of(self._set_cont)
        else:
            self._set_all = self._plan(inputs, 1)
        self._get_ft = self._plan([p for p in read if p.name in feedthrough], 0)
        self._get_step = self._plan([p for p in read if p.name not in feedthrough]
                                    if self.has_feedthrough and not self._after_step_all
                                    else read, 0)
        self._read_ft, self._read_step = self._readers(self._get_ft), \
            self._readers(self._get_step)
        if not self.me:
            self._sets = [(setter, vrs, gather) for setter, vrs, _, _, gather in self._set_all]
        self._sent = None
        if not self.me and not self.event_mode:
            self._step = stepper(f, self.fmi3) if direct_calls(f) and \
                not self._pythonfmu else self._fmpy_step
        if self.event_mode:  # initialization ended in event mode
            self._events = EventMode(EventHost(self))
            self._events.start(self.start_time)
            self._call("fmi3EnterStepMode", f.enterStepMode)
        try:
            self._get(self._plan(outputs, 0))
        except Exception as exc:  # noqa: BLE001
            raise self._error("reading the outputs after initialization", exc) from exc
        self._initialized = True

    def check_bus_data(self, port: str, data: bytes, t: float) -> None:
        """Decode the LS-BUS operations an FMU put on bus port `port` at t [s]; malformed ones
        stop the run naming the FMU, the terminal and the time."""
        terminal = self.bus_data.get(port)
        if terminal is None:
            return
        from twmr.fmi.lsbus.operations import BusOperationError, decode

        try:
            decode(data)
        except BusOperationError as err:
            raise FmuError(self.name, t, f"FMU '{self.path.name}', bus terminal '{terminal}' "
                           f"({port}, {len(data)} bytes): {err}. Fix: the FMU writes malformed "
                           f"bus operations; see its log or ask its vendor.",
                           self.log.tail()) from None

    def controls_its_error(self) -> bool:
        return self.me and self.solver == "cvode"

    def repeats_steps(self) -> bool:
        return self._integrator is None or not self._integrator.continued

    def early_event(self) -> float | None:
        return self._events.early if self._events is not None else None

    def events_unseen(self) -> str | None:
        if self.me or (self.md.modelExchange is not None and
                       not self.md.numberOfEventIndicators):
            return None  # its model-exchange interface says it has no state events
        cs = self.md.coSimulation
        if self.fmi3 and self.event_mode and cs.mightReturnEarlyFromDoStep:
            return None
        if any(p.kind == "output" and p.fmi_type not in ("Real", "Float64", "Float32")
               for p in self.ports):
            return None  # a counter or mode output that changes at its events
        how = "FMI 2.0 co-simulation" if not self.fmi3 else \
            "FMI 3.0 co-simulation without event mode and early return"
        return f"it runs as {how}: its events happen inside doStep, unreported"

    def next_event(self, t: float) -> float | None:
        if self._events is None:
            return None
        upcoming = self._events.next_time()
        return upcoming if upcoming > t and upcoming < math.inf else None

    def _plan(self, ports: list[FmuPort], which: int) -> list[Any]:
        """Per FMI type: the bound fmpy getter (which=0) or setter (1), the value references, the
        number of values, the ports [(name, scalar, count)] and a function gathering their
        values (for a setter), so each type is one call."""
        by: dict[tuple[str, tuple[float, float] | None], list[FmuPort]] = {}
        for p in ports:
            by.setdefault((_call_suffix(p.fmi_type, self.fmi3), p.display), []).append(p)
        plan = []
        direct = not self._pythonfmu and direct_calls(self._fmu)
        for (suffix, display), ps in by.items():
            vrs = [vr for p in ps for vr in p.vrs]
            count = sum(p.count for p in ps)
            if direct and display is None and supports(suffix, self.fmi3):
                fn = accessor(self._fmu, self.fmi3, suffix, which, vrs, count)
            else:
                fn = self._accessors(ps[0].fmi_type)[which]
                if which == 0 and ps[0].fmi_type == "String":
                    fn = _text_getter(fn)
                if display is not None:
                    fn = _shown(fn, *display)
            names = [(p.name, p.scalar, p.count) for p in ps]
            plan.append((fn, vrs, count, names, self._gather(names)))
        return plan

    def _gather(self, names: list[tuple[str, bool, int]]) -> Callable[[], list[Any]]:
        """A function returning the present values of ports `names`, flattened."""
        d = self.__dict__
        if len(names) == 1:
            name, scalar, _ = names[0]
            return (lambda: [d[name]]) if scalar else (lambda: list(d[name]))
        if all(scalar for _, scalar, _ in names):
            get = operator.itemgetter(*(name for name, _, _ in names))
            return lambda: list(get(d))
        return lambda: self._values(names)

    def _write(self, ports: list[FmuPort]) -> None:
        """Start values and parameters of `ports`, one call per type (initialization)."""
        for setter, vrs, _, names, gather in self._plan(ports, 1):
            values = gather()
            if setter.__name__ == "setString":
                values = [str(v) for v in values]
            self._call(f"{setter.__name__} of {', '.join(n for n, _, _ in names)}", setter, vrs,
                       values)

    def _values(self, names: list[tuple[str, bool, int]]) -> list[Any]:
        d = self.__dict__
        if len(names) == 1:
            name, scalar, _ = names[0]
            return [d[name]] if scalar else list(d[name])
        values: list[Any] = []
        for name, scalar, _ in names:
            if scalar:
                values.append(d[name])
            else:
                values.extend(d[name])
        return values

    @staticmethod
    def _values_of(plan: list[Any]) -> list[list[Any]]:
        return [gather() for *_, gather in plan]

    @staticmethod
    def _set(plan: list[Any]) -> None:
        for setter, vrs, _, _, gather in plan:
            setter(vrs, gather())

    def _get(self, plan: list[Any]) -> None:
        d = self.__dict__
        for getter, vrs, count, names, _ in plan:
            values = getter(vrs, count) if self.fmi3 else getter(vrs)
            if len(names) == 1:
                name, scalar, _ = names[0]
                d[name] = values[0] if scalar else tuple(values)
                continue
            k = 0
            for name, scalar, n in names:
                d[name] = values[k] if scalar else tuple(values[k:k + n])
                k += n

    def _readers(self, plan: list[Any]) -> list[Callable[[], None]]:
        """One function per call of `plan` (a getter's) getting its values into the ports."""
        d = self.__dict__
        out: list[Callable[[], None]] = []
        for entry in plan:
            getter, vrs, count, names, _ = entry
            if len(names) != 1 or not names[0][1]:
                out.append(functools.partial(self._get, [entry]))
            elif self.fmi3:
                def read3(getter: Any = getter, vrs: Any = vrs, count: int = count,
                          name: str = names[0][0]) -> None:
                    d[name] = getter(vrs, count)[0]
                out.append(read3)
            else:
                def read2(getter: Any = getter, vrs: Any = vrs, name: str = names[0][0]) -> None:
                    d[name] = getter(vrs)[0]
                out.append(read2)
        return out

    def _set_inputs(self, t: float) -> None:
        """The wired inputs into the FMU; for model exchange a changed discrete input is set in
        event mode (an event at t), and a changed continuous one restarts the solver."""
        if not self.me:
            self._set(self._set_all)
            return
        integ = self._integrator
        assert integ is not None
        if self._set_cont:
            values = self._values_of(self._set_cont)
            if values != self._last_cont:
                self._set(self._set_cont)
                self._last_cont = values
                integ.restart()
        if self._set_disc:
            values = self._values_of(self._set_disc)
            if values != self._last_disc:
                integ.event(t, lambda: self._set(self._set_disc))
                self._last_disc = values

    def evaluate(self, t: float) -> None:
        self._t = t
        try:
            if self.me:
                self._set_inputs(t)
            else:
                self._sent = sent = tuple([gather() for _, _, gather in self._sets])
                for (setter, vrs, _), values in zip(self._sets, sent, strict=True):
                    setter(vrs, values)
            for read in self._read_ft:
                read()
        except (FmuError, Terminated):
            raise
        except Exception as exc:  # noqa: BLE001 - fmpy raises FMICallException
            raise self._error("setting the inputs and getting the outputs", exc) from exc

    def do_step(self, t: float, h: float) -> None:
        self._t = t
        try:
            # the inputs as they are now: under Gauss-Seidel a block stepped since `evaluate`
            # may have changed them (only those that changed are set again)
            if self.me:
                self._set_inputs(t)
            else:
                sent, self._sent = self._sent, None
                if sent is None:
                    for setter, vrs, gather in self._sets:
                        setter(vrs, gather())
                else:
                    for (setter, vrs, gather), values in zip(self._sets, sent, strict=True):
                        now = gather()
                        if now != values:
                            setter(vrs, now)
            terminate = False
            if self.me:
                assert self._integrator is not None
                self._integrator.stop_inside = self.stop_at_events
                self._integrator.advance(t + h)
            elif self._events is not None:
                self._events.step(t, h)
            elif self._step(t, h):
                terminate = True
            for read in self._read_step:
                read()
        except Terminated as stop:
            raise self._terminated(stop.args[0], "(terminateSimulation)") from None
        except FmuError:
            raise
        except Exception as exc:  # noqa: BLE001 - fmpy raises FMICallException
            if self._fmi2_terminated():
                raise self._terminated(t, _FMI2_DISCARDED) from None
            what = "the model-exchange step" if self.me else ("fmi3DoStep" if self.fmi3
                                                              else "fmi2DoStep")
            raise self._error(what, exc) from exc
        if terminate:
            raise self._terminated(t, "(fmi3DoStep terminateSimulation)")

    def _fmpy_step(self, t: float, h: float) -> bool:
        """fmpy's doStep: whether the FMU asks to terminate (FMI 3.0)."""
        result = self._fmu.doStep(t, h)
        return bool(self.fmi3 and result[1])

    def _terminated(self, t: float, how: str) -> FmuTerminated:
        """The FMU's request at `t` to end the simulation, `how` it asked."""
        return FmuTerminated(self.name, t, f"FMU '{self.path.name}' asked to terminate the "
                             f"simulation {how}.", self.log.tail())

    def state_event(self) -> float | None:
        return None if self._integrator is None else self._integrator.state_event

    def event(self, t: float) -> None:
        """Model exchange: the state event held at the end of the last step (event mode and
        iteration), then every read output got again."""
        integ = self._integrator
        if integ is None or not integ.held:
            return
        self._t = t
        try:
            integ.handle_held()
            self._get(self._get_ft)
            self._get(self._get_step)
        except Terminated as stop:
            raise self._terminated(stop.args[0], "(terminateSimulation)") from None
        except FmuError:
            raise
        except Exception as exc:  # noqa: BLE001 - fmpy raises FMICallException
            raise self._error("the event at the end of the step", exc) from exc

    def _fmi2_terminated(self) -> bool:
        """After a discarded fmi2DoStep: whether the FMU says it has terminated."""
        if self.me or self.fmi3:
            return False
        try:
            from fmpy.fmi2 import fmi2Terminated

            return bool(self._fmu.getBooleanStatus(fmi2Terminated))
        except Exception:  # noqa: BLE001 - the status is optional in FMI 2.0
            return False

    def _error(self, what: str, exc: BaseException) -> FmuError:
        from fmpy.fmi1 import FMICallException

        if isinstance(exc, FMICallException):  # "fmi2DoStep failed with status 3 (error)."
            said = str(exc).rstrip(".")
            cause = said if exc.function in what else f"{what}: {said}"
        else:
            cause = f"{what} failed ({type(exc).__name__}: {exc})"
        return FmuError(self.name, self._t, f"FMU '{self.path.name}': {cause}. Fix: see the "
                        f"FMU's log; check its inputs and parameters at this time.",
                        self.log.tail())

    def report(self) -> dict[str, Any]:
        if self._integrator is None:
            return {}
        return {"solver": self.solver, "events": self._integrator.events}

    def compiled_calls(self, h: float) -> Kernel | None:
        """This FMU's compiled form, for the compiled loop (`twmr.master.compiled`, mode 'on'):
        the loop calls its set, get and doStep functions itself through their C function
        pointers, with the calls and their order of `evaluate` / `do_step`
        (`twmr.fmi.compiled_calls`). `NotCompilable` saying why not for model exchange, event
        mode, pythonfmu's own FMUs (they keep the Python loop) and a port the loop cannot
        carry. Call after `initialize`; `h` [s] is its step."""
        from twmr.fmi.compiled_calls import TERMINATE, NotCompilable, compiled_form

        fmu = self._fmu
        why = "it is not instantiated" if fmu is None or not hasattr(fmu, "dll") else \
            "it is model exchange (the master's solver integrates it, in Python)" if self.me \
            else "it runs in event mode (FMI 3.0 hasEventMode: the master handles its events " \
            "and clocks, in Python)" if self.event_mode else \
            "it is a pythonfmu FMU (its model runs in this interpreter)" if self._pythonfmu \
            else ""
        if why:
            raise NotCompilable(f"FMU '{self.name}' ({self.path.name}) is not called from the "
                                f"compiled loop: {why}")
        version = "fmi3" if self.fmi3 else "fmi2"

        def error(call: str, status: int, t: float) -> BaseException:
            self._t = t
            if status == TERMINATE:
                return self._terminated(t, "(fmi3DoStep terminateSimulation)")
            if call == "fmi2DoStep" and status == 2 and self._fmi2_terminated():
                return self._terminated(t, _FMI2_DISCARDED)
            said = _FMI_STATUS.get(status, str(status))
            return FmuError(self.name, t, f"FMU '{self.path.name}': {call} returned "
                            f"{version}{said}. Fix: see the FMU's log; check its inputs and "
                            f"parameters at this time.", self.log.tail())

        return compiled_form(self, fmu, self.fmi3, [self._set_all, self._get_ft,
                                                    self._get_step], error)

    def get_state(self) -> Any:
        """(the FMU's state: serialised bytes, or a token while the FMU holds it; the ports,
        time and step flag; for model exchange the integrator's time, next event time and last
        inputs): plain values that pickle. For model exchange the solver goes on after a save
        with its history and restarts at a restore (`repeats_steps`)."""
        if not self.can_get_and_set_state:
            raise self.no_state("save")
        if self._states is None:
            raise FmuError(self.name, None, f"FMU '{self.path.name}': its state can be saved "
                           f"only between setup() and terminate().")
        return self._states.save(), super().get_state(), self._integrator_state()

    def _integrator_state(self) -> tuple[Any, ...]:
        integ = self._integrator
        if integ is None:
            return ()
        return (integ.save(), tuple(map(tuple, self._last_cont)),
                tuple(map(tuple, self._last_disc)))

    def set_state(self, state: Any) -> None:
        if not self.can_get_and_set_state:
            raise self.no_state("restore")
        if self._states is None:
            raise FmuError(self.name, None, f"FMU '{self.path.name}': its state can be "
                           f"restored only between setup() and terminate().")
        try:
            saved, values, integrator = state
        except (TypeError, ValueError):
            raise ComponentError(self.name, None, "the state given to set_state was not saved "
                                 "by an FMU component. Fix: restore only states that this "
                                 "component's get_state returned.") from None
        try:
            self._states.restore(saved)
        except StateGone:
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}': state {saved} was "
                           f"released (a component holds at most the last "
                           f"{KEEP} unreleased states of an FMU that cannot serialise them). "
                           f"Fix: release states no longer needed, or restore a newer one.",
                           ) from None
        super().set_state(values)
        if self._integrator is not None:
            at, cont, disc = integrator
            self._last_cont, self._last_disc = list(map(list, cont)), list(map(list, disc))
            self._integrator.restore(at)

    def release_state(self, state: Any) -> None:
        if self._states is not None:
            self._states.release(state[0])

    def no_state(self, what: str) -> ComponentError:
        return FmuError(self.name, None, f"FMU '{self.path.name}' cannot {what} its state: "
                        f"{self.why_no_state()}. Fix: use an algorithm that does not roll steps "
                        f"back with this FMU, or an FMU exported with state support.")

    def _read_last_sent(self, fmu: Any) -> None:
        """Each bus terminal's Tx_Data after fmi3Terminate, where the FMU lets it be read."""
        vrs = {p.name: p.vrs[0] for p in self.ports}
        for terminal, members in self.terminals.items():
            try:
                with self.log.probe():
                    raw = fmu.getBinary([vrs[members["Tx_Data"]]])[0]
            except Exception:  # noqa: BLE001 - an FMU that keeps nothing for after terminate
                continue
            if raw:
                self._last_sent[terminal] = bytes(raw)

    def last_sent(self, terminal: str) -> bytes:
        return getattr(self, "_last_sent", {}).get(terminal, b"")

    def why_no_state(self) -> str:
        iface = "model exchange" if self.me else "co-simulation"
        attribute = "canGetAndSetFMUState" if self.fmi3 else "canGetAndSetFMUstate"
        return f"its modelDescription.xml does not declare {attribute}=\"true\" for {iface}"

    def terminate(self) -> None:
        """fmiTerminate, each bus terminal's last Tx_Data read (FMI 3.0 allows getting values
        in the Terminated state: a CAN node's frames that stop its drives), fmiFreeInstance
        (only for an instance that was created)."""
        if self._states is not None:
            self._states.close()
            self._states = None
        self._last_sent: dict[str, bytes] = {}
        if self._fmu is not None:
            fmu, self._fmu = self._fmu, None
            try:
                if not self._pythonfmu:  # see __init__: pythonfmu's own binary
                    fmu.terminate()
                    self._read_last_sent(fmu)
                    fmu.freeInstance()
            except Exception:  # noqa: BLE001 - terminating after an error must not mask it
                pass
        if self._integrator is not None:
            self._integrator.close()
            self._integrator = None
        if self._unzipped:
            unpacked.give_back(self._unzipped)
            self._unzipped = None
        if self._guarded:
            self._guarded = False
            guard.leave()


class EventHost:
    """What the event mode of an FMI 3.0 FMU (`twmr.fmi.clocks.EventMode`) may use of its
    `FmuComponent`, and nothing more: the instance, its ports and values, the calls that report
    failures with the FMU's log, and the clock state the component saves with its own state.
    (A separate object, so no name of it can clash with a variable of the FMU.)"""

    def __init__(self, comp: FmuComponent):
        self._c = comp
        self.name, self.path, self.log = comp.name, comp.path, comp.log
        self.ports, self.source_path = comp.ports, comp.source_path
        #: the component's variable values, by port name
        self.values: dict[str, Any] = comp.__dict__
        self.bus_data = comp.bus_data
        self.check_bus_data = comp.check_bus_data
        self.call, self.write, self.plan = comp._call, comp._write, comp._plan
        self.terminated = comp._terminated

    @property
    def instance(self) -> Any:
        """fmpy's instance of the FMU."""
        return self._c._fmu

    @property
    def now(self) -> float:
        """The time [s] the FMU's calls are made at (for their errors)."""
        return self._c._t

    @now.setter
    def now(self, t: float) -> None:
        self._c._t = t

    @property
    def clock_due(self) -> tuple[tuple[str, float], ...]:
        """The scheduled clocks' next ticks: (clock port, time [s]), by name."""
        return self._c._clock_due

    @clock_due.setter
    def clock_due(self, due: tuple[tuple[str, float], ...]) -> None:
        self._c._clock_due = due

    @property
    def time_event(self) -> float:
        """The FMU's next time event [s] (inf: none)."""
        return self._c._time_event

    @time_event.setter
    def time_event(self, t: float) -> None:
        self._c._time_event = t

