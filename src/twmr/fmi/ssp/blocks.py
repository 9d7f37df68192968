"""The FMU of each block of a system, for an SSP archive: a native block as its standalone C FMU
(its parameters, initial states and input start values as the FMU's start values), an FMU block
copied as it is, a block without a C twin through the Python route (`python=True`). What cannot
be exported is refused in one paragraph naming every such block."""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import CosimError
from twmr.scenario.structure import ScenarioSpec
from twmr.scenario.system import System

#: FMI type -> SSP connector / parameter type
TYPES = {"Real": "Real", "Float64": "Real", "Float32": "Real", "Integer": "Integer",
         "Enumeration": "Integer", "Boolean": "Boolean", "String": "String",
         **{f"{s}Int{n}": "Integer" for s in ("", "U") for n in (8, 16, 32, 64)}}
KINDS = ("input", "output", "parameter")


@dataclass(frozen=True)
class Connector:
    """One variable of a block's FMU as the SSD shows it: its name, kind (input | output |
    parameter), SSP type (Real | Integer | Boolean | String) and unit ('' for none)."""

    name: str
    kind: str
    type: str
    unit: str = ""


@dataclass
class BlockFmu:
    """A block's FMU file, how it was made, its connectors, the FMU variable of each port
    element ((port, 0-based index or None) -> name) and the values bound in its .ssv
    (variable -> (SSP type, value))."""

    name: str
    path: Path
    how: str
    connectors: list[Connector]
    elements: dict[tuple[str, int | None], str]
    values: dict[str, tuple[str, Any]] = field(default_factory=dict)
    #: the FMU's own UnitDefinitions: unit -> BaseUnit attributes (SI exponents, factor, offset)
    units: dict[str, dict[str, str]] = field(default_factory=dict)

    def variable(self, port: str, index: int | None) -> str:
        """The FMU variable of element `index` of `port` (CosimError when the FMU lacks it)."""
        key = (port, index)
        if key not in self.elements:
            what = port if index is None else f"{port}[{index + 1}]"
            raise CosimError(f"export: the FMU of '{self.name}' ({self.how}) has no variable "
                             f"for '{self.name}.{what}'. Fix: leave the port unwired, or export "
                             f"the block another way (a C twin, or an FMU of your own).")
        return self.elements[key]


def block_fmus(system: System, spec: ScenarioSpec, folder: Path, fmi: int = 2,
               python: bool = False) -> dict[str, BlockFmu]:
    """The FMU of every block of `system` (built from `spec`), written into `folder` as
    <name>.fmu. CosimError naming every block that cannot be exported, with the fix."""
    out: dict[str, BlockFmu] = {}
    refused: list[str] = []
    fixes: dict[str, None] = {}
    for name, comp in system.components.items():
        kind = str(spec.components[name].kind.value)
        try:
            out[name] = _block_fmu(name, kind, comp, folder / f"{name}.fmu", fmi, python)
        except CosimError as err:
            refused.append(f"'{name}' (kind {kind}): {_reason(err)}")
            fixes[_HARDWARE_FIX if comp.needs_realtime else _FIX] = None
    if refused:
        many = len(refused) > 1
        raise CosimError(f"{spec.source}: cannot export {'these blocks' if many else 'the block'}"
                         f" to SSP: {'; '.join(refused)}. Fix: {' '.join(fixes)}")
    return out


_FIX = ("swap it for a block with a C twin (`twmr components` lists the kinds; docs/export.md) "
        "or an FMU (kind: fmu), or add --python to export a block without a C twin through "
        "pythonfmu (FMI 2.0; the FMU needs twmr-cosim where it runs).")
_HARDWARE_FIX = ("export the simulated twin of a hardware block (kind motor_driver for a "
                 "can_drive).")


def _reason(err: CosimError) -> str:
    """The part of an export error that says what is wrong (its own 'Fix:' left out)."""
    text = str(err).split(" Fix:")[0].rstrip(". ")
    return text.removeprefix("export ")


