"""Subsystems flattened: a nested `ScenarioSpec` -> the flat one the builder reads.

Every block inside a subsystem becomes an instance named by its path (`robot.plant`), every wire
inside one is prefixed the same way, and a wire to or from an exposed port (`robot.pose`) is
rewired to the inner port it names (`robot.plant.pose`), keeping the exposed ports it passes
through (`Via`) so that their declared units take part in the wire's unit conversion. A step
multiple on a subsystem multiplies those of its blocks. The included files' own `experiment:`
and `record:` are not used; their `open:` inputs stay open.

Used on its own, a file's exposed inputs are open inputs (they keep their start values).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Literal

from twmr.core.errors import Location, Problem
from twmr.registry import suggest
from twmr.scenario.graph import End, parse_end
from twmr.scenario.structure import ComponentSpec, Exposure, Given, ScenarioSpec

Side = Literal["src", "dst"]
_WILD = set("*?[")


@dataclass(frozen=True)
class Via:
    """An exposed port a wire passes through: the exposure, its full name ('robot.pose') and
    the elements of it the wire carries (None: all, in order)."""

    exposure: Exposure
    path: str
    index: tuple[int, ...] | None

    def element(self, k: int) -> int:
        """The 0-based element of the exposed port that the wire's k-th element is."""
        return self.index[k] if self.index is not None else k

    def unit(self, k: int) -> str:
        """The declared unit of the wire's k-th element here ('' when none is declared)."""
        unit = self.exposure.unit.value if self.exposure.unit is not None else ""
        if isinstance(unit, str):
            return unit
        i = self.element(k)
        return str(unit[i]) if i < len(unit) else ""


@dataclass(frozen=True)
class Wire(Given[str]):
    """A wire of the flat structure ('robot.plant.pose -> ctrl.pose'), with the exposed ports
    its source passes through (innermost first) and those its destination passes through
    (outermost first)."""

    src_via: tuple[Via, ...] = ()
    dst_via: tuple[Via, ...] = ()


@dataclass(frozen=True)
class Exposed:
    """An exposed port to check against the built components: the inner port it names (flat),
    the exposure, and the exposures below it that the inner end passes through."""

    side: Side
    end: End
    via: Via
    below: tuple[Via, ...]


@dataclass
class _Flat:
    comps: dict[str, ComponentSpec] = field(default_factory=dict)
    wires: list[Given[str]] = field(default_factory=list)
    open: list[Given[str]] = field(default_factory=list)
    exposed: list[Exposed] = field(default_factory=list)
    problems: list[Problem] = field(default_factory=list)
    miswired: set[tuple[str, str]] = field(default_factory=set)


@dataclass(frozen=True)
class Flat:
    """A flattened scenario: the flat structure, the exposed ports to check against the built
    components, the problems found while flattening (wires naming a port no subsystem exposes,
    exposed inputs left unconnected) and the flat inputs of the wires refused."""

    spec: ScenarioSpec
    exposed: tuple[Exposed, ...] = ()
    problems: tuple[Problem, ...] = ()
    miswired: frozenset[tuple[str, str]] = frozenset()


def has_subsystems(spec: ScenarioSpec) -> bool:
    """Whether any component of `spec` is a subsystem."""
    return any(c.system is not None for c in spec.components.values())


def flatten(spec: ScenarioSpec) -> Flat:
    """The flat structure of `spec`, with what the builder checks and reports."""
    out = _Flat()
    _into(spec, "", 1, out)
    for side, name, ex in _exposures(spec):  # the file runs on its own: its inputs are open
        found = _exposure(spec, "", name, ex, side, out)
        if found is not None and side == "dst":
            out.open.append(Given(f"{found.end.comp}.{found.end.port}", ex.where))
    record = spec.record
    if record.signals is not None:
        record = dataclasses.replace(record, signals=tuple(
            _pattern(spec, s) for s in record.signals))
    flat = dataclasses.replace(spec, components=out.comps, connections=tuple(out.wires),
                               open=tuple(out.open), record=record, inputs={}, outputs={})
    return Flat(flat, tuple(out.exposed), tuple(dict.fromkeys(out.problems)),
                frozenset(out.miswired))


