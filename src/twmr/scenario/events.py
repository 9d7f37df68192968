"""A scenario's `events:`. Each fault on a port becomes a `port_fault` block on the port's wires
(`twmr.blocks.faults`). A fault on an output sits between it and every input it feeds; a fault
on an input, between its source and it. The block takes the port's width and unit, so the wires
select and convert as before; the port itself keeps its value in the results (record the
fault block's `y`, named `fault<k>_<comp>_<port>`, for what the readers saw). Being a block with
a kernel, a fault runs alike in the Python schedule, the compiled loop and the adaptive master. Each
`set` of a parameter is a `Change` the master applies between two steps (`apply_change`): the
blocks' kernels are made anew from the parameters of then, in the Python schedule and the
compiled loop alike. A condition event (`when:`) becomes a `condition_watch` block on the
output it watches (`twmr.blocks.watch`) and a `Watch`: each time the block fires, the master adds
the changes of its action (a parameter set, or the window of its fault block opened).
"""
from __future__ import annotations

import dataclasses
import math
import re
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import Problem
from twmr.registry import suggest
from twmr.scenario.graph import element_of, parse_end
from twmr.scenario.structure import ComponentSpec, EventSpec, Given, ScenarioSpec
from twmr.scenario.system import Experiment

#: the masters whose steps stop at a set event
FIXED_STEP = ("gauss_seidel", "jacobi")


@dataclasses.dataclass(frozen=True)
class Change:
    """A parameter set during a run: `name` of component `comp` to `value` before base step
    `step` (the first communication point at or after `at` [s])."""

    step: int
    at: float
    comp: str
    name: str
    value: Any


@dataclasses.dataclass(frozen=True)
class Watch:
    """A condition event: its `condition_watch` block and condition, and its action — `set`
    a parameter (`change`, its step and time given when it fires) or a fault (its name) on
    `target` by its `port_fault` block, open for `duration` [s] (inf: to the end) from each
    firing."""

    block: str
    condition: str
    action: str
    target: str
    value: float
    change: Change | None
    fault_block: str
    duration: float

    def fired(self, step: int, at: float) -> list[Change]:
        """The changes of a firing whose action applies from base step `step` (time `at`)."""
        if self.change is not None:
            return [dataclasses.replace(self.change, step=step, at=at)]
        return [Change(step, at, self.fault_block, "start", at),
                Change(step, at, self.fault_block, "stop", at + self.duration)]


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
                  ) -> tuple[ScenarioSpec, list[Problem], list[Mark], list[Watch]]:
    """`spec` with a `port_fault` block for each fault event (added to `comps` too) and a
    `condition_watch` block for each condition event; the problems of the events that cannot
    be, the marks of the timed ones and the watches of the conditioned ones."""
    wires = list(spec.connections)
    specs = dict(spec.components)
    problems: list[Problem] = []
    marks: list[Mark] = []
    watches: list[Watch] = []
    opened = {str(g.value).strip() for g in spec.open}
    watched: list[Given[str]] = []  # joined last: a watch reads its port, not a fault of it
    for k, event in enumerate(spec.events, 1):
        if event.when is None and event.at.value is None:
            problems.append(Problem(event.where, "events: an event needs at (a time [s]) or "
                                    "when (a condition).", "give at: 5.0, or when: "
                                    "'comp.port > 2.0'."))
            continue
        if event.when is not None:
            watch = _watch(k, event, comps, specs, wires, watched, opened, problems)
            if watch is not None:
                watches.append(watch)
            continue
        if event.set is not None or not _is_fault(event, problems) or _misplaced(event,
                                                                               problems):
            continue
        start, stop = _window(event, experiment, problems)
        if start is None or stop is None:
            continue
        made = _fault_block(k, event, start, stop, comps, specs, wires, opened, problems)
        if made is not None:
            text, name, value = made
            assert event.fault is not None
            marks.append(Mark(start, stop, text, str(event.fault.value), value, name))
    if watches and experiment.algorithm not in FIXED_STEP:
        problems.append(Problem(spec.at("events"), f"events: condition events (when:) run on "
                                f"the fixed-step masters ({', '.join(FIXED_STEP)}), not on "
                                f"'{experiment.algorithm}'.", "use algorithm: gauss_seidel or "
                                "jacobi."))
    spec = dataclasses.replace(spec, components=specs, connections=(*wires, *watched))
    return spec, problems, marks, watches


