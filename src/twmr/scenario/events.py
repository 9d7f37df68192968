"""A scenario's `events:`: each fault on a port becomes a `port_fault` block on the port's wires
(`twmr.blocks.faults`). A fault on an output sits between it and every input it feeds; a fault
on an input, between its source and it. The block takes the port's width and unit, so the wires
select and convert as before; the port itself keeps its value in the results (record the
fault block's `y`, named `fault<k>_<comp>_<port>`, for what the readers saw). Being a block with
a kernel, a fault runs alike in the Python schedule, the compiled loop and the adaptive master.
"""
from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import Problem
from twmr.registry import suggest
from twmr.scenario.graph import parse_end
from twmr.scenario.structure import ComponentSpec, EventSpec, Given, ScenarioSpec
from twmr.scenario.system import Experiment


@dataclasses.dataclass(frozen=True)
class Mark:
    """An event as the results keep it: when [s], until when, the port and the fault, the block
    that applies it."""

    at: float
    until: float
    port: str
    fault: str
    value: float
    block: str

    def plain(self) -> dict[str, Any]:
        return {**dataclasses.asdict(self), "until": self.until if math.isfinite(self.until)
                else None}


def insert_faults(spec: ScenarioSpec, comps: dict[str, Component], experiment: Experiment
                  ) -> tuple[ScenarioSpec, list[Problem], list[Mark]]:
    """`spec` with a `port_fault` block for each event (added to `comps` too), the problems of
    the events that cannot be, and the marks of those that are."""
    from twmr.blocks.faults import PortFault

    wires = list(spec.connections)
    specs = dict(spec.components)
    opened = {str(g.value).strip() for g in spec.open}
    problems: list[Problem] = []
    marks: list[Mark] = []
    for k, event in enumerate(spec.events, 1):
        found = _port(event, comps, problems)
        if found is None:
            continue
        comp, port, output = found
        start, stop = _window(event, experiment, problems)
        if start is None or stop is None:
            continue
        text = f"{comp}.{port}"
        if not output and text in opened:
            problems.append(Problem(event.port.where, f"events: '{text}' is listed under "
                                    f"'open:': no wire brings it a value to fault.",
                                    "fault the output that would feed it, or wire it."))
            continue
        touched = [i for i, w in enumerate(wires) if _end_of(w, output) == (comp, port)]
        if not touched:
            problems.append(Problem(event.port.where, f"events: '{text}' is on no wire, so a "
                                    f"fault on it changes nothing any block reads.",
                                    "fault a port that is wired."))
            continue
        name = _free_name(f"fault{k}_{comp.replace('.', '_')}_{port}", comps)
        var = comps[comp].variables[port]
        block = PortFault(name, unit=var.unit if isinstance(var.unit, str) else "")
        value = float(event.value.value) if event.value is not None else 0.0
        block.set_parameter("n", var.width)
        for key, given in (("fault", event.fault.value), ("start", start), ("stop", stop),
                           ("value", value),
                           ("seed", event.seed.value if event.seed is not None else 0)):
            block.set_parameter(key, given)
        comps[name] = block
        specs[name] = ComponentSpec(name, Given("port_fault", event.where), {}, {},
                                    Given(1, event.where), event.where,
                                    f"events: {event.fault.value} on {text}")
        for i in touched:
            wires[i] = _rerouted(wires[i], output, comp, port, name)
        wires.append(Given(f"{text} -> {name}.u" if output else f"{name}.y -> {text}",
                           event.where))
        marks.append(Mark(start, stop, text, str(event.fault.value), value, name))
    return dataclasses.replace(spec, components=specs, connections=tuple(wires)), problems, marks


def _port(event: EventSpec, comps: dict[str, Component], problems: list[Problem]
          ) -> tuple[str, str, bool] | None:
    """(component, port, whether an output) the event names; None after its problem."""
    text = str(event.port.value).strip()
    comp, _, port = text.rpartition(".")
    if comp not in comps:
        problems.append(Problem(event.port.where, f"events: '{text}' names no component"
                                f"{suggest(comp, list(comps))}.", "give comp.port of a "
                                "component of this scenario (comp.sub.port inside a subsystem)."))
        return None
    ports = [*comps[comp].outputs, *comps[comp].inputs]
    if port not in ports:
        problems.append(Problem(event.port.where, f"events: '{comp}' has no port '{port}'"
                                f"{suggest(port, ports)}.", f"known: {', '.join(ports)}."))
        return None
    return comp, port, port in comps[comp].outputs


def _window(event: EventSpec, experiment: Experiment, problems: list[Problem]
            ) -> tuple[float | None, float | None]:
    """[start, stop) [s] of the event, inside the run; (None, None) after its problem."""
    start = float(event.at.value)
    stop = float(event.until.value) if event.until is not None else math.inf
    if not (math.isfinite(start) and experiment.start <= start < experiment.stop):
        problems.append(Problem(event.at.where, f"events: at = {start:g} s is outside the run "
                                f"[{experiment.start:g}, {experiment.stop:g}) s.",
                                "give a time within the experiment."))
        return None, None
    if not stop > start or math.isnan(stop):
        where = event.until.where if event.until is not None else event.where
        problems.append(Problem(where, f"events: until = {stop:g} s is not after at = "
                                f"{start:g} s.", "give until after at, or leave it out (to "
                                "the end)."))
        return None, None
    return start, stop


def _end_of(wire: Given[str], output: bool) -> tuple[str, str] | None:
    """(component, port) of the wire's source (`output`) or destination; None if unreadable
    (reported when the wires are read)."""
    left, _, right = str(wire.value).partition("->")
    try:
        end = parse_end(left if output else right)
    except ValueError:
        return None
    return end.comp, end.port


def _rerouted(wire: Given[str], output: bool, comp: str, port: str, block: str) -> Given[str]:
    """The wire with its end at comp.port moved to the fault block (its element selection
    kept): an output's readers read the block's y, an input's source feeds the block's u."""
    left, _, right = str(wire.value).partition("->")
    end = left if output else right
    moved = re.sub(rf"^\s*{re.escape(comp)}\.{re.escape(port)}",
                   f"{block}.{'y' if output else 'u'}", end)
    text = f"{moved.strip()} -> {right.strip()}" if output else f"{left.strip()} -> {moved.strip()}"
    return Given(text, wire.where)


def _free_name(wanted: str, comps: dict[str, Component]) -> str:
    name, n = wanted, 1
    while name in comps:
        n += 1
        name = f"{wanted}_{n}"
    return name
