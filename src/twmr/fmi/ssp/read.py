"""An SSP system structure (.ssd in an .ssp archive or a folder) -> the flat `ScenarioSpec`.

Every FMU component of the system and of its nested systems becomes one component of kind `fmu`
named by its path (`sub.comp`); a component whose source is another .ssd is read as a nested
system. A connection is followed through the connectors of the systems between its two FMU ends;
its transformation, and a unit conversion the builder cannot see (a unit declared only on an
SSP connector), become an `SspMap` component on the wire (`<destination>_<input>_ssp`); a plain
wire stays a wire, and the builder converts the FMUs' own units as for any scenario. Parameter
bindings (.ssv files or inline, with .ssm mappings and prefixes) set the FMUs' parameters and
start values, a system level over the levels below it as the standard says. The
`DefaultExperiment` gives start and stop; the step comes from an annotation's `stepSize` (as
OMSimulator writes it) or `step`, else 1 ms when it divides the run, else 1/1000 of the run.

What SSP allows and twmr does not run is refused naming the element and line: components that are
not FMUs (or nested .ssp packages), signal dictionaries, connections into parameters from outputs,
Binary parameters, connector names that are not identifiers (optionally with one `[i]`)."""
from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError, Location, Problem, ScenarioError, UnitError
from twmr.core.units import Unit, conversion, known_unit
from twmr.fmi.ssp.archive import unpacked
from twmr.fmi.ssp.common import Transformation, enumerations, transformation, units
from twmr.fmi.ssp.params import Entry, Value, parameter_mapping, parameter_set
from twmr.fmi.ssp.schema import validate
from twmr.fmi.ssp.xmlsafe import MAX_XML_BYTES, NS, at, parse_xml, tag
from twmr.scenario.structure import (
    ComponentSpec,
    ExperimentSpec,
    Given,
    RecordingSpec,
    ScenarioSpec,
)

log = logging.getLogger("twmr")

FMU_TYPE = "application/x-fmu-sharedlibrary"
SSD_TYPE = "application/x-ssp-definition"
MAP_KIND = "twmr.fmi.ssp.transform:SspMap"
#: the step when no annotation gives one [s] (used when it divides the run)
DEFAULT_STEP = 1e-3
_NAME = re.compile(r"^[A-Za-z_]\w*$")
_CONNECTOR = re.compile(r"^([A-Za-z_]\w*)(?:\[(\d+)\])?$")
_TYPES = {"Real": "Real", "Integer": "Integer", "Boolean": "Boolean", "String": "String",
          "Enumeration": "Integer", "Binary": "Binary"}

Path_ = tuple[str, ...]
EndKey = tuple[Path_, str]  # (element path, connector name)


def load_ssp(path: str | Path) -> ScenarioSpec:
    """The flat structure of an SSP: an `.ssp` archive, a folder holding SystemStructure.ssd,
    an `.ssd` file, or `X.ssp#variant.ssd` (another .ssd of the archive)."""
    path = Path(path)
    text = str(path)
    if "#" in text and not path.exists():
        archive, _, member = text.partition("#")
        folder, beside = unpacked(Path(archive)), Path(archive).parent
        return _Reader(archive, folder, beside).read(folder / member)
    if path.is_dir():
        return _Reader(text, path, path.parent).read(path / "SystemStructure.ssd", text)
    if path.suffix.lower() == ".ssd":
        return _Reader(str(path.parent), path.parent, path.parent).read(path, text)
    if not path.is_file():
        raise ScenarioError(Problem(Location(text), "no such SSP file or folder.",
                                    "give an .ssp archive, an unpacked folder holding "
                                    "SystemStructure.ssd, or an .ssd file."))
    folder = unpacked(path)
    return _Reader(text, folder, path.parent).read(folder / "SystemStructure.ssd", text)


@dataclass
class _Fmu:
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
class _Edge:
    start: EndKey
    transform: Transformation | None
    suppress: bool
    where: Location