def _misplaced(event: EventSpec, problems: list[Problem]) -> bool:
    """Whether a timed event (at) carries a condition event's keys; if so, its problem."""
    extra = [key for key in ("hysteresis", "duration") if getattr(event, key) is not None]
    if extra:
        problems.append(Problem(event.where, f"events: {extra[0]} goes with when (a condition "
                                f"event), not with at.", "write when: 'comp.port > value' in "
                                "place of at, or leave it out (a timed fault lasts until "
                                "until)."))
    return bool(extra)


_CONDITION = re.compile(r"^\s*(?P<port>[A-Za-z_][\w.]*?)(?:\[(?P<element>\d+)\])?\s*"
                        r"(?P<op>>=|<=|>|<)\s*(?P<value>[-+0-9.eEinfINF]+)\s*$")


def _condition(event: EventSpec, comps: dict[str, Component], problems: list[Problem]
               ) -> tuple[str, str, float] | None:
    """(the watched end 'comp.port[i]', the comparison, the threshold) of a condition event;
    None after its problem."""
    from twmr.blocks.watch import OPS

    assert event.when is not None
    text, where = str(event.when.value), event.when.where
    form = "write when: 'comp.port > 2.0' (or >=, <, <=; comp.port[i] for element i)."
    found = _CONDITION.match(text)
    if found is None:
        problems.append(Problem(where, f"events: when '{text}' is not a condition of the form "
                                f"'comp.port > value'.", form))
        return None
    try:
        threshold = float(found["value"])
    except ValueError:
        threshold = math.nan
    if not math.isfinite(threshold):
        problems.append(Problem(where, f"events: when '{text}': {found['value']!r} is not a "
                                f"finite number.", form))
        return None
    comp, _, port = found["port"].rpartition(".")
    if comp not in comps:
        problems.append(Problem(where, f"events: when '{text}' names no component"
                                f"{suggest(comp, list(comps))}.", form))
        return None
    outputs = list(comps[comp].outputs)
    if port not in outputs:
        said = ("an input: watch the output that feeds it" if port in comps[comp].inputs
                else f"no output of '{comp}'{suggest(port, outputs)}")
        problems.append(Problem(where, f"events: when '{text}': '{port}' is {said}.",
                                f"watch an output of '{comp}': {', '.join(outputs)}."))
        return None
    width = comps[comp].variables[port].width
    element = int(found["element"]) if found["element"] else None
    if (element is None and width > 1) or (element is not None and not 1 <= element <= width):
        problems.append(Problem(where, f"events: when '{text}': {comp}.{port} has {width} "
                                f"elements; a condition watches one.",
                                f"name it, 1 to {width}: {comp}.{port}[1]."))
        return None
    end = f"{comp}.{port}" if element is None else f"{comp}.{port}[{element}]"
    assert found["op"] in OPS
    return end, found["op"], threshold