def _block_fmu(name: str, kind: str, comp: Component, path: Path, fmi: int,
               python: bool) -> BlockFmu:
    from twmr.fmi.cexport import twins, write_c_fmu
    from twmr.fmi.fmu import FmuComponent

    if comp.needs_realtime:
        raise CosimError("it drives hardware in real time, which an FMU cannot carry")
    if isinstance(comp, FmuComponent):
        shutil.copyfile(comp.path, path)
        md = _description(path)
        names = {v.valueReference: v.name for v in md.modelVariables}
        elements = {(p.name, None if p.scalar else i): names[vr]
                    for p in comp.ports for i, vr in enumerate(p.vrs)}
        return BlockFmu(name, path, f"FMU {comp.source_path.name} copied",
                        _connectors(md), elements, _given(comp, elements, md), _units(md))
    reason = "it has no C twin"
    if kind in twins():
        try:
            write_c_fmu(comp, kind, path, fmi)
            md = _description(path)
            return BlockFmu(name, path, f"C FMU, FMI {fmi}.0", _connectors(md),
                            _by_convention(comp, md), _starts(md))
        except CosimError as err:
            if not python:
                raise
            reason = _reason(err)
    if not python:
        raise CosimError(reason)
    if fmi != 2:
        raise CosimError(f"{reason}, and the Python route makes FMI 2.0 FMUs only (drop --fmi "
                         f"3 to export it with --python)")
    from twmr.fmi.export import export_component

    values = {n: _plain(comp.get(n)) for n, v in comp.variables.items()
              if v.kind in ("parameter", "state") and n not in comp.construction_parameters}
    export_component(kind if ":" not in kind else type(comp), path, values)
    md = _description(path)
    return BlockFmu(name, path, "Python route (pythonfmu, FMI 2.0)", _connectors(md),
                    _by_convention(comp, md), _starts(md))


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def _description(path: Path) -> Any:
    from fmpy import read_model_description

    return read_model_description(str(path), validate=False)  # read before, by its block


def _unit(v: Any) -> str:
    unit = getattr(v, "unit", None) or getattr(getattr(v, "declaredType", None), "unit", None)
    return "" if unit in (None, "1") else str(unit)


def _units(md: Any) -> dict[str, dict[str, str]]:
    """The BaseUnit attributes of each unit the FMU defines."""
    out = {}
    for u in md.unitDefinitions:
        base = u.baseUnit
        if base is None:
            continue
        attrs = {k: str(getattr(base, k)) for k in ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
                 if getattr(base, k, 0)}
        for k, neutral in (("factor", 1.0), ("offset", 0.0)):
            if float(getattr(base, k, neutral)) != neutral:
                attrs[k] = repr(float(getattr(base, k)))
        out[u.name] = attrs
    return out


def _connectors(md: Any) -> list[Connector]:
    return [Connector(v.name, v.causality, TYPES[v.type], _unit(v))
            for v in md.modelVariables if v.causality in KINDS and v.type in TYPES]


def _by_convention(comp: Component, md: Any) -> dict[tuple[str, int | None], str]:
    """Port elements -> FMU variables of our own exports: `port` for a scalar, `port[i]`
    (1-based) for a vector, each where the FMU has it."""
    have = {v.name for v in md.modelVariables}
    out: dict[tuple[str, int | None], str] = {}
    for var in comp.variables.values():
        if var.kind == "parameter":
            continue
        keys = [(None, var.name)] if var.size is None else \
            [(i, f"{var.name}[{i + 1}]") for i in range(len(comp.get(var.name)))]
        out.update({(var.name, i): n for i, n in keys if n in have})
    return out


def _value(v: Any) -> tuple[str, Any]:
    kind = TYPES[v.type]
    text = str(v.start)
    if kind == "Real":
        return kind, float(text)
    if kind == "Integer":
        return kind, int(text)
    if kind == "Boolean":
        return kind, text.lower() in ("true", "1")
    return kind, text


def _starts(md: Any) -> dict[str, tuple[str, Any]]:
    """The start values of our own export's parameters and of its states (outputs whose start
    an importer sets: initial="exact")."""
    return {v.name: _value(v) for v in md.modelVariables
            if v.type in TYPES and v.start is not None and (
                v.causality == "parameter" or (v.causality == "output" and
                                               v.initial == "exact"))}


def _given(comp: Any, elements: dict[tuple[str, int | None], str], md: Any
           ) -> dict[str, tuple[str, Any]]:
    """The values a scenario gave an FMU block (its parameters and start values), by FMU
    variable."""
    types = {v.name: TYPES.get(v.type, "String") for v in md.modelVariables}
    out: dict[str, tuple[str, Any]] = {}
    for port in getattr(comp, "_given", ()):
        value = comp.get(port)
        items = [(None, value)] if not isinstance(value, (tuple, list)) else list(enumerate(value))
        for i, x in items:
            name = elements.get((port, i)) or (port if i is None else f"{port}[{i + 1}]")
            if name in types:
                out[name] = (types[name], x)
    return out
