"""`FmuComponent`: an FMU (FMI 2.0 or 3.0 co-simulation, FMI 2.0 model exchange integrated here by
RK4) as a component, through fmpy.

Ports come from the modelDescription: causality input/output -> `Input`/`Output`, parameters
(fixed or tunable) -> `Parameter`, with type, unit (the variable's or its declaredType's), start,
min/max and description. Modelica array names `x[1]..x[n]` are grouped into a vector port `x` of
size n. Direct feedthrough comes from ModelStructure (an output without dependency information
depends on every input, as the standard says).

Each step is one set call per type for all inputs, `doStep`, and one get call for all outputs.
Every FMI call that fails raises `FmuError` naming the instance, the FMU, the call and the time.
"""
from __future__ import annotations

import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

from twmr.core.component import Component
from twmr.core.errors import FmuError
from twmr.core.port import (
    BOOLEAN, INTEGER, REAL, STRING, Input, Output, Parameter, State, Variable,
)

_ARRAY = re.compile(r"^(.*)\[(\d+)\]$")
_TYPES = {"Real": REAL, "Float64": REAL, "Float32": REAL, "Integer": INTEGER, "Int32": INTEGER,
          "Int64": INTEGER, "Int16": INTEGER, "Int8": INTEGER, "UInt32": INTEGER,
          "UInt16": INTEGER, "UInt8": INTEGER, "UInt64": INTEGER, "Enumeration": INTEGER,
          "Boolean": BOOLEAN, "String": STRING}


@dataclass
class _Port:
    """One port and the FMU variables behind it (value references, in element order)."""

    name: str
    kind: str
    type: str
    vrs: list[int]
    scalar: bool


def _unit(v: Any) -> str:
    unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None)
    return unit or ""


def _start(v: Any, type_: str) -> Any:
    raw = getattr(v, "start", None)
    if raw is None:
        return None
    if type_ == STRING:
        return str(raw)
    text = str(raw).strip()
    try:
        if type_ == BOOLEAN:
            return {"true": True, "1": True, "false": False, "0": False}[text.lower()]
        return float(text) if type_ == REAL else int(float(text))
    except (ValueError, KeyError):
        raise ValueError(f"variable '{v.name}' has start=\"{raw}\", which is not a valid "
                         f"{type_}") from None


def read_description(path: Path, instance: str = "fmu") -> Any:
    """fmpy's ModelDescription of `path`, with every failure as an FmuError."""
    from fmpy import read_model_description

    if not path.exists():
        raise FmuError(instance, None, f"FMU file '{path}' not found. Fix: check `path:` (relative "
                       f"paths are taken from the scenario's folder).")
    try:
        md = read_model_description(str(path), validate=False)
    except Exception as exc:  # noqa: BLE001 - fmpy raises many kinds (zip, XML, schema)
        raise FmuError(instance, None, f"'{path}' is not a readable FMU ({type(exc).__name__}: "
                       f"{exc}). Fix: check the file is an FMU (a zip with modelDescription.xml)."
                       ) from None
    if md.fmiVersion.startswith("1."):
        raise FmuError(instance, None, f"'{path}' is an FMI 1.0 FMU, which is not supported. Fix: "
                       f"export it as FMI 2.0 or 3.0 co-simulation.")
    if md.coSimulation is None and (md.modelExchange is None or md.fmiVersion != "2.0"):
        raise FmuError(instance, None, f"'{path}' has neither a co-simulation interface nor an "
                       f"FMI 2.0 model-exchange one. Fix: export it as FMI 2.0/3.0 co-simulation "
                       f"or FMI 2.0 model exchange.")
    return md