def _watch(k: int, event: EventSpec, comps: dict[str, Component],
           specs: dict[str, ComponentSpec], wires: list[Given[str]], watched: list[Given[str]],
           opened: set[str], problems: list[Problem]) -> Watch | None:
    """The watch of condition event `k` (its `condition_watch` block and wire added, and for a
    fault its `port_fault` block, closed until the condition opens it); None after its
    problem."""
    from twmr.blocks.watch import ConditionWatch

    assert event.when is not None
    if event.at.value is not None or event.until is not None:
        key = "at" if event.at.value is not None else "until"
        fix = ("leave at out: the condition says when." if key == "at" else
               "write duration: [s] in place of until (how long a fault it opens lasts).")
        problems.append(Problem(event.where, f"events: {key} with when: a condition event "
                                f"happens when its condition becomes true.", fix))
        return None
    condition = _condition(event, comps, problems)
    if condition is None:
        return None
    end, op, threshold = condition
    hysteresis = float(event.hysteresis.value) if event.hysteresis is not None else 0.0
    duration = float(event.duration.value) if event.duration is not None else math.inf
    change, fault_block, target = None, "", ""
    if event.set is not None:
        if event.port is not None or event.fault is not None or event.duration is not None:
            problems.append(Problem(event.where, "events: a set event takes set and value; "
                                    "port, fault and duration are a fault's.",
                                    "split it into two events."))
            return None
        if event.value is None:
            problems.append(Problem(event.set.where, f"events: set {event.set.value} needs a "
                                    f"value.", "give value: the parameter's new value."))
            return None
        target = str(event.set.value).strip()
        change = parameter_change(target, event.value.value, 0.0, comps, None, event.set.where,
                         problems)
        if change is None:
            return None
        action = "set"
    else:
        if not _is_fault(event, problems):
            return None
        made = _fault_block(k, event, math.inf, math.inf, comps, specs, wires, opened,
                            problems)
        if made is None:
            return None
        target, fault_block, _ = made
        assert event.fault is not None
        action = str(event.fault.value)
    name = _free_name(f"watch{k}", comps)
    block = ConditionWatch(name)
    for key, value in (("op", op), ("threshold", threshold), ("hysteresis", hysteresis)):
        block.set_parameter(key, value)
    comps[name] = block
    specs[name] = ComponentSpec(name, Given("condition_watch", event.where), {}, {},
                                Given(1, event.where), event.where,
                                f"events: when {event.when.value}")
    watched.append(Given(f"{end} -> {name}.u", event.when.where))
    value = float(event.value.value) if event.value is not None and isinstance(
        event.value.value, int | float) else math.nan
    return Watch(name, str(event.when.value).strip(), action, target, value, change,
                 fault_block, duration)


