"""The structure an SSP was read into -> the flat components and wires of a `ScenarioSpec`.

Each FMU's ports come from its model description. A connection is followed through the
connectors of the systems between its two FMU ends; its transformation, and a unit conversion
the builder cannot see (a unit declared only on an SSP connector), become an `SspMap` component on
the wire (`<destination>_<input>_ssp`); a plain wire stays a wire, and the builder converts the
FMUs' own units as for any scenario. Bound values are checked against the FMU variables' types
and converted to their units."""
from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError, Location, Problem, ScenarioError, UnitError
from twmr.core.units import Unit, conversion, known_unit
from twmr.fmi.ssp.common import Transformation
from twmr.fmi.ssp.params import Value
from twmr.scenario.structure import ComponentSpec, Given

log = logging.getLogger("twmr")

MAP_KIND = "twmr.fmi.ssp.transform:SspMap"
_CONNECTOR = re.compile(r"^([A-Za-z_][\w.]*?)(?:\[(\d+)\])?$")
_BRACKETED = re.compile(r"^\[([^\[\]]+)\]$")
_TYPES = {"Real": "Real", "Integer": "Integer", "Boolean": "Boolean", "String": "String",
          "Enumeration": "Integer", "Binary": "Binary"}

Path_ = tuple[str, ...]
EndKey = tuple[Path_, str]  # (element path, connector name)