def ports_of(md: Any) -> tuple[list[_Port], dict[str, Variable]]:
    """Ports (grouped arrays) and their Variable descriptors from a ModelDescription."""
    groups: dict[tuple[str, str], list[tuple[int, Any]]] = {}
    order: list[tuple[str, str]] = []
    for v in md.modelVariables:
        if v.causality == "input":
            kind = "input"
        elif v.causality == "output":
            kind = "state" if getattr(v, "initial", None) == "exact" else "output"
        elif v.causality == "parameter" and v.variability in ("fixed", "tunable"):
            kind = "parameter"
        else:
            continue
        m = _ARRAY.match(v.name)
        key = (m.group(1), kind) if m else (v.name, kind)
        idx = int(m.group(2)) if m else 0
        if key not in groups:
            groups[key] = []
            order.append(key)
        groups[key].append((idx, v))
    ports: list[_Port] = []
    variables: dict[str, Variable] = {}
    inputs_by_var: dict[int, str] = {}
    for key in order:
        name, kind = key
        items = sorted(groups[key], key=lambda x: x[0])
        scalar = len(items) == 1 and items[0][0] == 0
        if not scalar and [i for i, _ in items] != list(range(1, len(items) + 1)):
            # not a complete 1..n array: keep every element as its own scalar port
            for i, v in items:
                _add(ports, variables, f"{name}_{i}", kind, [v], True)
            continue
        _add(ports, variables, name, kind, [v for _, v in items], scalar)
        if kind == "input":
            for _, v in items:
                inputs_by_var[id(v)] = name
    all_inputs = tuple(p.name for p in ports if p.kind == "input")
    deps: dict[str, set[str]] = {}
    for unknown in getattr(md, "outputs", []) or []:
        m = _ARRAY.match(unknown.variable.name)
        port = m.group(1) if m else unknown.variable.name
        if getattr(unknown.variable, "initial", None) == "exact":
            continue  # a state: never depends directly on inputs
        if unknown.dependencies is None:
            deps.setdefault(port, set()).update(all_inputs)
        else:
            deps.setdefault(port, set()).update(
                inputs_by_var[id(d)] for d in unknown.dependencies if id(d) in inputs_by_var)
    for p in ports:
        if p.kind in ("output", "state"):
            var = variables[p.name]
            assert isinstance(var, Output)
            var.depends_on = () if p.kind == "state" else \
                tuple(sorted(deps.get(p.name, set(all_inputs))))
    return ports, variables


def _add(ports: list[_Port], variables: dict[str, Variable], name: str, kind: str,
         vs: list[Any], scalar: bool) -> None:
    type_ = _TYPES.get(vs[0].type, REAL)
    units = tuple(_unit(v) for v in vs)
    starts = [_start(v, type_) for v in vs]
    cls = {"input": Input, "output": Output, "state": State, "parameter": Parameter}[kind]
    kwargs: dict[str, Any] = {"type": type_, "description": vs[0].description or ""}
    if type_ != STRING:
        kwargs["unit"] = units[0] if len(set(units)) == 1 else units
    if scalar:
        start = starts[0]
        if start is None:
            start = "" if type_ == STRING else (False if type_ == BOOLEAN else 0)
        var = cls(start=start, **kwargs)
    else:
        kwargs["size"] = len(vs)
        var = cls(start=tuple(0 if s is None else s for s in starts), **kwargs)
    var.name = name
    variables[name] = var
    ports.append(_Port(name, kind, type_, [v.valueReference for v in vs], scalar))


