"""`export_ssp`: a scenario as an SSP archive (System Structure and Parameterization, 1.0 by
default, 2.0 on request) that other co-simulation tools run.

The archive holds `SystemStructure.ssd` (the system: one component per block, its connectors,
the connections with their unit conversions as linear transformations, the units, the
`DefaultExperiment`), `resources/<block>.fmu` (each block's FMU, `twmr.fmi.ssp.blocks`) and
`resources/<block>.ssv` (the block's parameter values and initial states, bound to it). The
base step, the algorithm, the recorded signals and the events go into annotations: the experiment's
`org.twmr-cosim` one (ours) and libcosim's `com.opensimulationplatform` fixed-step one. The
element prefixes are written as the standard's examples write them (ssd:, ssc:, ssv:), which the
parsers of libcosim and Ecos require. docs/systems.md, SSP export describes the mapping.
"""
from __future__ import annotations

import dataclasses
import datetime
import os
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError, UnitError
from twmr.core.units import BASES, parse_unit
from twmr.fmi.ssp.blocks import BlockFmu, block_fmus
from twmr.fmi.ssp.events import events_element
from twmr.fmi.ssp.xmlsafe import NS
from twmr.scenario.structure import EventSpec, ScenarioSpec
from twmr.scenario.system import Connection, System

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
OSP = NS["osp"]
TWMR = NS["twmr"]
TWMR_TYPE = "org.twmr-cosim"
NAMESPACES = {"ssd": SSD, "ssc": SSC, "ssv": SSV, "osp": OSP, "twmr": TWMR}
for _prefix, _uri in NAMESPACES.items():
    ET.register_namespace(_prefix, _uri)


def _q(ns: str, tag: str) -> str:
    return f"{{{ns}}}{tag}"


def export_ssp(scenario: str | Path, out: str | Path, overrides: Sequence[str] = (),
               fmi: int = 2, python: bool = False, ssp: int = 1) -> Path:
    """Write the scenario file `scenario` (with `--set` overrides) as the SSP archive `out`
    (SSP `ssp` = 1 or 2, block FMUs of FMI `fmi` = 2 or 3; `python`: blocks without a C twin
    through the Python route); the path. Raises a `CosimError` (ScenarioError for a bad
    scenario) naming what cannot be exported; `out` is written only when all of it could be."""
    from twmr.scenario.build import build_system, scenario_spec
    from twmr.scenario.flatten import flatten
    from twmr.scenario.loaders import load_structure

    if ssp not in (1, 2):
        raise CosimError(f"SSP version {ssp!r} is not written. Fix: use --ssp 1 or --ssp 2.")
    if fmi not in (2, 3):
        raise CosimError(f"FMI version {fmi!r} is not exported. Fix: use --fmi 2 or --fmi 3.")
    target = Path(out)
    if target.suffix.lower() != ".ssp":
        raise CosimError(f"export: '{target}' does not end in .ssp. Fix: give --out X.ssp.")
    spec = scenario_spec(load_structure(scenario), overrides=overrides)
    build_system(spec)  # the events checked with the rest
    events = spec.events  # written in our annotation: the system is exported without them
    spec = dataclasses.replace(spec, events=())
    system = build_system(spec)
    spec = dataclasses.replace(flatten(spec).spec, events=events)  # blocks named by path
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="twmr-ssp-") as tmp:
        blocks = block_fmus(system, spec, Path(tmp), fmi, python)
        set_name = _name(spec)
        entries: dict[str, bytes] = {"SystemStructure.ssd": ssd(system, spec, blocks, ssp)}
        for name, block in blocks.items():
            entries[f"resources/{element_name(name)}.fmu"] = block.path.read_bytes()
            if block.values:
                entries[f"resources/{element_name(name)}.ssv"] = ssv(set_name, block, ssp)
        partial = target.with_name(f".{target.name}.{os.getpid()}.partial")
        try:
            with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
                for entry, data in entries.items():
                    z.writestr(entry, data)
            os.replace(partial, target)
        finally:
            partial.unlink(missing_ok=True)
    return target.resolve()


def element_name(instance: str) -> str:
    """The SSP element of an instance: a block inside subsystems ('robot.plant') is one
    element of the flat system, its path joined by '__' ('robot__plant'; SSP names are
    identifiers)."""
    return instance.replace(".", "__")


