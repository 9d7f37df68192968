"""A controller FMU on an FMI-LS-BUS CAN terminal (`twmr export KIND --fmi 3 --can PROTOCOL`):
what a CAN drive protocol brings (`CNode`: its host side in C, implementing c/node.h, and its
FMU parameters) and what the FMU gets from it: the terminal `CanChannel` (Rx_Data, Tx_Data,
Rx_Clock triggered input clock, Tx_Clock triggered output clock; the MIME type of FMI-LS-BUS CAN
1.0.0), `terminalsAndIcons.xml` and the layered standard's manifest.

A protocol offers its node as the attribute `c_node` of its `Link` class, registered in the
entry-point group `twmr.can_protocols` (the engine imports no CAN package: it finds the node
through the registry). The block's input the drives' frames give (`replaces`, the wheel speeds)
becomes an output of the FMU; the node's parameters are Float64 parameters `drive.<name>`.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError
from twmr.core.port import Parameter
from twmr.fmi.cexport.describe import Element
from twmr.registry import CAN_PROTOCOLS, plugin, plugins, suggest

#: the FMI-LS-BUS CAN MIME type of Rx_Data and Tx_Data
MIME = 'application/org.fmi-standard.fmi-ls-bus.can; version="1.0.0"'
TERMINAL = "CanChannel"
PREFIX = "drive."
#: the terminal's members after the elements and `time` (value reference NV): offset, name
MEMBERS = {"VR_RX_DATA": (1, "Rx_Data"), "VR_TX_DATA": (2, "Tx_Data"),
           "VR_RX_CLOCK": (3, "Rx_Clock"), "VR_TX_CLOCK": (4, "Tx_Clock")}
#: the C files of the FMI-LS-BUS framing (beside the FMI wrapper)
LSBUS_SOURCES = ("lsbus.c",)
LSBUS_HEADERS = ("lsbus.h", "node.h")


@dataclass(frozen=True)
class CNode:
    """A protocol's host side in C: `source` implements c/node.h, `codec` are its frame
    encoders and decoders (a .c with its .h, the C twin of the protocol's Python module);
    `parameters` its FMU parameters (name -> the drive block's Parameter; exported as
    `drive.<name>`; `node_ids` within the Link's `node_range`, by default its
    `default_nodes`), `options(values)` the #defines compiled in from the text ones (`texts`:
    name -> default), `state` how many values of its own it keeps; `replaces` the controller's
    input its frames give, `sends` the output it sends."""

    source: Path
    codec: tuple[Path, Path]
    parameters: Mapping[str, Parameter]
    texts: Mapping[str, str] = field(default_factory=dict)
    options: Callable[[Mapping[str, Any]], Mapping[str, int]] = field(
        default=lambda values: {})
    state: int = 1
    replaces: str = "wheel_speed"
    sends: str = "torque"


@dataclass(frozen=True)
class Bus:
    """The CAN node of one export: the protocol, its C node, the node ids it can address and
    its defaults (from its Link class), the node's parameters given."""

    protocol: str
    node: CNode
    node_range: range
    default_nodes: tuple[int, int]
    given: Mapping[str, Any]


def bus_of(protocol: str, parameters: Mapping[str, Any]) -> tuple[Bus, dict[str, Any]]:
    """The CAN node of the registered CAN protocol `protocol` with its `drive.<name>` values
    among `parameters`, and the rest (the block's); CosimError naming the protocols that have
    one."""
    known = plugins(CAN_PROTOCOLS)
    if protocol not in known:
        raise CosimError(f"--can {protocol}: no CAN protocol of that name{suggest(protocol, known)}"
                         f" (registered: {', '.join(sorted(known)) or 'none'}). Fix: give one of "
                         f"them; install twmr-cosim[hw] for odrive and cia402.")
    link = plugin(CAN_PROTOCOLS, protocol, "CAN protocol")
    node = getattr(link, "c_node", None)
    if not isinstance(node, CNode):
        raise CosimError(f"--can {protocol}: the protocol has no C node for a controller FMU. "
                         f"Fix: use a protocol that has one, or give its Link class a `c_node` "
                         f"(twmr.fmi.cexport.busnode.CNode).")
    own = {k: v for k, v in parameters.items() if not k.startswith(PREFIX)}
    given = {k[len(PREFIX):]: v for k, v in parameters.items() if k.startswith(PREFIX)}
    names = [*node.parameters, *node.texts]
    for key in given:
        if key not in names:
            raise CosimError(f"export --can {protocol}: '{PREFIX}{key}' is not a parameter of "
                             f"the node{suggest(key, names)}; it has "
                             f"{', '.join(PREFIX + n for n in names)}. Fix: give one of them.")
    return Bus(protocol, node, link.node_range, tuple(link.default_nodes), given), own


def node_elements(bus: Bus) -> list[Element]:
    """The node's Float64 parameters (fixed), `drive.<name>[i]` for a vector, with the
    values given or the drive block's defaults."""
    out: list[Element] = []
    node, protocol = bus.node, bus.protocol
    for name, var in node.parameters.items():
        value = bus.given.get(name, bus.default_nodes if name == "node_ids" else var.start)
        try:
            value = var.coerce(value)
        except (TypeError, ValueError) as err:
            raise CosimError(f"export --can {protocol}: {PREFIX}{name} = {value!r}: {err}. "
                             f"Fix: give a value that fits the parameter.") from None
        port = f"drive_{name}"
        values = [value] if var.size is None else list(value)
        lo, hi = ((bus.node_range.start, bus.node_range.stop - 1) if name == "node_ids"
                  else (var.min, var.max))
        for i, x in enumerate(values):
            label = f"{PREFIX}{name}" + ("" if var.size is None else f"[{i + 1}]")
            out.append(Element(label, port, None if var.size is None else i, float(x), var,
                               "f", None if lo is None else float(lo),
                               None if hi is None else float(hi)))
    return out


