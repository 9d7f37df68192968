"""`TwmrSlave`: the pythonfmu slave that runs a native component inside an exported FMU.

An exported FMU holds a tiny script `class <Model>(TwmrSlave): KIND = ...; PARAMETERS = ...`
(or `COMPONENT = <a Component class>` for a class of the user's); at run time the FMU's binary
(`pyfmu_wrapper/pyslave.c`) imports it in the Python interpreter of the host process, so **the host
must be Python with twmr-cosim installed**; otherwise the FMU logs that and fmi2Instantiate fails.

Every port element becomes one FMI variable, named `port[i]` for vector ports as Modelica tools do;
inputs and outputs are read and written straight in the component's values; states are outputs
with initial="exact", so their start values can be set before initialization. A feedthrough output
is recomputed (`evaluate`) when it is read after an input changed or after a step.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any, ClassVar

from pythonfmu import (
    Boolean,
    Fmi2Causality,
    Fmi2Initial,
    Fmi2Slave,
    Fmi2Variability,
    Integer,
    Real,
    String,
)

from twmr.core.component import Component
from twmr.registry import lookup

_CAUSALITY = {"input": Fmi2Causality.input, "output": Fmi2Causality.output,
              "state": Fmi2Causality.output, "parameter": Fmi2Causality.parameter}
_CLASS = {"Real": Real, "Integer": Integer, "Boolean": Boolean, "String": String}


def element_names(comp: Component) -> list[tuple[str, str, int | None]]:
    """(FMI name, variable, element index or None) for every exported element, in order.
    Optional inputs are not exported: an FMU importer must wire or open every input, so the
    exported block keeps them at their start values (what an unwired optional input means)."""
    out: list[tuple[str, str, int | None]] = []
    for var in comp.variables.values():
        if getattr(var, "optional", False):
            continue
        value = comp.__dict__[var.name]
        if var.size is None:
            out.append((var.name, var.name, None))
        else:
            out += [(f"{var.name}[{i + 1}]", var.name, i) for i in range(len(value))]
    return out


class TwmrSlave(Fmi2Slave):
    """Base of exported FMUs: a component of class `COMPONENT` (or of the registered kind `KIND`)
    with `PARAMETERS` applied."""

    KIND = ""
    COMPONENT: type[Component] | None = None
    PARAMETERS: ClassVar[dict[str, Any]] = {}

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        cls = self.COMPONENT or lookup(self.KIND)
        self.description = (cls.__doc__ or "").strip().splitlines()[0] if cls.__doc__ else ""
        self.comp = cls(self.instance_name)
        for key, value in self.PARAMETERS.items():
            self.comp.set_parameter(key, value)
        self._t = 0.0
        self._stop: float | None = None
        self._dirty = True
        self._ready = False
        for fmi_name, var_name, index in element_names(self.comp):
            var = self.comp.variables[var_name]
            variability = (Fmi2Variability.fixed if var.kind == "parameter" else
                           Fmi2Variability.continuous if var.type == "Real" else
                           Fmi2Variability.discrete)
            self.register_variable(_CLASS[var.type](
                fmi_name, causality=_CAUSALITY[var.kind], variability=variability,
                description=var.description or None,
                initial=Fmi2Initial.exact if var.kind == "state" else None,
                getter=self._getter(var_name, index), setter=self._setter(var_name, index)),
                nested=False)

    def _getter(self, name: str, index: int | None) -> Callable[[], Any]:
        d = self.comp.__dict__
        is_output = self.comp.variables[name].kind in ("output", "state")

        def get() -> Any:
            if is_output and self._dirty and self._ready and self.comp.has_feedthrough:
                self.comp.evaluate(self._t)
                self._dirty = False
            value = d[name]
            return value if index is None else value[index]
        return get

    def _setter(self, name: str, index: int | None) -> Callable[[Any], None]:
        d = self.comp.__dict__

        def set_(value: Any) -> None:
            if index is None:
                d[name] = value
            else:
                v = list(d[name])
                v[index] = value
                d[name] = tuple(v)
            self._dirty = True
        return set_

    def setup_experiment(self, start_time: float, stop_time: float | None,
                         tolerance: float | None) -> None:
        self._t, self._stop, self._start = start_time, stop_time, start_time
        self._k, self._h = 0, 0.0

    def exit_initialization_mode(self) -> None:
        self.comp.setup(self._t, self._stop)
        self.comp.initialize()
        self._ready = True
        self._dirty = True

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self._dirty and self.comp.has_feedthrough:
            self.comp.evaluate(current_time)
        self.comp.do_step(current_time, step_size)
        # time as start + k h while the step is constant, as the master keeps it (no drift)
        self._k = self._k + 1 if step_size == self._h else 1
        if step_size != self._h:
            self._start, self._h = current_time, step_size
        self._t = self._start + self._k * step_size
        self._dirty = True
        return True

    def terminate(self) -> None:
        self.comp.terminate()