class _Reader:
    def __init__(self, label: str, root: Path, beside: Path):
        self.label, self.root, self.beside = label, root, beside
        self.problems: list[Problem] = []
        self.fmus: dict[Path_, _Fmu] = {}
        self.systems: dict[Path_, dict[str, tuple[str, str, Location]]] = {}
        self.edges: dict[EndKey, list[_Edge]] = {}
        self.system_values: dict[EndKey, Value] = {}
        self.units: dict[str, Unit] = {}
        self.enums: dict[str, dict[str, int]] = {}
        self.reading: list[Path] = []
        self.refused: set[Path_] = set()  # elements refused (their connections are not checked)

    def fail_if_problems(self) -> None:
        if self.problems:
            raise ScenarioError(self.problems)

    def name(self, file: Path) -> str:
        """How a file of the package is named in messages: the package, then the member."""
        try:
            rel = file.resolve().relative_to(self.root.resolve()).as_posix()
        except ValueError:
            return str(file)
        return f"{self.label}/{rel}"

    def xml(self, file: Path, where: Location | None = None) -> tuple[Any, str]:
        """The validated root element of a file of the package, and its name for messages."""
        source = self.name(file)
        if not file.resolve().is_relative_to(self.root.resolve()):
            raise ScenarioError(Problem(where or Location(source), f"'{source}' lies outside "
                                        f"the package.", "reference files inside the package "
                                        "by paths relative to its root."))
        if not file.is_file():
            raise ScenarioError(Problem(where or Location(source), f"'{source}' is not in the "
                                        f"package.", "add the file, or correct the reference "
                                        "to it (paths are relative to the package's root)."))
        if file.stat().st_size > MAX_XML_BYTES:
            raise ScenarioError(Problem(where or Location(source), f"'{source}' is "
                                        f"{file.stat().st_size:,} bytes, more than the "
                                        f"{MAX_XML_BYTES:,} an SSP XML file may have.",
                                        "check that the reference names the right file."))
        root = parse_xml(file.read_bytes(), source)
        validate(root, source)
        return root, source

    # -- the file and its systems --------------------------------------------------------------
    def read(self, ssd: Path, label: str | None = None) -> ScenarioSpec:
        if label is not None and not ssd.is_file():
            raise ScenarioError(Problem(Location(label), "the SSP holds no SystemStructure.ssd.",
                                        "an SSP package (or its folder) holds the system in "
                                        "SystemStructure.ssd at its root."))
        root, source = self.xml(ssd)
        if tag(root) != "ssd:SystemStructureDescription":
            raise ScenarioError(Problem(at(source, root), f"the root element is {tag(root)}, "
                                        f"not ssd:SystemStructureDescription.",
                                        "give the system structure (.ssd) file."))
        self.reading.append(ssd.resolve())
        self.description(root, source, (), ssd.parent)
        self.fail_if_problems()
        self.read_fmus()
        self.fail_if_problems()
        comps, conns, opened = self.wires(source)
        self.fail_if_problems()
        experiment = self.experiment(root, source)
        self.fail_if_problems()
        top = at(source, root)
        return ScenarioSpec(source=source, base_dir=self.root, components=comps,
                            connections=tuple(conns), open=tuple(opened), experiment=experiment,
                            record=RecordingSpec(None, Given(1, top), top),
                            description=root.get("description") or root.get("name") or "",
                            sections={"components": top, "connections": top})

    def description(self, root: Any, source: str, path: Path_, base: Path) -> None:
        """Read one .ssd: its units, enumerations and its system at `path`."""
        self.units.update(units(root))
        self.enums.update(enumerations(root))
        for dictionaries in root.iterfind("ssd:System/ssd:SignalDictionaries", NS):
            self.refuse(at(source, dictionaries), "signal dictionaries (ssb:) are not supported",
                        "connect the components directly.")
        system = root.find("ssd:System", NS)
        if system is not None:
            self.system(system, source, path, base)
            self.bindings(system, source, path, base)

    def system(self, elem: Any, source: str, path: Path_, base: Path) -> None:
        self.systems[path] = self.connectors(elem, source)[0]
        for child in elem.iterfind("ssd:Elements/*", NS):
            name = child.get("name") or ""
            where = at(source, child, f"{tag(child)} {name}")
            if not _NAME.match(name):
                self.refuse(where, f"the element name '{name}' is not a name twmr can use",
                            "rename it with letters, digits and '_' only (not starting with a "
                            "digit).")
                continue
            sub = (*path, name)
            if sub in self.fmus or sub in self.systems:
                self.refuse(where, f"a second element named '{name}'", "give each a name of "
                            "its own.")
                continue
            kind = tag(child)
            self.refused.add(sub)
            if kind == "ssd:System":
                self.refused.discard(sub)
                self.system(child, source, sub, base)
                self.bindings(child, source, sub, base)
            elif kind == "ssd:Component":
                self.component(child, source, sub, base, where)
                if sub in self.fmus or sub in self.systems:
                    self.refused.discard(sub)
            else:
                self.refuse(where, f"{kind} elements are not supported", "replace it by an FMU "
                            "component or a nested system.")
        for conn in elem.iterfind("ssd:Connections/ssd:Connection", NS):
            self.connection(conn, source, path)

    def component(self, elem: Any, source: str, path: Path_, base: Path,
                  where: Location) -> None:
        kind = elem.get("type") or FMU_TYPE
        src = elem.get("source") or ""
        if kind == SSD_TYPE or (not elem.get("type") and src.lower().endswith(".ssd")):
            file = (base / src).resolve()
            if file in self.reading:
                self.refuse(where, f"'{src}' includes itself", "remove the cycle of .ssd files.")
                return
            self.reading.append(file)
            root, inner = self.xml(file, where)
            self.description(root, inner, path, file.parent)
            self.reading.pop()
            self.bindings(elem, source, path, base)
            return
        if kind != FMU_TYPE:
            self.refuse(where, f"the component's type '{kind}' is not an FMU "
                        f"({FMU_TYPE}); twmr runs FMU components and nested .ssd systems only",
                        "export the component as an FMU (FMI 2.0 or 3.0).")
            return
        found = self.find(src, base, where)
        if found is None:
            return
        interface = {"ModelExchange": "model_exchange", "CoSimulation": "co_simulation"}.get(
            elem.get("implementation") or "any", "auto")
        if elem.get("implementation") == "ScheduledExecution":
            self.refuse(where, "implementation 'ScheduledExecution' is not supported",
                        "use CoSimulation, ModelExchange or any.")
        connectors, enum_types = self.connectors(elem, source)
        self.fmus[path] = _Fmu(".".join(path), where, found, interface, connectors, enum_types)
        self.bindings(elem, source, path, base)

    def find(self, src: str, base: Path, where: Location) -> Path | None:
        """An FMU named by a component's source: in the package, else beside the archive."""
        if not src or (re.match(r"^[A-Za-z][\w+.-]+:", src) and not src.startswith("file:")):
            self.refuse(where, f"the source '{src}' is not a relative path of the package",
                        "give the FMU's path inside the package, e.g. resources/model.fmu.")
            return None
        rel = src.removeprefix("file:")
        for folder in (base, self.beside):
            file = (folder / rel).resolve()
            inside = any(file.is_relative_to(f.resolve()) for f in (self.root, self.beside))
            if inside and file.is_file():
                return file
        self.problems.append(Problem(where, f"the FMU '{src}' is neither in the package nor "
                                     f"beside it ({self.beside}).", "add the FMU to the package "
                                     "(resources/) or put it beside the .ssp."))
        return None

    def connectors(self, elem: Any, source: str
                   ) -> tuple[dict[str, tuple[str, str, Location]], dict[str, str]]:
        found, enum_types = {}, {}
        for c in elem.iterfind("ssd:Connectors/ssd:Connector", NS):
            typed = next((t for t in c if isinstance(t.tag, str) and
                          t.tag.split("}")[0][1:] == NS["ssc"]), None)
            unit = typed.get("unit", "") if typed is not None else ""
            if typed is not None and typed.tag.endswith("}Enumeration"):
                enum_types[c.get("name")] = typed.get("name", "")
            found[c.get("name")] = (c.get("kind", ""), unit,
                                    at(source, c, f"ssd:Connector {c.get('name')}"))
        return found, enum_types

    def connection(self, elem: Any, source: str, path: Path_) -> None:
        ends = []
        for side in ("start", "end"):
            element, connector = elem.get(f"{side}Element"), elem.get(f"{side}Connector")
            ends.append(((*path, element) if element else path, connector))
        text = " -> ".join(".".join((*p[len(path):], c)) for p, c in ends)
        where = at(source, elem, f"ssd:Connection {text}")
        for end_path, connector in ends:
            if end_path in self.refused:
                return
            if end_path not in self.fmus and end_path not in self.systems:
                self.refuse(where, f"no element '{end_path[-1]}' in the system"
                            f" '{'.'.join(path) or '(top)'}'",
                            "connect elements of the system the connection is written in.")
                return
            declared = self.fmus[end_path].connectors if end_path in self.fmus \
                else self.systems[end_path]
            if end_path in self.systems and connector not in declared:
                self.refuse(where, f"the system '{'.'.join(end_path) or '(top)'}' has no "
                            f"connector '{connector}'", f"declare it under the system's "
                            f"ssd:Connectors, or use one of: {', '.join(declared) or '(none)'}.")
                return
        suppress = elem.get("suppressUnitConversion") in ("true", "1")
        edge = _Edge(ends[0], transformation(elem, source), suppress, where)
        self.edges.setdefault(ends[1], []).append(edge)

    # -- parameters ----------------------------------------------------------------------------
    def bindings(self, elem: Any, source: str, path: Path_, base: Path) -> None:
        """Apply the ParameterBindings of the element at `path` (after those of its elements:
        a higher level takes precedence)."""
        for b in elem.iterfind("ssd:ParameterBindings/ssd:ParameterBinding", NS):
            where = at(source, b, "ssd:ParameterBinding")
            src = b.get("source")
            if b.get("sourceBase") == "component":
                self.refuse(where, "sourceBase='component' (a parameter file inside the FMU) is "
                            "not supported", "put the .ssv in the package and drop sourceBase.")
                continue
            if src:
                root, set_source = self.xml(base / src.removeprefix("file:"), where)
            else:
                root = b.find("ssd:ParameterValues/ssv:ParameterSet", NS)
                set_source = source
                if root is None:
                    self.refuse(where, "the binding has neither a source nor an inline "
                                "ssv:ParameterSet", "give one of them.")
                    continue
            if tag(root) != "ssv:ParameterSet":
                self.refuse(where, f"'{src}' holds {tag(root)}, not ssv:ParameterSet",
                            "bind a parameter values (.ssv) file.")
                continue
            values, defined = parameter_set(root, set_source)
            mapping = self.mapping(b, source, base)
            for value in values:
                self.bind(path, b.get("prefix", "") + value.name, value, {**self.units,
                                                                          **defined}, mapping)

    def mapping(self, binding: Any, source: str, base: Path) -> dict[str, Entry]:
        m = binding.find("ssd:ParameterMapping", NS)
        if m is None:
            return {}
        if m.get("source"):
            root, msource = self.xml(base / m.get("source").removeprefix("file:"),
                                     at(source, m, "ssd:ParameterMapping"))
            return parameter_mapping(root, msource)
        inline = m.find("ssm:ParameterMapping", NS)
        return parameter_mapping(inline, source) if inline is not None else {}

    def bind(self, path: Path_, name: str, value: Value, defined: dict[str, Unit],
             mapping: dict[str, Entry]) -> None:
        entry = mapping.get(name)
        target = entry.target if entry else name
        if path in self.fmus:
            self.set_value(self.fmus[path], target, value, defined, entry)
            return
        if target in self.systems.get(path, {}):
            self.system_values[(path, target)] = value
            return
        parts = target.split(".")
        for i in range(len(parts) - 1, 0, -1):
            sub = (*path, *parts[:i])
            rest = ".".join(parts[i:])
            if sub in self.fmus:
                self.set_value(self.fmus[sub], rest, value, defined, entry)
                return
            if sub in self.systems and rest in self.systems[sub]:
                self.system_values[(sub, rest)] = value
                return
        if any(target.startswith(".".join(p[len(path):]) + ".") for p in self.refused
               if p[:len(path)] == path):
            return
        log.warning("warning: %s: the parameter '%s' names no component or connector of the "
                    "system '%s'; it is ignored (as the SSP standard says).", value.where,
                    target, ".".join(path) or "(top)")

    def set_value(self, fmu: _Fmu, name: str, value: Value, defined: dict[str, Unit],
                  entry: Entry | None) -> None:
        """Record `fmu`.`name` = value (checked against the FMU once its ports are read)."""
        fmu.values[name] = Given((value, defined, entry), value.where)

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

    def typed(self, fmu: _Fmu, name: str, given: Given[Any]) -> tuple[str, Any] | None:
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
        return name if index is None else f"{name}[{index + 1}]", v

    def variable(self, fmu: _Fmu, name: str) -> tuple[Any, int | None]:
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

    def items(self, fmu: _Fmu, connector: str) -> dict[str, int]:
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
    def wires(self, source: str) -> tuple[dict[str, ComponentSpec], list[Given[str]],
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

    def put(self, fmu: _Fmu, port: str, value: Any, where: Location,
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

    def wire(self, end: EndKey, edge: _Edge, comps: dict[str, ComponentSpec],
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

    def enum_table(self, t: Transformation, src: _Fmu, sconn: str, dst: _Fmu,
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

    def undriven(self, end: EndKey, start: EndKey, chain: list[_Edge],
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

    def port_text(self, fmu: _Fmu, connector: str, where: Location) -> str | None:
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

    # -- the experiment ------------------------------------------------------------------------
    def experiment(self, root: Any, source: str) -> ExperimentSpec:
        de = root.find("ssd:DefaultExperiment", NS)
        where = at(source, de if de is not None else root, "ssd:DefaultExperiment")
        start = float(de.get("startTime", 0.0)) if de is not None else 0.0
        stop_text = de.get("stopTime") if de is not None else None
        if stop_text is None:
            log.warning("warning: %s: no stopTime; the run stops at start + 1 s. Fix: give "
                        "ssd:DefaultExperiment stopTime, or --set experiment.stop=...", where)
        stop = float(stop_text) if stop_text is not None else start + 1.0
        step: Any = None
        algorithm = "gauss_seidel"
        for note in root.iter(f"{{{NS['ssc']}}}Annotation"):
            for e in note.iter():
                for key in ("stepSize", "step"):
                    if step is None and e.get(key) is not None:
                        step = Given(float(e.get(key)), at(source, e, f"{tag(e)} {key}"))
                if e.get("algorithm") in ("jacobi", "gauss_seidel"):
                    algorithm = e.get("algorithm")
        if step is None:
            duration = stop - start
            n = duration / DEFAULT_STEP
            value = DEFAULT_STEP if duration > 0 and math.isclose(n, round(n), rel_tol=1e-9) \
                else duration / 1000
            step = Given(value, Location(source, where.line, "default step"))
        return ExperimentSpec(Given(start, where), Given(stop, where), step,
                              Given(algorithm, where), Given(None, where), where)

    def refuse(self, where: Location, what: str, fix: str) -> None:
        self.problems.append(Problem(where, f"{what}.", fix))


def _convert(src: str, dst: str, defined: dict[str, Unit]) -> tuple[float, float]:
    """(gain, offset) from unit `src` to `dst`, units defined by the SSP or FMU or Modelica's;
    UnitError when either is unknown or they measure different quantities."""
    a, b = known_unit(src, defined), known_unit(dst, defined)
    if a is None or b is None:
        raise UnitError(f"the unit '{src if a is None else dst}' is neither defined "
                        f"(ssc:Unit with a BaseUnit) nor a Modelica unit")
    return conversion(a, b)