def _name(spec: ScenarioSpec) -> str:
    """The system's name: the scenario file's stem."""
    return Path(spec.source).stem or "system"


def _version(ssp: int) -> str:
    return "1.0" if ssp == 1 else "2.0"


def ssd(system: System, spec: ScenarioSpec, blocks: dict[str, BlockFmu], ssp: int = 1) -> bytes:
    """SystemStructure.ssd of `system`, its blocks exported as `blocks`."""
    from twmr import __version__

    root = ET.Element(_q(SSD, "SystemStructureDescription"), {
        "version": _version(ssp), "name": _name(spec),
        "generationTool": f"twmr-cosim {__version__}",
        "generationDateAndTime": datetime.datetime.now(datetime.timezone.utc).strftime(
            "%Y-%m-%dT%H:%M:%SZ")})
    if spec.description:
        root.set("description", spec.description)
    units: set[str] = set()
    root.append(system_element(_name(spec), system, blocks, units, ssp))
    defined = {n: attrs for b in blocks.values() for n, attrs in b.units.items()}
    bases = {u: defined.get(u) or _base_unit(u) for u in sorted(units)}
    if any(b is not None for b in bases.values()):
        defs = ET.SubElement(root, _q(SSD, "Units"))
        for unit, base in bases.items():
            if base is not None:
                ET.SubElement(ET.SubElement(defs, _q(SSC, "Unit"), name=unit),
                              _q(SSC, "BaseUnit"), base)
    root.append(default_experiment(system, spec.events))
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def _base_unit(unit: str) -> dict[str, str] | None:
    """BaseUnit attributes of a Modelica unit string (None for a unit we cannot read, whose
    FMU does not define it either: it is left undefined, as in the FMU)."""
    try:
        u = parse_unit(unit)
    except UnitError:
        return None
    base = {b: str(x) for b, x in zip(BASES, u.exponents, strict=False) if x}
    if u.factor != 1.0:
        base["factor"] = repr(u.factor)
    if u.offset:
        base["offset"] = repr(u.offset)
    return base


def system_element(name: str, system: System, blocks: dict[str, BlockFmu], units: set[str],
                   ssp: int = 1) -> ET.Element:
    """The ssd:System of a flat system: one ssd:Component per block, the connections. (A
    subsystem becomes an ssd:System inside Elements, with the ports it exposes as its
    ssd:Connectors: docs/systems.md, SSP export.)"""
    root = ET.Element(_q(SSD, "System"), name=name)
    elements = ET.SubElement(root, _q(SSD, "Elements"))
    for block in blocks.values():
        elements.append(component_element(block, units, ssp))
    wires = [w for c in system.connections for w in _wires(system, blocks, c)]
    if wires:
        conns = ET.SubElement(root, _q(SSD, "Connections"))
        for attrs, gain, offset in wires:
            conn = ET.SubElement(conns, _q(SSD, "Connection"), attrs)
            if gain is not None:
                ET.SubElement(conn, _q(SSC, "LinearTransformation"),
                              factor=repr(gain), offset=repr(offset))
    return root


def component_element(block: BlockFmu, units: set[str], ssp: int = 1) -> ET.Element:
    """The ssd:Component of one block: its FMU, connectors, parameter binding."""
    comp = ET.Element(_q(SSD, "Component"), {
        "name": element_name(block.name), "type": "application/x-fmu-sharedlibrary",
        "source": f"resources/{element_name(block.name)}.fmu", "description": block.how})
    connectors = ET.SubElement(comp, _q(SSD, "Connectors"))
    for c in block.connectors:
        conn = ET.SubElement(connectors, _q(SSD, "Connector"), name=c.name, kind=c.kind)
        typed = ET.SubElement(conn, _q(SSC, _ssp_type(c.type, ssp)))
        if c.unit and c.type == "Real":
            typed.set("unit", c.unit)
            units.add(c.unit)
    if block.values:
        bindings = ET.SubElement(comp, _q(SSD, "ParameterBindings"))
        ET.SubElement(bindings, _q(SSD, "ParameterBinding"),
                      source=f"resources/{element_name(block.name)}.ssv")
    return comp