class FmuComponent(Component):
    """An FMU (FMI 2.0/3.0 co-simulation) stepped through fmpy; ports from its modelDescription."""

    kind = "fmu"
    construction_parameters = ("path", "interface", "solver_step")

    def __init__(self, name: str = "", path: str | Path = "", interface: str = "auto",
                 solver_step: float = 1e-3, **parameters: Any):
        """`interface`: auto (co-simulation when the FMU has it) | co_simulation |
        model_exchange (FMI 2.0: integrated here by RK4 with steps of at most `solver_step` [s],
        inputs held over each communication step; time and state events are not handled)."""
        self.path = Path(path)
        self.md = read_description(self.path, name or "fmu")
        if interface not in ("auto", "co_simulation", "model_exchange"):
            raise FmuError(name, None, f"interface '{interface}' is unknown. Fix: use auto, "
                           f"co_simulation or model_exchange.")
        self.me = interface == "model_exchange" or (interface == "auto" and
                                                     self.md.coSimulation is None)
        if (self.me and self.md.modelExchange is None) or (not self.me and
                                                           self.md.coSimulation is None):
            raise FmuError(name, None, f"'{self.path.name}' has no {interface} interface.")
        self.solver_step = float(solver_step)
        try:
            self.ports, self._variables = ports_of(self.md)
        except ValueError as err:
            raise FmuError(name, None, f"'{self.path.name}': {err} in its modelDescription.xml. "
                           f"Fix: correct the FMU's model description (or ask its vendor).") \
                from None
        self.fmi3 = self.md.fmiVersion.startswith("3.")
        self._slave: Any = None
        self._unzipped: str | None = None
        self._t = 0.0
        super().__init__(name)
        self.variables = dict(self._variables)
        for var in self.variables.values():
            self.__dict__[var.name] = var.start
        for key, value in parameters.items():
            self.set_parameter(key, value)

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> "FmuComponent":
        path = construction.get("path")
        if not path:
            raise FmuError(name, None, "a component of kind 'fmu' needs `path:` under "
                           "`parameters:`. Fix: give the FMU file, e.g. path: fmus/plant.fmu")
        p = Path(str(path))
        rest = {k: v for k, v in construction.items() if k != "path"}
        return cls(name, p if p.is_absolute() else base_dir / p, **rest)

    # -- FMI calls --------------------------------------------------------------------------
    def _call(self, what: str, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            return fn(*args)
        except Exception as exc:  # noqa: BLE001 - fmpy's FMICallException and OSError alike
            raise self._error(what, exc) from exc

    def _accessors(self, type_: str) -> tuple[Callable[..., Any], Callable[..., Any]]:
        s = self._slave
        if self.fmi3:
            return {REAL: (s.getFloat64, s.setFloat64), INTEGER: (s.getInt32, s.setInt32),
                    BOOLEAN: (s.getBoolean, s.setBoolean), STRING: (s.getString, s.setString)
                    }[type_]
        return {REAL: (s.getReal, s.setReal), INTEGER: (s.getInteger, s.setInteger),
                BOOLEAN: (s.getBoolean, s.setBoolean), STRING: (s.getString, s.setString)}[type_]

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        from fmpy import extract

        self._t = start
        import fmpy

        platforms = fmpy.supported_platforms(str(self.path))
        here = fmpy.platform if not self.fmi3 else __import__("fmpy.fmi3").fmi3.platform_tuple
        if fmpy.platform not in platforms and here not in platforms:
            raise FmuError(self.name, start, f"FMU '{self.path.name}' has no binary for this "
                           f"platform ({fmpy.platform}); it has: {', '.join(platforms) or 'none'}"
                           f". Fix: get a build of the FMU for {fmpy.platform}.")
        self._unzipped = self._call("extract", extract, str(self.path),
                                    tempfile.mkdtemp(prefix="twmr-fmu-"))
        cs = self.md.modelExchange if self.me else self.md.coSimulation
        if self.me:
            from fmpy.fmi2 import FMU2Model

            self._slave = FMU2Model(guid=self.md.guid, unzipDirectory=self._unzipped,
                                    modelIdentifier=cs.modelIdentifier, instanceName=self.name)
            self._call("fmi2Instantiate", self._slave.instantiate)
            self._call("fmi2SetupExperiment", self._slave.setupExperiment, None, start)
        elif self.fmi3:
            from fmpy.fmi3 import FMU3Slave

            self._slave = FMU3Slave(guid=self.md.instantiationToken,
                                    unzipDirectory=self._unzipped,
                                    modelIdentifier=cs.modelIdentifier, instanceName=self.name)
            self._call("fmi3InstantiateCoSimulation", self._slave.instantiate)
        else:
            from fmpy.fmi2 import FMU2Slave

            self._slave = FMU2Slave(guid=self.md.guid, unzipDirectory=self._unzipped,
                                    modelIdentifier=cs.modelIdentifier, instanceName=self.name)
            self._call("fmi2Instantiate", self._slave.instantiate)
            self._call("fmi2SetupExperiment", self._slave.setupExperiment, None, start)

    def initialize(self) -> None:
        s = self._slave
        if self.fmi3:
            self._call("fmi3EnterInitializationMode", s.enterInitializationMode, None,
                       self.start_time)
        else:
            self._call("fmi2EnterInitializationMode", s.enterInitializationMode)
        self._write([p for p in self.ports if p.kind in ("parameter", "input", "state")])
        self._call("ExitInitializationMode", s.exitInitializationMode)
        if self.me:
            self._me_start()
        self._inputs = [p for p in self.ports if p.kind == "input"]
        self._outputs = [p for p in self.ports if p.kind in ("output", "state")]
        self._plan = self._group(self._inputs), self._group(self._outputs)
        self._compile()
        try:
            self._read()
        except Exception as exc:  # noqa: BLE001
            raise self._error("reading the outputs after initialization", exc) from exc

    def _group(self, ports: list[_Port]) -> list[tuple[str, list[int], list[_Port]]]:
        """Ports by type, with their value references concatenated: one FMI call per type."""
        by: dict[str, list[_Port]] = {}
        for p in ports:
            by.setdefault(p.type, []).append(p)
        return [(t, [vr for p in ps for vr in p.vrs], ps) for t, ps in by.items()]

    def _write(self, ports: list[_Port]) -> None:
        d = self.__dict__
        for type_, vrs, ps in self._group(ports):
            values: list[Any] = []
            for p in ps:
                v = d[p.name]
                values.extend((v,) if p.scalar else v)
            if type_ == STRING:
                values = [str(v) for v in values]
            self._call(f"set {type_}", self._accessors(type_)[1], vrs, values)

    def _compile(self) -> None:
        """Per type: the bound fmpy setter/getter, the value references, and the ports, so a step
        is one set call per input type, doStep, one get call per output type."""
        def plan(groups: list[tuple[str, list[int], list[_Port]]], which: int) -> list[Any]:
            return [(self._accessors(t)[which], vrs, [(q.name, q.scalar, len(q.vrs)) for q in ps])
                    for t, vrs, ps in groups]

        self._set_plan = plan(self._plan[0], 1)
        self._get_plan = plan(self._plan[1], 0)

    def _write_inputs(self) -> None:
        d = self.__dict__
        for setter, vrs, ports in self._set_plan:
            if len(ports) == 1:
                name, scalar, _ = ports[0]
                setter(vrs, (d[name],) if scalar else d[name])
                continue
            values: list[Any] = []
            for name, scalar, _ in ports:
                if scalar:
                    values.append(d[name])
                else:
                    values.extend(d[name])
            setter(vrs, values)

    def _read(self) -> None:
        d = self.__dict__
        for getter, vrs, ports in self._get_plan:
            values = getter(vrs)
            k = 0
            for name, scalar, n in ports:
                d[name] = values[k] if scalar else tuple(values[k:k + n])
                k += n

    def evaluate(self, t: float) -> None:
        self._t = t
        try:
            self._write_inputs()
            self._read()
        except Exception as exc:  # noqa: BLE001 - fmpy raises FMICallException
            raise self._error("get/set of inputs and outputs", exc) from exc

    def _me_start(self) -> None:
        """Event iteration after initialization, then continuous-time mode (model exchange)."""
        import numpy as np

        s = self._slave
        while self._call("fmi2NewDiscreteStates", s.newDiscreteStates)[0]:
            pass  # iterate until no new discrete states are needed
        self._call("fmi2EnterContinuousTimeMode", s.enterContinuousTimeMode)
        self._nx = self.md.numberOfContinuousStates
        self._x = np.zeros(self._nx)
        self._dx = np.zeros(self._nx)

    def _me_step(self, t: float, h: float) -> None:
        """RK4 over [t, t + h] with the inputs held, substeps of at most `solver_step`."""
        from ctypes import POINTER, c_double

        s, x, dx, nx = self._slave, self._x, self._dx, self._nx
        xp, dxp = x.ctypes.data_as(POINTER(c_double)), dx.ctypes.data_as(POINTER(c_double))

        def f(time: float, state: Any) -> Any:
            x[:] = state
            s.setTime(time)
            s.setContinuousStates(xp, nx)
            s.getDerivatives(dxp, nx)
            return dx.copy()

        s.getContinuousStates(xp, nx)
        n = max(1, int(-(-h // self.solver_step)))
        hs = h / n
        y = x.copy()
        for k in range(n):
            tk = t + k * hs
            k1 = f(tk, y)
            k2 = f(tk + hs / 2, y + hs / 2 * k1)
            k3 = f(tk + hs / 2, y + hs / 2 * k2)
            k4 = f(tk + hs, y + hs * k3)
            y = y + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        x[:] = y
        s.setTime(t + h)
        s.setContinuousStates(xp, nx)
        enter_event, terminate = s.completedIntegratorStep()
        if terminate:
            raise FmuError(self.name, t + h, f"FMU '{self.path.name}' asked to terminate.")

    def do_step(self, t: float, h: float) -> None:
        self._t = t
        try:
            self._write_inputs()
            result = self._me_step(t, h) if self.me else self._slave.doStep(t, h)
            self._read()
        except Exception as exc:  # noqa: BLE001 - fmpy raises FMICallException
            raise self._error("doStep", exc) from exc
        if self.fmi3 and result is not None and result[1]:
            raise FmuError(self.name, t, f"FMU '{self.path.name}' asked to terminate the "
                           f"simulation (fmi3DoStep terminateSimulation).")

    def _error(self, what: str, exc: BaseException) -> FmuError:
        return FmuError(self.name, self._t, f"FMU '{self.path.name}': {what} failed "
                        f"({type(exc).__name__}: {exc}). Fix: see the FMU's log; check its "
                        f"inputs and parameters at this time.")

    def get_state(self) -> Any:
        if not getattr(self.md.coSimulation, "canGetAndSetFMUstate", False):
            raise FmuError(self.name, self._t, f"FMU '{self.path.name}' cannot save its state "
                           f"(canGetAndSetFMUstate is false).")
        get = getattr(self._slave, "getFMUState", None) or self._slave.getFMUstate
        return self._call("getFMUstate", get), dict(self.__dict__)

    def set_state(self, state: Any) -> None:
        fmu_state, values = state
        set_ = getattr(self._slave, "setFMUState", None) or self._slave.setFMUstate
        self._call("setFMUstate", set_, fmu_state)
        self.__dict__.update(values)

    def terminate(self) -> None:
        if self._slave is not None:
            try:
                if not (self.md.generationTool or "").startswith("PythonFMU"):
                    self._slave.terminate()
                    self._slave.freeInstance()
                # pythonfmu 0.7 FMUs run in this interpreter; their fmi2Terminate/FreeInstance
                # release Python objects they do not own and crash a later garbage collection
                # (seen with several instances in one process), so they are left to process exit
            except Exception:  # noqa: BLE001 - terminating after an error must not mask it
                pass
            self._slave = None
        if self._unzipped:
            shutil.rmtree(self._unzipped, ignore_errors=True)
            self._unzipped = None