def _fault_block(k: int, event: EventSpec, start: float, stop: float,
                 comps: dict[str, Component], specs: dict[str, ComponentSpec],
                 wires: list[Given[str]], opened: set[str], problems: list[Problem]
                 ) -> tuple[str, str, float] | None:
    """Insert the `port_fault` block of fault event `k` on its port's wires, faulting from
    `start` to `stop` [s]: (the port, the block, the fault's value), or None after its
    problem."""
    from twmr.blocks.faults import PortFault

    assert event.port is not None and event.fault is not None
    found = _port(event, comps, problems)
    if found is None:
        return None
    comp, port, output, element = found
    text = f"{comp}.{port}"
    if not output and text in opened:
        problems.append(Problem(event.port.where, f"events: '{text}' is listed under "
                                f"'open:': no wire brings it a value to fault.",
                                "fault the output that would feed it, or wire it."))
        return None
    touched = [i for i, w in enumerate(wires) if _end_of(w, output) == (comp, port)]
    if not touched:
        problems.append(Problem(event.port.where, f"events: '{text}' is on no wire, so a "
                                f"fault on it changes nothing any block reads.",
                                "fault a port that is wired."))
        return None
    name = _free_name(f"fault{k}_{comp.replace('.', '_')}_{port}", comps)
    var = comps[comp].variables[port]
    block = PortFault(name, unit=var.unit if isinstance(var.unit, str) else "")
    value = float(event.value.value) if event.value is not None else 0.0
    block.set_parameter("n", var.width)
    for key, given in (("fault", event.fault.value), ("start", start), ("stop", stop),
                       ("value", value), ("element", element),
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
    return (f"{text}[{element}]" if element else text), name, value


def _is_fault(event: EventSpec, problems: list[Problem]) -> bool:
    """Whether `event` is a fault as written (port and fault given); else its problem."""
    if event.port is not None and event.fault is not None:
        return True
    problems.append(Problem(event.where, "events: an event needs either port and fault (a "
                            "fault on a port) or set and value (a parameter changed).",
                            "write {at: 5, port: comp.port, fault: freeze} or {at: 5, set: "
                            "comp.parameter, value: 2.0}."))
    return False


def parameter_changes(spec: ScenarioSpec, comps: dict[str, Component], experiment: Experiment
                      ) -> tuple[list[Change], list[Problem], list[Mark]]:
    """The `set` events of `spec`: each a `Change` at the first base step at or after its time
    (within 1e-9 of a step), its value taken by the parameter as `--set` would; the problems of
    those that cannot be, and their marks."""
    changes: list[Change] = []
    problems: list[Problem] = []
    marks: list[Mark] = []
    held: dict[tuple[str, str], Any] = {}  # each parameter's value as the events leave it
    sets = sorted((e for e in spec.events if e.set is not None and e.when is None
                   and e.at.value is not None), key=lambda e: _time(e.at))
    for event in sets:
        assert event.set is not None
        where = event.set.where
        if _misplaced(event, problems):
            continue
        if event.port is not None or event.fault is not None or event.seed is not None:
            problems.append(Problem(event.where, "events: a set event takes at, set, value and "
                                    "until (a ramp); port, fault and seed are a fault's (either "
                                    "one or the other).", "split it into two events."))
            continue
        if event.value is None:
            problems.append(Problem(where, f"events: set {event.set.value} needs a value.",
                                    "give value: the parameter's new value."))
            continue
        start, stop = _window(event, experiment, problems)
        if start is None or stop is None:
            continue
        change = parameter_change(str(event.set.value).strip(), event.value.value, start, comps,
                         experiment, where, problems)
        if change is None:
            continue
        key = (change.comp, change.name)
        before = held.get(key, comps[change.comp].get(change.name))
        held[key] = change.value
        if event.until is None:
            changes.append(change)
        else:
            ramp = _ramp(change, before, stop, experiment, where, problems)
            if ramp is None:
                continue
            changes += ramp
        value = change.value
        marks.append(Mark(start, stop, f"{change.comp}.{change.name}", "set",
                          float(value) if isinstance(value, int | float) else math.nan,
                          change.comp))
    if changes and experiment.algorithm not in FIXED_STEP:
        problems.append(Problem(spec.at("events"), f"events: set events run on the fixed-step "
                                f"masters ({', '.join(FIXED_STEP)}), not on "
                                f"'{experiment.algorithm}' (the adaptive master's steps do not "
                                f"stop at them).", "use algorithm: gauss_seidel or jacobi."))
    return sorted(changes, key=lambda c: c.step), problems, marks


def parameter_change(text: str, value: Any, at: float, comps: dict[str, Component],
            experiment: Experiment | None, where: Any, problems: list[Problem]
            ) -> Change | None:
    """The change `text` = value at time `at` [s] (with no `experiment`, at no step yet: a
    condition event's), or None after its problem."""
    comp_name, _, name = text.rpartition(".")
    comp = comps.get(comp_name)
    if comp is None:
        problems.append(Problem(where, f"events: '{text}' names no component"
                                f"{suggest(comp_name, list(comps))}.", "give comp.parameter."))
        return None
    var = comp.variables.get(name)
    params = list(comp.parameters)
    if var is None:
        problems.append(Problem(where, f"events: '{comp_name}' has no parameter '{name}'"
                                f"{suggest(name, params)}.", f"known: {', '.join(params)}."))
        return None
    if var.kind != "parameter":
        problems.append(Problem(where, f"events: '{text}' is an {var.kind}, not a parameter.",
                                "set a parameter; a port's value is changed with a fault "
                                "(port: ..., fault: stuck_at)."))
        return None
    why = _fixed(comp, name)
    if why:
        problems.append(Problem(where, f"events: '{text}' cannot change during a run: {why}.",
                                "set it before the run (parameters:, --set)."))
        return None
    try:
        coerced = var.coerce(value)
    except (TypeError, ValueError) as err:
        problems.append(Problem(where, f"events: '{text}' cannot take {value!r}: {err}.",
                                "give a value of the parameter's type and range."))
        return None
    if experiment is None:
        return Change(-1, at, comp_name, name, coerced)
    step = math.ceil((at - experiment.start) / experiment.step - 1e-9)
    return Change(step, at, comp_name, name, coerced)


def _time(given: Given[Any]) -> float:
    try:
        return float(given.value)
    except (TypeError, ValueError):
        return math.inf


def _ramp(change: Change, before: Any, until: float, experiment: Experiment, where: Any,
          problems: list[Problem]) -> list[Change] | None:
    """`change` reached linearly from `before` between its time and `until` [s]: a change at
    every base step of the ramp, the last one (the first step at or after `until`) the value
    itself; None after the problem of a parameter that cannot ramp."""
    target = change.value
    if isinstance(target, bool) or not isinstance(target, float) or \
            isinstance(before, bool) or not isinstance(before, int | float):
        problems.append(Problem(where, f"events: {change.comp}.{change.name} cannot ramp: "
                                f"only a Real scalar parameter ramps.", "leave until out (the "
                                "value from `at` on)."))
        return None
    last = math.ceil((until - experiment.start) / experiment.step - 1e-9)
    ramp = []
    for k in range(change.step, last + 1):
        t = experiment.start + k * experiment.step
        share = min(1.0, max(0.0, (t - change.at) / (until - change.at)))
        value = target if k == last else before + (target - before) * share
        ramp.append(dataclasses.replace(change, step=k, value=float(value)))
    return ramp


def _fixed(comp: Component, name: str) -> str:
    """Why parameter `name` of `comp` cannot change during a run ('' when it can)."""
    if name in comp.sizing_parameters:
        return "it sizes the block's ports (it changes the block's ports)"
    if name in comp.construction_parameters:
        return "the block is made from it"
    tunable = getattr(comp, "tunable", None)
    if getattr(comp, "kind", "") == "fmu" and (tunable is None or name not in tunable):
        if tunable is None:
            return ("an FMU in a worker process (isolate: true) takes its parameters only "
                    "before it is initialized (changes during the run not built for it)")
        if getattr(comp, "me", False):
            return ("a model-exchange FMU's parameters are set before it is initialized (a "
                    "tunable one would need an event iteration, not built)")
        return ("the FMU declares it fixed (variability not tunable): it takes it only "
                "before it is initialized")
    if comp.needs_realtime:
        return "the block is hardware in the loop"
    return ""


def apply_change(comp: Component, change: Change) -> None:
    """Set `change` on `comp` during a run; CosimError when it changes the block's ports (their
    sizes or what its outputs depend on)."""
    from twmr.core.component import parameters_changed
    from twmr.core.errors import CosimError

    before = _ports_of(comp)
    comp.set_parameter(change.name, change.value)
    if _ports_of(comp) != before:
        raise CosimError(f"events: setting {change.comp}.{change.name} at t = {change.at:g} s "
                         f"changes the block's ports (their sizes or feedthrough). Fix: set it "
                         f"before the run.")
    parameters_changed(comp)


def _ports_of(comp: Component) -> tuple[Any, ...]:
    return tuple((n, v.size, getattr(v, "depends_on", None))
                 for n, v in comp.variables.items() if v.kind != "parameter")


def _port(event: EventSpec, comps: dict[str, Component], problems: list[Problem]
          ) -> tuple[str, str, bool, int] | None:
    """(component, port, whether an output, the element from 1 or 0 for all) the event names
    ('comp.port' or 'comp.port[i]'); None after its problem."""
    assert event.port is not None
    try:
        comp, port, element = element_of(str(event.port.value), comps)
    except ValueError as err:
        problems.append(Problem(event.port.where, f"events: {err}.", "give comp.port or "
                                "comp.port[i]."))
        return None
    text = f"{comp}.{port}"
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
    width = comps[comp].variables[port].width
    if element > width:
        problems.append(Problem(event.port.where, f"events: '{text}' has {width} element(s); "
                                f"element {element} does not exist.",
                                f"give {text}[1] to {text}[{width}], or {text} for all."))
        return None
    return comp, port, port in comps[comp].outputs, element


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