def _ssp_type(kind: str, ssp: int) -> str:
    """The element of a connector type: SSP 2.0 names the FMI 3.0 types (Float64, Int32)."""
    if ssp == 1:
        return kind
    return {"Real": "Float64", "Integer": "Int32"}.get(kind, kind)


def _wires(system: System, blocks: dict[str, BlockFmu], c: Connection
           ) -> list[tuple[dict[str, str], float | None, float]]:
    """The element connections of one wire: (attributes, linear factor or None, offset).
    A wire whose units differ (gain or offset from the conversion found at build time) gets
    the conversion as its LinearTransformation, with the tool's own unit conversion
    suppressed, so every tool applies it exactly once."""
    comps = system.components
    src_var, dst_var = comps[c.src].variables[c.src_port], comps[c.dst].variables[c.dst_port]
    sidx = c.src_index if c.src_index is not None else (
        (None,) if src_var.size is None else tuple(range(len(comps[c.src].get(c.src_port)))))
    didx = c.dst_index if c.dst_index is not None else (
        (None,) if dst_var.size is None else tuple(range(len(comps[c.dst].get(c.dst_port)))))
    out: list[tuple[dict[str, str], float | None, float]] = []
    for s, d in zip(sidx, didx, strict=True):
        attrs = {"startElement": element_name(c.src),
                 "startConnector": blocks[c.src].variable(c.src_port, s),
                 "endElement": element_name(c.dst),
                 "endConnector": blocks[c.dst].variable(c.dst_port, d)}
        same = src_var.element_unit(s or 0) == dst_var.element_unit(d or 0)
        if c.gain == 1.0 and c.offset == 0.0 and same:
            out.append((attrs, None, 0.0))
        else:
            attrs["suppressUnitConversion"] = "true"
            out.append((attrs, c.gain, c.offset))
    return out


def default_experiment(system: System, events: tuple[EventSpec, ...] = ()) -> ET.Element:
    """ssd:DefaultExperiment: start and stop; the base step, algorithm, recording and events
    in our annotation, the base step again in libcosim's."""
    exp = system.experiment
    el = ET.Element(_q(SSD, "DefaultExperiment"), startTime=repr(exp.start),
                    stopTime=repr(exp.stop))
    notes = ET.SubElement(el, _q(SSD, "Annotations"))
    ours = ET.SubElement(notes, _q(SSC, "Annotation"), type=TWMR_TYPE)
    run = ET.SubElement(ours, _q(TWMR, "Experiment"), step=repr(exp.step),
                        algorithm=exp.algorithm)
    if isinstance(exp.realtime, bool):
        run.set("realtime", "true" if exp.realtime else "false")
    elif exp.realtime is not None:
        run.set("realtime", repr(float(exp.realtime)))
    multiples = {n: m for n, m in system.step_multiples.items() if m != 1}
    for name, m in multiples.items():
        ET.SubElement(run, _q(TWMR, "StepMultiple"), element=element_name(name), value=str(m))
    record = ET.SubElement(run, _q(TWMR, "Record"), decimation=str(system.record.decimation))
    for comp, port in system.record.signals:
        ET.SubElement(record, _q(TWMR, "Signal"), element=element_name(comp), port=port)
    if events:
        run.append(events_element(events, _q(TWMR, "Events"), element_name))
    osp = ET.SubElement(notes, _q(SSC, "Annotation"), type="com.opensimulationplatform")
    ET.SubElement(ET.SubElement(osp, _q(OSP, "Algorithm")), _q(OSP, "FixedStepAlgorithm"),
                  baseStepSize=repr(exp.step))
    return el


def ssv(set_name: str, block: BlockFmu, ssp: int = 1) -> bytes:
    """The .ssv of one block: its parameter values and initial states, by FMU variable."""
    root = ET.Element(_q(SSV, "ParameterSet"), version=_version(ssp), name=set_name)
    params = ET.SubElement(root, _q(SSV, "Parameters"))
    for name, (kind, value) in block.values.items():
        p = ET.SubElement(params, _q(SSV, "Parameter"), name=name)
        ET.SubElement(p, _q(SSV, _ssp_type(kind, ssp)), value=_text(value))
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)
