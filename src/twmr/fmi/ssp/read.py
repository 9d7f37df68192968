"""An SSP system structure (.ssd in an .ssp archive or a folder) -> the flat `ScenarioSpec`.

Every FMU component of the system and of its nested systems becomes one component of kind `fmu`
named by its path (`sub.comp`); a component whose source is another .ssd is read as a nested
system. Connections, transformations and units are resolved by `twmr.fmi.ssp.flatten`. Parameter
bindings (.ssv files or inline, with .ssm mappings and prefixes) set the FMUs' parameters and
start values, a system level over the levels below it as the standard says. The
`DefaultExperiment` gives start and stop; base step, algorithm, pacing, step multiples and the
recording come from our annotation (`twmr export`), else the base step from libcosim's
`osp:FixedStepAlgorithm` (run as libcosim runs it: Jacobi), else from an annotation's `stepSize`
(as OMSimulator writes it) or `step`, else 1 ms when it divides the run, else 1/1000 of the run.
A connector names an FMU variable as the FMU does: dotted Modelica names (`consumerFeed.p`) and
one element of an array variable (`p_Crane.f[1]`) alike.

What SSP allows and twmr does not run is refused naming the element and line: components that are
not FMUs (or nested .ssp packages), signal dictionaries, connections into parameters from outputs,
Binary parameters."""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import re
from pathlib import Path
from typing import Any

from twmr.core.errors import Location, Problem, ScenarioError
from twmr.core.units import Unit
from twmr.fmi.ssp.archive import unpacked
from twmr.fmi.ssp.common import enumerations, transformation, units
from twmr.fmi.ssp.events import read_events
from twmr.fmi.ssp.flatten import Edge, EndKey, Flattener, Fmu, Path_
from twmr.fmi.ssp.params import Entry, Value, parameter_mapping, parameter_set
from twmr.fmi.ssp.schema import validate
from twmr.fmi.ssp.xmlsafe import MAX_XML_BYTES, NS, at, parse_xml, tag
from twmr.scenario.structure import (
    MAX_DEPTH,
    MAX_INCLUSIONS,
    ExperimentSpec,
    Given,
    RecordingSpec,
    ScenarioSpec,
)

log = logging.getLogger("twmr")

FMU_TYPE = "application/x-fmu-sharedlibrary"
SSD_TYPE = "application/x-ssp-definition"
#: the step when no annotation gives one [s] (used when it divides the run)
DEFAULT_STEP = 1e-3
TWMR, OSP = NS["twmr"], NS["osp"]
_NAME = re.compile(r"^[A-Za-z_]\w*$")


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