@dataclass
class Fmu:
    """One FMU component while the structure is read."""

    name: str
    where: Location
    path: Path
    interface: str
    connectors: dict[str, tuple[str, str, Location]]  # name -> (kind, unit, where)
    enum_types: dict[str, str]  # connector -> its ssc:Enumeration name
    md: Any = None
    variables: dict[str, Any] = field(default_factory=dict)
    values: dict[str, Given[Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class Edge:
    start: EndKey
    transform: Transformation | None
    suppress: bool
    where: Location


class Flattener:
    """The FMUs and wires of the structure `_Reader` collected (`twmr.fmi.ssp.read`)."""

    def __init__(self, fmus: dict[Path_, Fmu], edges: dict[EndKey, list[Edge]],
                 system_values: dict[EndKey, Value], units: dict[str, Unit],
                 enums: dict[str, dict[str, int]]):
        self.fmus, self.edges, self.system_values = fmus, edges, system_values
        self.units, self.enums = units, enums
        self.problems: list[Problem] = []

    def flatten(self) -> tuple[dict[str, ComponentSpec], list[Given[str]], list[Given[str]]]:
        """(components, wires, inputs left open); ScenarioError listing every problem."""
        self.read_fmus()
        if not self.problems:
            found = self.wires()
            if not self.problems:
                return found
        raise ScenarioError(self.problems)

    # -- the FMUs ------------------------------------------------------------------------------
    def read_fmus(self) -> None:
        from twmr.fmi.description import ports_of, read_description

        for fmu in self.fmus.values():
            try:
                fmu.md = read_description(fmu.path, fmu.name)
                fmu.variables = ports_of(fmu.md)[1]
            except (CosimError, ValueError) as err:
                self.problems.append(Problem(fmu.where, f"component '{fmu.name}': {err}"))
                continue
            for name, (kind, _, where) in fmu.connectors.items():
                if self.variable(fmu, name)[0] is None:
                    log.warning("warning: %s: the FMU of '%s' (%s) has no %s '%s' (or not one "
                                "twmr can set or read); the connector is ignored unless a "
                                "connection uses it.", where, fmu.name, fmu.path.name,
                                kind or "variable", name)

    def typed(self, fmu: Fmu, name: str, given: Given[Any]) -> tuple[str, Any] | None:
        """(port, value) of a bound value, converted to the FMU variable's unit; None after
        adding the problem."""
        value, defined, entry = given.value
        var, index = self.variable(fmu, name)
        if var is None:
            log.warning("warning: %s: the FMU of '%s' has no parameter or start value '%s'; "
                        "the value is ignored (as the SSP standard says).", value.where,
                        fmu.name, name)
            return None
        if var.kind not in ("parameter", "input", "state"):
            self.problems.append(Problem(value.where, f"'{fmu.name}.{name}' is an output of "
                                         f"its FMU, which cannot be set.", "bind parameters, "
                                         "inputs and states only."))
            return None
        want = var.type
        got = _TYPES[value.type]
        if got != want and not (want == "Real" and got == "Integer"):
            self.problems.append(Problem(value.where, f"the value of '{name}' is written as "
                                         f"ssv:{value.type} ({value.value!r}) but "
                                         f"'{fmu.name}.{name}' is {want} in its FMU.",
                                         f"write it as ssv:{'Real' if want == 'Real' else want}."))
            return None
        v = value.value
        if value.type == "Enumeration":
            items = self.items(fmu, name)
            if v not in items:
                self.problems.append(Problem(value.where, f"'{v}' is not an item of the "
                                             f"enumeration of '{fmu.name}.{name}'",
                                             f"use one of: {', '.join(items) or '(none known)'}."))
                return None
            v = items[v]
        if want == "Real":
            unit = var.element_unit(index or 0)
            suppress = entry.suppress_units if entry else False
            if value.unit and unit and value.unit != unit and not suppress:
                try:
                    g, o = _convert(value.unit, unit, {**defined, **var.unit_definitions})
                except UnitError as err:
                    self.problems.append(Problem(value.where, f"the value of '{name}': {err}.",
                                                 f"give it in '{unit}' or a unit convertible "
                                                 f"to it."))
                    return None
                v = g * float(v) + o
            if entry and entry.transform and entry.transform.kind == "linear":
                v = entry.transform.factor * float(v) + entry.transform.offset
        elif entry and entry.transform and entry.transform.table:
            v = dict(entry.transform.table).get(v, v)
        return name if index is None else f"{name.partition('[')[0]}[{index + 1}]", v

    def variable(self, fmu: Fmu, name: str) -> tuple[Any, int | None]:
        """The FMU port a name means and the element (None: the whole port)."""
        if name in fmu.variables:
            return fmu.variables[name], None
        m = _CONNECTOR.match(name)
        if m and m.group(2) and m.group(1) in fmu.variables:
            var = fmu.variables[m.group(1)]
            i = int(m.group(2)) - 1
            if var.size and 0 <= i < var.width:
                return var, i
        return None, None

    def items(self, fmu: Fmu, connector: str) -> dict[str, int]:
        """An enumeration connector's items: the SSD's ssc:Enumeration, else the FMU's type."""
        name = fmu.enum_types.get(connector, "")
        if name in self.enums:
            return self.enums[name]
        base = _CONNECTOR.match(connector)
        for v in fmu.md.modelVariables:
            if v.name in (connector, base.group(1) if base else "") and v.declaredType:
                return {i.name: int(i.value) for i in getattr(v.declaredType, "items", [])}
        return {}

    # -- the flat structure --------------------------------------------------------------------
    def wires(self) -> tuple[dict[str, ComponentSpec], list[Given[str]],
                                          list[Given[str]]]:
        comps: dict[str, ComponentSpec] = {}
        for fmu in self.fmus.values():
            params: dict[str, Given[Any]] = {"path": Given(str(fmu.path), fmu.where)}
            if fmu.interface != "auto":
                params["interface"] = Given(fmu.interface, fmu.where)
            initial: dict[str, Given[Any]] = {}
            for name, given in fmu.values.items():
                done = self.typed(fmu, name, given)
                if done is not None:
                    self.put(fmu, *done, given.where, params, initial)
            comps[fmu.name] = ComponentSpec(fmu.name, Given("fmu", fmu.where), params, initial,
                                            Given(1, fmu.where), fmu.where)
        conns: list[Given[str]] = []
        opened: list[Given[str]] = []
        for end, edges in self.edges.items():
            if end[0] not in self.fmus:
                continue
            for edge in edges:
                self.wire(end, edge, comps, conns, opened)
        driven = {g.value.split("->")[1].strip().split("[")[0] for g in conns}
        for fmu in self.fmus.values():  # an unconnected input keeps its start value (SSP)
            for port, var in fmu.variables.items():
                text = f"{fmu.name}.{port}"
                if var.kind == "input" and text not in driven and \
                        text not in {g.value for g in opened}:
                    opened.append(Given(text, fmu.where))
        return comps, conns, opened

    def put(self, fmu: Fmu, port: str, value: Any, where: Location,
            params: dict[str, Given[Any]], initial: dict[str, Given[Any]]) -> None:
        """Set a bound value: a parameter, or an input's or state's start value (an element
        of a vector port merged into the port's list)."""
        base, _, index = port.partition("[")
        var = fmu.variables[base]
        section = params if var.kind == "parameter" else initial
        if index:
            old = section.get(base)
            values = list(old.value if old else var.start)
            values[int(index[:-1]) - 1] = value
            value = values
        section[base] = Given(value, where)

    def wire(self, end: EndKey, edge: Edge, comps: dict[str, ComponentSpec],
             conns: list[Given[str]], opened: list[Given[str]]) -> None:
        """The wire (and any transformation component) that drives FMU connector `end`."""
        chain = [edge]
        start = edge.start
        seen = {end}
        while start[0] not in self.fmus:
            if start in seen:
                self.refuse(edge.where, "the connections form a cycle through system "
                            "connectors", "remove the cycle.")
                return
            seen.add(start)
            drivers = self.edges.get(start, [])
            if not drivers:
                self.undriven(end, start, chain, comps, opened)
                return
            if len(drivers) > 1:
                self.refuse(drivers[1].where, f"the system connector "
                            f"'{'.'.join((*start[0], start[1]))}' is driven twice",
                            "keep one connection into each connector.")
                return
            chain.insert(0, drivers[0])
            start = drivers[0].start
        src, dst = self.fmus[start[0]], self.fmus[end[0]]
        where = chain[-1].where
        stext, dtext = self.port_text(src, start[1], where), self.port_text(dst, end[1], where)
        if stext is None or dtext is None:
            return
        texts = [stext, dtext]
        svar, sidx = self.variable(src, start[1])
        dvar, didx = self.variable(dst, end[1])
        if dvar.kind == "parameter":
            self.refuse(where, f"the connection drives the parameter '{dst.name}.{end[1]}' "
                        f"from an output", "twmr sets parameters from parameter bindings "
                        "(.ssv) only; connect an input.")
            return
        transforms = [e.transform for e in chain if e.transform is not None]
        suppress = any(e.suppress for e in chain)
        su = src.connectors.get(start[1], ("", "", where))[1]
        du = dst.connectors.get(end[1], ("", "", where))[1]
        fsu = svar.element_unit(sidx or 0) if svar.type == "Real" else ""
        fdu = dvar.element_unit(didx or 0) if dvar.type == "Real" else ""
        for fmu, conn, unit, fmu_unit in ((src, start[1], su, fsu), (dst, end[1], du, fdu)):
            if unit and fmu_unit and unit != fmu_unit:
                log.warning("warning: %s: the connector '%s.%s' declares the unit '%s' but its "
                            "FMU's variable is in '%s'; the FMU's unit is used.",
                            fmu.connectors[conn][2], fmu.name, conn, unit, fmu_unit)
        eff_s, eff_d = fsu or su, fdu or du
        gain, offset = 1.0, 0.0
        if eff_s and eff_d and eff_s != eff_d and not suppress:
            try:
                gain, offset = _convert(eff_s, eff_d, {**self.units, **svar.unit_definitions,
                                                       **dvar.unit_definitions})
            except UnitError as err:
                self.problems.append(Problem(where, f"unit mismatch on '{texts[0]} -> "
                                             f"{texts[1]}': {err}.", "connect connectors that "
                                             "measure the same quantity, or correct a unit."))
                return
        needs_map = transforms or (suppress and eff_s != eff_d) or \
            (eff_s != eff_d and not (fsu and fdu) and (gain, offset) != (1.0, 0.0))
        if not needs_map:
            conns.append(Given(f"{texts[0]} -> {texts[1]}", where))
            return
        kinds = {svar.type, dvar.type}
        if kinds - {"Real", "Integer", "Boolean"} or \
                ("Boolean" in kinds and any(t.kind == "linear" for t in transforms)):
            self.refuse(where, f"a transformation between {svar.type} and {dvar.type} "
                        f"connectors", "transform Real and Integer values linearly, and map "
                        "Boolean, Integer and enumeration values.")
            return
        if len(transforms) > 1 and any(t.kind != "linear" for t in transforms):
            self.refuse(where, "a mapping transformation is combined with another "
                        "transformation on the way through the systems' connectors",
                        "keep one mapping transformation per path.")
            return
        table: tuple[tuple[Any, Any], ...] = ()
        for t in transforms:
            if t.kind == "linear":
                gain, offset = t.factor * gain, t.factor * offset + t.offset
            elif t.kind == "enumeration":
                table = self.enum_table(t, src, start[1], dst, end[1])
            else:
                table = t.table
        name = f"{dst.name}_{texts[1].rsplit('.', 1)[1].replace('[', '_').rstrip(']')}_ssp"
        while name in comps:
            name += "_"
        construction = {"in_type": svar.type, "out_type": dvar.type,
                        "in_unit": "" if suppress else fsu, "out_unit": "" if suppress else fdu,
                        "factor": gain, "offset": offset, "table": [list(p) for p in table]}
        comps[name] = ComponentSpec(name, Given(MAP_KIND, where),
                                    {k: Given(v, where) for k, v in construction.items()}, {},
                                    Given(1, where), where)
        conns += [Given(f"{texts[0]} -> {name}.u", where), Given(f"{name}.y -> {texts[1]}", where)]

    def enum_table(self, t: Transformation, src: Fmu, sconn: str, dst: Fmu,
                   dconn: str) -> tuple[tuple[int, int], ...]:
        a, b = self.items(src, sconn), self.items(dst, dconn)
        rows = []
        for s, d in t.table:
            if s not in a or d not in b:
                missing = s if s not in a else d
                self.refuse(t.where, f"the enumeration item '{missing}' is not defined for "
                            f"the connectors it maps", "define the enumeration under "
                            "ssd:Enumerations (or use the FMU's item names).")
                return ()
            rows.append((a[s], b[d]))
        return tuple(rows)

    def undriven(self, end: EndKey, start: EndKey, chain: list[Edge],
                 comps: dict[str, ComponentSpec], opened: list[Given[str]]) -> None:
        """An FMU connector wired to a system connector that nothing drives: a system
        parameter's bound value, or an input of the whole system left open."""
        fmu = self.fmus[end[0]]
        value = self.system_values.get(start)
        var, _ = self.variable(fmu, end[1])
        if var is not None and var.kind == "parameter":
            if value is not None:
                linear = [e.transform for e in chain if e.transform and
                          e.transform.kind == "linear"]
                spec = comps[fmu.name]
                done = self.typed(fmu, end[1], Given((value, self.units, None), value.where))
                if done is not None:
                    port, v = done
                    for t in linear:
                        v = t.factor * v + t.offset
                    self.put(fmu, port, v, value.where, spec.parameters, spec.initial)
            return
        text = self.port_text(fmu, end[1], chain[-1].where)
        if text is not None and var is not None and var.kind == "input":
            opened.append(Given(text.split("[")[0], chain[-1].where))

    def port_text(self, fmu: Fmu, connector: str, where: Location) -> str | None:
        """'comp.port' or 'comp.port[i]' for an FMU connector; None after adding the problem."""
        m = _CONNECTOR.match(connector or "")
        var, _ = self.variable(fmu, connector)
        if var is None:
            known = [n for n, v in fmu.variables.items() if v.kind != "parameter"]
            self.refuse(where, f"the FMU of component '{fmu.name}' ({fmu.path.name}) has no "
                        f"connector '{connector}'", f"use one of: {', '.join(known)}.")
            return None
        if not m:
            self.refuse(where, f"the connector '{connector}' of '{fmu.name}' is not a name a "
                        f"twmr wire can give (an identifier, with one [i] for an element)",
                        "rename the FMU variable, or wrap the FMU.")
            return None
        return f"{fmu.name}.{connector}"

    def refuse(self, where: Location, what: str, fix: str) -> None:
        self.problems.append(Problem(where, f"{what}.", fix))


def _convert(src: str, dst: str, defined: dict[str, Unit]) -> tuple[float, float]:
    """(gain, offset) from unit `src` to `dst`, units defined by the SSP or FMU or Modelica's
    (a unit written in brackets, '[m]', as tools print them, is the unit inside); UnitError when
    either is unknown or they measure different quantities."""
    src, dst = _BRACKETED.sub(r"\1", src), _BRACKETED.sub(r"\1", dst)
    a, b = known_unit(src, defined), known_unit(dst, defined)
    if a is None or b is None:
        raise UnitError(f"the unit '{src if a is None else dst}' is neither defined "
                        f"(ssc:Unit with a BaseUnit) nor a Modelica unit")
    return conversion(a, b)