def node_defines(bus: Bus, nv: int) -> dict[str, int | str]:
    """config.h's #defines of the node: BUS_TERMINAL, its state size, the terminal's value
    references (after the `nv` elements and `time`) and its compiled-in options."""
    node = bus.node
    texts = {k: str(bus.given.get(k, v)) for k, v in node.texts.items()}
    return {"BUS_TERMINAL": 1, "NODE_NS": max(1, node.state),
            **{k: nv + offset for k, (offset, _) in MEMBERS.items()}, **node.options(texts)}


def bus_elements(comp: Any, kind: str, elems: list[Element], bus: Bus
                 ) -> tuple[list[Element], dict[str, int | str]]:
    """The elements of a CAN node FMU of `comp` (the input the drives' frames give is an
    output, the node's parameters appended) and the node's #defines."""
    protocol, node = bus.protocol, bus.node
    for port in (node.replaces, node.sends):
        if port not in comp.variables:
            raise CosimError(f"export {kind} --can {protocol}: the kind has no port '{port}' "
                             f"(the drives' frames give '{node.replaces}', the node sends "
                             f"'{node.sends}'). Fix: export a controller with both (asmc, smc).")
    for e in elems:
        if e.port == node.replaces:
            e.code = "o"
            e.var = replace(e.var, description=f"{e.var.description}, from the drives' frames")
    elems = [*elems, *node_elements(bus)]
    return elems, node_defines(bus, len(elems))


def with_terminal(description: bytes, protocol: str, nv: int) -> bytes:
    """modelDescription.xml `description` of `nv` elements with the terminal added."""
    root = ET.fromstring(description)
    root.set("description", f"{root.get('description', '')} An FMI-LS-BUS CAN node: the host "
             f"of two {protocol} drives on its terminal {TERMINAL}.".strip())
    add_terminal(root, nv)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True)


def add_terminal(root: ET.Element, nv: int) -> None:
    """The terminal's variables in modelDescription.xml (FMI 3.0), after `time`; event mode;
    no output depends directly on an input (they change at the node's events only)."""
    cs = root.find("CoSimulation")
    assert cs is not None
    cs.set("hasEventMode", "true")
    variables = root.find("ModelVariables")
    assert variables is not None
    vr = {name: str(nv + offset) for offset, name in MEMBERS.values()}
    rx = ET.SubElement(variables, "Binary", {
        "name": f"{TERMINAL}.Rx_Data", "valueReference": vr["Rx_Data"], "causality": "input",
        "variability": "discrete", "clocks": vr["Rx_Clock"], "mimeType": MIME,
        "description": "bus operations received (FMI-LS-BUS CAN)"})
    ET.SubElement(rx, "Start", value="")
    ET.SubElement(variables, "Binary", {
        "name": f"{TERMINAL}.Tx_Data", "valueReference": vr["Tx_Data"], "causality": "output",
        "variability": "discrete", "initial": "calculated", "clocks": vr["Tx_Clock"],
        "mimeType": MIME, "description": "bus operations sent (FMI-LS-BUS CAN)"})
    ET.SubElement(variables, "Clock", {
        "name": f"{TERMINAL}.Rx_Clock", "valueReference": vr["Rx_Clock"], "causality": "input",
        "intervalVariability": "triggered", "description": "ticks when Rx_Data holds operations"})
    ET.SubElement(variables, "Clock", {
        "name": f"{TERMINAL}.Tx_Clock", "valueReference": vr["Tx_Clock"], "causality": "output",
        "intervalVariability": "triggered",
        "description": "ticks when initialization ends and at the end of every step"})
    structure = root.find("ModelStructure")
    assert structure is not None
    for output in structure.iter("Output"):
        output.set("dependencies", "")  # they change at the node's events only
    first_initial = next((i for i, e in enumerate(structure) if e.tag == "InitialUnknown"),
                         len(structure))
    for k, name in enumerate(("Tx_Data", "Tx_Clock")):
        out = ET.Element("Output", valueReference=vr[name], dependencies="")
        structure.insert(first_initial + k, out)
    ET.SubElement(structure, "InitialUnknown", valueReference=vr["Tx_Clock"])
    ET.indent(root)


def terminals_xml() -> str:
    """terminalsAndIcons/terminalsAndIcons.xml: the network terminal CanChannel."""
    members = "\n".join(
        f'      <TerminalMemberVariable variableKind="signal" '
        f'variableName="{TERMINAL}.{m}" memberName="{m}"/>'
        for m in ("Rx_Clock", "Rx_Data", "Tx_Clock", "Tx_Data"))
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiTerminalsAndIcons fmiVersion="3.0">\n'
            f'  <Terminals>\n    <Terminal terminalKind="org.fmi-ls-bus.network-terminal" '
            f'matchingRule="org.fmi-ls-bus.transceiver"\n              name="{TERMINAL}" '
            f'description="CAN bus terminal">\n{members}\n    </Terminal>\n  </Terminals>\n'
            f'</fmiTerminalsAndIcons>\n')


MANIFEST = """<?xml version="1.0" encoding="UTF-8"?>
<fmiLayeredStandardManifest xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"
    fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-bus" fmi-ls:fmi-ls-version="1.0.0"
    fmi-ls:fmi-ls-description="Layered Standard for the simulation of bus communication"
    isBusSimulationFMU="false"/>
"""
#: where the two files go in the FMU
EXTRA_FILES = {"terminalsAndIcons/terminalsAndIcons.xml": terminals_xml,
               "extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml": lambda: MANIFEST}