def _into(spec: ScenarioSpec, prefix: str, multiple: int, out: _Flat) -> None:
    """Add the blocks, wires and open inputs of `spec` (a subsystem at `prefix`) to `out`."""
    used: set[tuple[str, str]] = set()  # (subsystem, exposed input) driven or opened here
    for name, comp in spec.components.items():
        step = comp.step_multiple
        if multiple != 1:
            step = Given(int(step.value) * multiple, step.where)
        if comp.system is None:
            out.comps[prefix + name] = dataclasses.replace(comp, name=prefix + name,
                                                           step_multiple=step)
            continue
        if comp.body:
            first = next(iter(comp.body.values()))
            out.problems.append(Problem(first.where, f"component '{prefix}{name}' is a "
                                        f"subsystem: its vehicle (body:) is drawn from the "
                                        f"block inside that moves it.",
                                        "give body: on that block in the subsystem's file."))
        _into(comp.system, f"{prefix}{name}.", int(step.value), out)
        for side, port, ex in _exposures(comp.system):
            _exposure(comp.system, f"{prefix}{name}.", port, ex, side, out)
    for given in spec.connections:
        left, _, right = str(given.value).partition("->")
        try:
            ends = parse_end(left), parse_end(right)
        except ValueError:  # the builder reports it, at its line
            out.wires.append(given)
            continue
        src = _resolve(spec, prefix, ends[0], "src", given.where, out)
        dst = _resolve(spec, prefix, ends[1], "dst", given.where, out)
        if dst is not None and dst[1]:
            used.add((ends[1].comp, ends[1].port))
        if src is None or dst is None:
            if dst is not None:
                out.miswired.add((dst[0].comp, dst[0].port))
            continue
        out.wires.append(Wire(f"{_text(src[0])} -> {_text(dst[0])}", given.where,
                              src_via=src[1], dst_via=dst[1]))
    for given in spec.open:
        try:
            end = parse_end(str(given.value))
        except ValueError:
            out.open.append(Given(prefix + str(given.value), given.where))
            continue
        found = _resolve(spec, prefix, end, "dst", given.where, out)
        if found is not None:
            used.add((end.comp, end.port))
            text = str(given.value)
            elements = text[text.index("["):] if "[" in text else ""  # 'lag.u[3]' keeps [3]
            out.open.append(Given(f"{found[0].comp}.{found[0].port}{elements}", given.where))
    for ex in spec.inputs.values():  # an input exposed again from here is connected outside
        try:
            end = parse_end(ex.port.value)
        except ValueError:
            continue
        used.add((end.comp, end.port))
    for name, comp in spec.components.items():
        for port, ex in (comp.system.inputs if comp.system is not None else {}).items():
            if (name, port) not in used:
                out.problems.append(Problem(
                    comp.where, f"exposed input '{prefix}{name}.{port}' (the subsystem's "
                    f"{ex.port.value}, {ex.where}) is not connected.",
                    f"wire an output to it ('x.y -> {name}.{port}'), or list '{name}.{port}' "
                    f"under 'open:' to keep the start value of {ex.port.value}."))


def _exposures(spec: ScenarioSpec) -> list[tuple[Side, str, Exposure]]:
    """(side, name, exposure) of every port `spec` exposes: inputs are wires' destinations."""
    return [*(("dst", n, e) for n, e in spec.inputs.items()),
            *(("src", n, e) for n, e in spec.outputs.items())]


def _exposure(spec: ScenarioSpec, prefix: str, name: str, ex: Exposure, side: Side,
              out: _Flat) -> Exposed | None:
    """Resolve one exposed port of `spec` (at `prefix`) and add it to the ports to check."""
    try:
        end = parse_end(ex.port.value)
    except ValueError as err:
        out.problems.append(Problem(ex.port.where, f"exposed {_noun(side)} '{prefix}{name}': "
                                    f"{err}.", "name an inner port: 'plant.pose', or "
                                    "'plant.pose[1:2]' for some of its elements."))
        return None
    found = _resolve(spec, prefix, end, side, ex.port.where, out)
    if found is None:
        return None
    exposed = Exposed(side, found[0], Via(ex, prefix + name, None), found[1])
    out.exposed.append(exposed)
    return exposed