class _Reader:
    def __init__(self, label: str, root: Path, beside: Path):
        self.label, self.root, self.beside = label, root, beside
        self.problems: list[Problem] = []
        self.fmus: dict[Path_, Fmu] = {}
        self.systems: dict[Path_, dict[str, tuple[str, str, Location]]] = {}
        self.edges: dict[EndKey, list[Edge]] = {}
        self.system_values: dict[EndKey, Value] = {}
        self.units: dict[str, Unit] = {}
        self.enums: dict[str, dict[str, int]] = {}
        self.reading: list[Path] = []
        self.included = 0  # .ssd files read as nested systems so far
        self.refused: set[Path_] = set()  # elements refused (their connections are not checked)
        #: bound parameters that name nothing of their system: (where, name, system)
        self.unmatched: list[tuple[Location, str, str]] = []

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
        self.report_unmatched()
        self.fail_if_problems()
        comps, conns, opened = Flattener(self.fmus, self.edges, self.system_values, self.units,
                                         self.enums).flatten()
        experiment = self.experiment(root, source)
        record = self.recording(root, source)
        for name, multiple in self.step_multiples(root).items():
            if name in comps:
                comps[name] = dataclasses.replace(comps[name], step_multiple=Given(
                    multiple, comps[name].where))
        self.fail_if_problems()
        top = at(source, root)
        note = _experiment_note(root)
        events = read_events(note.find(f"{{{TWMR}}}Events") if note is not None else None,
                             lambda e, what: at(source, e, what))
        return ScenarioSpec(source=source, base_dir=self.root, components=comps,
                            connections=tuple(conns), open=tuple(opened), experiment=experiment,
                            record=record, events=events,
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
            self.included += 1
            if self.included > MAX_INCLUSIONS or len(self.reading) >= MAX_DEPTH:
                what = f"more than {MAX_INCLUSIONS:,} .ssd inclusions (one included twice " \
                    f"counts twice)" if self.included > MAX_INCLUSIONS else \
                    f"more than {MAX_DEPTH} .ssd files deep"
                raise ScenarioError(Problem(where, f"'{src}': the system includes {what}, the "
                                            f"limit a system may have.", "include each part "
                                            "once, with fewer levels of .ssd files."))
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
        self.fmus[path] = Fmu(".".join(path), where, found, interface, connectors, enum_types)
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
        edge = Edge(ends[0], transformation(elem, source), suppress, where)
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
        self.unmatched.append((value.where, target, ".".join(path) or "(top)"))

    def report_unmatched(self) -> None:
        """One warning for the bound parameters that name nothing (the SSP standard ignores
        them): the first three, and how many there are."""
        if not self.unmatched:
            return
        where, name, system = self.unmatched[0]
        more = len(self.unmatched) - 1
        others = ", ".join(f"'{n}' (line {w.line})" for w, n, _ in self.unmatched[1:3])
        log.warning("warning: %s: the parameter '%s' names no component or connector of the "
                    "system '%s'%s; %s ignored (as the SSP standard says).", where, name,
                    system, f", nor do {more} more ({others}{', ...' if more > 2 else ''})"
                    if more else "", "they are" if more else "it is")

    def set_value(self, fmu: Fmu, name: str, value: Value, defined: dict[str, Unit],
                  entry: Entry | None) -> None:
        """Record `fmu`.`name` = value (checked against the FMU once its ports are read)."""
        fmu.values[name] = Given((value, defined, entry), value.where)

    # -- the experiment ------------------------------------------------------------------------
    def experiment(self, root: Any, source: str) -> ExperimentSpec:
        """Start and stop from ssd:DefaultExperiment; the base step, algorithm and pacing from
        our annotation (`twmr export` writes it), else libcosim's fixed-step one (base step,
        and libcosim's algorithm: every FMU steps from the outputs of the step before, i.e.
        Jacobi), else a `stepSize`/`step` attribute of any annotation (OMSimulator's)."""
        de = root.find("ssd:DefaultExperiment", NS)
        where = at(source, de if de is not None else root, "ssd:DefaultExperiment")
        start = float(de.get("startTime", 0.0)) if de is not None else 0.0
        stop_text = de.get("stopTime") if de is not None else None
        if stop_text is None:
            log.warning("warning: %s: no stopTime; the run stops at start + 1 s. Fix: give "
                        "ssd:DefaultExperiment stopTime, or --set experiment.stop=...", where)
        stop = float(stop_text) if stop_text is not None else start + 1.0
        step: Any = None
        algorithm = Given("gauss_seidel", where)
        realtime: Given[bool | float | None] = Given(None, where)
        ours = _experiment_note(root)
        osp = root.find(f".//{{{OSP}}}FixedStepAlgorithm") if de is not None else None
        if ours is not None:
            step = Given(float(ours.get("step")), at(source, ours, "twmr Experiment step"))
            if ours.get("algorithm"):
                algorithm = Given(ours.get("algorithm"), at(source, ours, "twmr Experiment"))
            paced = ours.get("realtime")
            if paced in ("true", "false"):
                realtime = Given(paced == "true", at(source, ours, "realtime"))
            elif paced is not None:
                with contextlib.suppress(ValueError):  # not ours: pacing as the run decides
                    realtime = Given(float(paced), at(source, ours, "realtime"))
        elif osp is not None and osp.get("baseStepSize") is not None:
            step = Given(float(osp.get("baseStepSize")),
                         at(source, osp, "osp:FixedStepAlgorithm baseStepSize"))
            algorithm = Given("jacobi", at(source, osp, "osp:FixedStepAlgorithm"))
        for note in root.iter(f"{{{NS['ssc']}}}Annotation"):
            for e in note.iter():
                for key in ("stepSize", "step"):
                    if step is None and e.get(key) is not None:
                        step = Given(float(e.get(key)), at(source, e, f"{tag(e)} {key}"))
                if ours is None and e.get("algorithm") in ("jacobi", "gauss_seidel"):
                    algorithm = Given(e.get("algorithm"), at(source, e, tag(e)))
        if step is None:
            duration = stop - start
            n = duration / DEFAULT_STEP
            value = DEFAULT_STEP if duration > 0 and math.isclose(n, round(n), rel_tol=1e-9) \
                else duration / 1000
            step = Given(value, Location(source, where.line, "default step"))
        return ExperimentSpec(Given(start, where), Given(stop, where), step, algorithm,
                              realtime, where)

    def recording(self, root: Any, source: str) -> RecordingSpec:
        """What `twmr export` recorded (our annotation's Record), else every output."""
        top = at(source, root)
        note = _experiment_note(root)
        record = note.find(f"{{{TWMR}}}Record") if note is not None else None
        if record is None:
            return RecordingSpec(None, Given(1, top), top)
        where = at(source, record, "twmr Record")
        signals = tuple(Given(f"{s.get('element')}.{s.get('port')}", at(source, s, "Signal"))
                        for s in record.findall(f"{{{TWMR}}}Signal"))
        decimation = int(record.get("decimation", "1"))
        return RecordingSpec(signals or None, Given(decimation, where), where)

    def step_multiples(self, root: Any) -> dict[str, int]:
        """Each element's step multiple from our annotation (1 where none is given)."""
        note = _experiment_note(root)
        return {} if note is None else {e.get("element", ""): int(e.get("value", "1"))
                                        for e in note.findall(f"{{{TWMR}}}StepMultiple")}

    def refuse(self, where: Location, what: str, fix: str) -> None:
        self.problems.append(Problem(where, f"{what}.", fix))


def _experiment_note(root: Any) -> Any:
    """Our annotation's Experiment element under ssd:DefaultExperiment (None: not written)."""
    return root.find(f"ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/{{{TWMR}}}Experiment",
                     NS)