def _resolve(spec: ScenarioSpec, prefix: str, end: End, side: Side, loc: Location,
             out: _Flat) -> tuple[End, tuple[Via, ...]] | None:
    """(the flat end, the exposed ports passed through) of a wire's end written in `spec`, or
    None after adding the problem."""
    if "." in end.comp and end.comp not in spec.components:  # (a flat 'sub.comp' is a block)
        parts = f"{end.comp}.{end.port}".split(".")
        for k in range(len(parts) - 2, 0, -1):  # a dotted port of a block: 'a.CanChannel.Tx'
            named = spec.components.get(".".join(parts[:k]))
            if named is not None and named.system is None:
                port = ".".join(parts[k:])
                return End(prefix + named.name, port, end.index, prefix + end.text), ()
        owner = end.comp.split(".")[0]
        out.problems.append(Problem(loc, f"'{end.text}' reaches inside the subsystem "
                                    f"'{prefix}{owner}': a wire names a block of its own file, "
                                    f"or a port a subsystem exposes.",
                                    f"expose the port in the subsystem's file ('outputs:' or "
                                    f"'inputs:') and wire {owner}.<name>."))
        return None
    comp = spec.components.get(end.comp)
    if comp is None or comp.system is None:
        return End(prefix + end.comp, end.port, end.index, prefix + end.text), ()
    inner = comp.system
    ports = inner.outputs if side == "src" else inner.inputs
    here = f"{prefix}{end.comp}"
    ex = ports.get(end.port)
    if ex is None:
        other = inner.inputs if side == "src" else inner.outputs
        also = f" ('{end.port}' is one of its {_noun('dst' if side == 'src' else 'src')}s)" \
            if end.port in other else ""
        out.problems.append(Problem(loc, f"the subsystem '{here}' ({inner.source}) exposes no "
                                    f"{_noun(side)} '{end.port}'{also}"
                                    f"{suggest(end.port, list(ports))}.",
                                    f"its {_noun(side)}s: {', '.join(ports) or '(none)'}; "
                                    f"expose more under '{_noun(side)}s:' in {inner.source}."))
        return None
    try:
        inner_end = parse_end(ex.port.value)
    except ValueError:  # reported once, where the exposure is checked
        return None
    index = _compose(inner_end.index, end.index)
    if index is None and inner_end.index is not None and end.index is not None:
        out.problems.append(Problem(loc, f"'{end.text}' selects element {max(end.index) + 1} "
                                    f"but the exposed {_noun(side)} '{here}.{end.port}' "
                                    f"({ex.port.value}) has {len(inner_end.index)}.",
                                    f"select elements 1..{len(inner_end.index)}."))
        return None
    found = _resolve(inner, here + ".", dataclasses.replace(inner_end, index=index), side,
                     ex.port.where, out)
    if found is None:
        return None
    via = Via(ex, f"{here}.{end.port}", end.index)
    return found[0], (*found[1], via) if side == "src" else (via, *found[1])


def _compose(inner: tuple[int, ...] | None, outer: tuple[int, ...] | None
             ) -> tuple[int, ...] | None:
    """The inner port's elements that selection `outer` of an exposure of `inner` names (None
    when `outer` goes beyond `inner`, or when both select everything)."""
    if outer is None:
        return inner
    if inner is None:
        return outer
    return tuple(inner[k] for k in outer) if max(outer) < len(inner) else None


def _pattern(spec: ScenarioSpec, given: Given[Any]) -> Given[Any]:
    """A record pattern naming an exposed port ('robot.pose') as the inner port it is."""
    text = str(given.value)
    if _WILD & set(text):
        return given
    try:
        end = parse_end(text)
    except ValueError:
        return given
    comp = spec.components.get(end.comp)
    if comp is None or comp.system is None or end.index is not None:
        return given
    side: Side = "src" if end.port in comp.system.outputs else "dst"
    probe = _Flat()
    found = _resolve(spec, "", end, side, given.where, probe)
    if found is None or found[0].index is not None:
        return given
    return Given(f"{found[0].comp}.{found[0].port}", given.where)


def _text(end: End) -> str:
    sel = "" if end.index is None else "[" + ",".join(str(i + 1) for i in end.index) + "]"
    return f"{end.comp}.{end.port}{sel}"


def _noun(side: Side) -> str:
    return "output" if side == "src" else "input"
