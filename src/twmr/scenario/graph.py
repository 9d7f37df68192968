"""The scenario as a graph: wires resolved and checked, execution order, algebraic loops.

Checks: ports exist (with "did you mean"), a wire goes from an output to an input, every input is
driven exactly once (or listed in `open:`), sizes and types agree after element selection, units
are compatible; a scale between compatible units (mm -> m, deg -> rad) becomes a gain folded into
the wire once, here. The graph is port-level, as in Drake: a wire links an output to an input, and
inside a component an input links to exactly the outputs that declare it in `depends_on`. The
Gauss-Seidel plan is topological over that graph; a cycle of it is an algebraic loop, reported
with the cycle printed, or (`experiment.loops: solve`) one strongly connected part of the graph,
torn at some of its inputs and iterated by the master (`find_loops`, `twmr.master.loops`).
"""
from __future__ import annotations

import functools
import heapq
import itertools
import logging
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from twmr.core.component import Component
from twmr.core.errors import Location, Problem, UnitError
from twmr.core.port import Variable
from twmr.core.units import conversion, known_unit
from twmr.registry import suggest
from twmr.scenario.system import Connection

if TYPE_CHECKING:
    from twmr.scenario.flatten import Via

log = logging.getLogger("twmr")

#: the most elements one end of a wire may select
MAX_SELECTED = 1_000_000
_END = re.compile(r"^\s*([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)\.([A-Za-z_]\w*)\s*"
                  r"(\[\s*([0-9:,\s]+)\s*\])?\s*$")


@dataclass(frozen=True)
class End:
    """One end of a wire as written: instance, port, 0-based selected elements (None = all)."""

    comp: str
    port: str
    index: tuple[int, ...] | None
    text: str


def parse_end(text: str) -> End:
    """'plant.pose[1:2]' -> End('plant', 'pose', (0, 1)); the last dot separates the port
    ('robot.plant.pose' -> End('robot.plant', 'pose', None)). ValueError with a plain message."""
    m = _END.match(text)
    if not m:
        raise ValueError(f"'{text.strip()}' is not of the form component.port or "
                         f"component.port[i] / [i:j] / [i,j]")
    if not m.group(4):
        return End(m.group(1), m.group(2), None, text.strip())
    index: list[int] = []
    for part in m.group(4).split(","):
        a, sep, b = part.strip().partition(":")
        lo, hi = int(a), int(b) if sep else int(a)
        if lo < 1 or hi < lo:
            raise ValueError(f"element selection [{m.group(4)}] must be 1-based and "
                             f"increasing, e.g. [1:2]")
        if len(index) + hi - lo + 1 > MAX_SELECTED:
            raise ValueError(f"element selection [{m.group(4).strip()}] names "
                             f"{len(index) + hi - lo + 1:,} elements, more than the "
                             f"{MAX_SELECTED:,} one wire may select (element {hi:,} is beyond "
                             f"any port's size)")
        index.extend(range(lo - 1, hi))
    return End(m.group(1), m.group(2), tuple(index), text.strip())


def resolve_end(comps: dict[str, Component], end: End) -> End:
    """`end` with the component's name found among dotted names: 'a.CanChannel.Tx_Data' is
    port 'CanChannel.Tx_Data' of 'a' when there is no component 'a.CanChannel' (FMI
    structured names); the longest component name that matches wins."""
    if end.comp in comps:
        return end
    parts = f"{end.comp}.{end.port}".split(".")
    for k in range(len(parts) - 2, 0, -1):
        comp, port = ".".join(parts[:k]), ".".join(parts[k:])
        if comp in comps:
            return End(comp, port, end.index, end.text)
    return end


def element_of(text: str, comps: dict[str, Component]) -> tuple[str, str, int]:
    """(component, port, element from 1 or 0 for the whole port) of 'comp.port' or
    'comp.port[i]', the component found among dotted names (`resolve_end`); ValueError when
    it is not of that form or selects more than one element."""
    end = resolve_end(comps, parse_end(text))
    if end.index is not None and len(end.index) != 1:
        raise ValueError(f"'{end.text}' selects {len(end.index)} elements: name one "
                         f"(comp.port[i]) or the whole port")
    return end.comp, end.port, end.index[0] + 1 if end.index else 0


def terminal_wires(comps: dict[str, Component], src: End, dst: End, loc: Location,
                   problems: list[Problem]) -> list[tuple[End, End]] | None:
    """The member wires of a wire between two bus terminals (each Tx member of one to the Rx
    member of the other, both ways); None when neither end is a terminal; [] after adding a
    problem (one end a terminal, the other not)."""
    ta = comps[src.comp].terminals.get(src.port) if src.comp in comps else None
    tb = comps[dst.comp].terminals.get(dst.port) if dst.comp in comps else None
    if ta is None and tb is None and not (src.comp in comps and dst.comp in comps and
                                          src.port not in comps[src.comp].variables and
                                          dst.port not in comps[dst.comp].variables):
        return None
    try:
        if ta is None and src.comp in comps and src.index is None:
            ta = comps[src.comp].open_terminal(src.port, comps[dst.comp], dst.port)
        if tb is None and ta is not None and dst.comp in comps and dst.index is None:
            tb = comps[dst.comp].open_terminal(dst.port, comps[src.comp], src.port)
        if ta is None and tb is None:
            return None
    except ValueError as err:
        problems.append(Problem(loc, f"'{src.text} -> {dst.text}': {err}.",
                                "wire each participant's terminal to a terminal of its own on "
                                "one bus block, e.g. 'ecu.CanChannel -> bus.ecu'."))
        return []
    if ta is None or tb is None or src.index is not None or dst.index is not None:
        term, other = (src, dst) if ta is not None else (dst, src)
        what = "a bus terminal" if (tb if ta is not None else ta) is not None else \
            "not a bus terminal"
        problems.append(Problem(loc, f"'{term.text}' is a bus terminal of '{term.comp}' and "
                                f"'{other.text}' is {what} (or an element of one): a terminal is "
                                f"wired to a whole terminal.", "wire two terminals, e.g. "
                                "'ecu.CanChannel -> bus.ecu'."))
        return []
    pairs = []
    for (x, tx), (y, ty) in (((src, ta), (dst, tb)), ((dst, tb), (src, ta))):
        for member in ("Tx_Data", "Tx_Clock"):
            peer = member.replace("Tx_", "Rx_")
            if member in tx and peer in ty:
                pairs.append((End(x.comp, tx[member], None, f"{x.text}.{member}"),
                              End(y.comp, ty[peer], None, f"{y.text}.{peer}")))
    return pairs


def find_port(comps: dict[str, Component], end: End, loc: Location,
              problems: list[Problem]) -> Variable | None:
    """The variable an end names, or None after adding a problem."""
    comp = comps.get(end.comp)
    if comp is None:
        problems.append(Problem(loc, f"no component '{end.comp}' in '{end.text}'"
                                f"{suggest(end.comp, list(comps))}.",
                                f"use one of: {', '.join(comps)}."))
        return None
    var = comp.variables.get(end.port)
    if var is None and end.port in comp.aliases:
        base = comp.aliases[end.port]
        parameter = getattr(comp.variables.get(base), "kind", "") == "parameter"
        problems.append(Problem(loc, f"'{end.comp}.{end.port}' is an alias of "
                                f"{'parameter ' if parameter else ''}'{end.comp}.{base}' (one "
                                f"variable of the FMU under two names), not a port.",
                                f"set '{base}' under 'parameters:' (parameters are not wired)."
                                if parameter else f"wire '{end.comp}.{base}'."))
        return None
    if var is None or var.kind == "parameter":
        ports = [n for n, v in comp.variables.items() if v.kind in ("input", "output", "state")]
        problems.append(Problem(loc, f"component '{end.comp}' ({type(comp).__name__}) has no port "
                                f"'{end.port}'{suggest(end.port, ports)}.",
                                f"its ports are: {', '.join(ports)}."))
        return None
    if end.index is not None and max(end.index) >= var.width:
        problems.append(Problem(loc, f"'{end.text}' selects element {max(end.index) + 1} but "
                                f"'{end.comp}.{end.port}' has {var.width}.",
                                f"select elements 1..{var.width}."))
        return None
    return var


@dataclass(frozen=True)
class _Node:
    """One unit on a wire's way: an end's element, or an exposed port's declared unit."""

    unit: str
    definitions: dict[str, Any] | None
    port: str
    element: int
    end: End | None = None


def _leg(x: _Node, y: _Node, comps: dict[str, Component], loc: Location,
         problems: list[Problem], unitless: list[str]) -> tuple[float, float] | None:
    """(gain, offset) from unit `x` to unit `y`, or None after adding the problem."""
    su, du = x.unit, y.unit
    if not su or not du:  # unspecified on one side: no check, no scale
        for node, unit, other in ((x, su, du), (y, du, su)):
            if node.end is not None and not unit and other and \
                    not getattr(comps[node.end.comp], "generic_units", True):
                unitless.append(f"'{node.port}' declares no unit but is wired to '{other}'")
        return 1.0, 0.0
    ua, ub = known_unit(su, x.definitions), known_unit(du, y.definitions)
    if ua is None or ub is None:
        if su == du:  # the same unit, though not one we can convert: pass as is
            return 1.0, 0.0
        unknown = [f"'{u}' ('{n.port}')" for u, n, k in ((su, x, ua), (du, y, ub)) if k is None]
        problems.append(Problem(
            loc, f"unit mismatch: '{x.port}' element {x.element + 1} is in '{su}' and "
            f"'{y.port}' element {y.element + 1} in '{du}', and {' and '.join(unknown)} "
            f"is neither a Modelica unit nor defined with a BaseUnit in the FMU's "
            f"UnitDefinitions, so no conversion between them is known.",
            "use the same unit string at both ends, or give the unit a BaseUnit in the FMU's "
            "UnitDefinitions."))
        return None
    try:
        return conversion(ua, ub)
    except UnitError:
        problems.append(Problem(
            loc, f"unit mismatch: '{x.port}' element {x.element + 1} is in '{su}' but "
            f"'{y.port}' element {y.element + 1} expects '{du}'; these units measure "
            f"different quantities.", "connect a port that measures the same quantity, or "
            "fix the unit declared by one of the components."))
        return None


def wire(comps: dict[str, Component], src: End, dst: End, loc: Location,
         problems: list[Problem], src_via: Sequence[Via] = (), dst_via: Sequence[Via] = ()
         ) -> list[Connection]:
    """Checked Connection(s) for one wire (split per element when units need per-element gains);
    the units declared by the exposed ports it passes through (`src_via` innermost first,
    `dst_via` outermost first, `twmr.scenario.flatten`) are steps of its conversion."""
    a = find_port(comps, src, loc, problems)
    b = find_port(comps, dst, loc, problems)
    if a is None or b is None:
        return []
    fix_dir = "write it as '<output> -> <input>'."
    if a.kind not in ("output", "state"):
        what = "an input" if a.kind == "input" else f"a {a.kind}"
        problems.append(Problem(loc, f"'{src.text}' is {what} of '{src.comp}', so it cannot drive "
                                f"'{dst.text}': a wire starts at an output.", fix_dir))
        return []
    if b.kind != "input":
        what = "an output" if b.kind in ("output", "state") else f"a {b.kind}"
        problems.append(Problem(loc, f"'{dst.text}' is {what} of '{dst.comp}': outputs cannot be "
                                f"driven (output-to-output).", fix_dir))
        return []
    sidx = src.index if src.index is not None else tuple(range(a.width))
    didx = dst.index if dst.index is not None else tuple(range(b.width))
    if len(sidx) != len(didx):
        problems.append(Problem(loc, f"size mismatch: '{src.text}' gives {len(sidx)} value(s), "
                                f"'{dst.text}' takes {len(didx)}.",
                                "select matching elements, e.g. 'plant.pose[1:2] -> x.xy'."))
        return []
    if (a.type == "Clock") != (b.type == "Clock"):
        clock, other = (src, dst) if a.type == "Clock" else (dst, src)
        problems.append(Problem(loc, f"'{clock.text}' is a clock and '{other.text}' is a "
                                f"{(b if a.type == 'Clock' else a).type} port: a clock carries "
                                f"ticks, not values.", "wire a clock to a clock (type Clock), "
                                "and a clocked variable to a variable of its type."))
        return []
    if a.type != b.type and not (a.type in ("Integer", "Boolean") and b.type == "Real"):
        problems.append(Problem(loc, f"type mismatch: '{src.text}' is {a.type}, '{dst.text}' is "
                                f"{b.type}.", "connect ports of the same type."))
        return []
    gains = []
    unitless: list[str] = []
    for k, (i, j) in enumerate(zip(sidx, didx, strict=False)):
        nodes = [_Node(a.element_unit(i), a.unit_definitions, f"{src.comp}.{src.port}", i, src),
                 *(_Node(v.unit(k), None, v.path, v.element(k)) for v in (*src_via, *dst_via)
                   if v.unit(k)),
                 _Node(b.element_unit(j), b.unit_definitions, f"{dst.comp}.{dst.port}", j, dst)]
        found = [_leg(x, y, comps, loc, problems, unitless) for x, y in itertools.pairwise(nodes)]
        legs = [leg for leg in found if leg is not None]
        if len(legs) != len(found):
            return []
        g, o = legs[0]
        for lg, lo in legs[1:]:
            g, o = lg * g, lg * o + lo
        gains.append((g, o))
    if unitless:
        log.warning("%s: %s; the value passes unconverted. Fix: check both ends measure the "
                    "same quantity in the same unit.", loc, "; ".join(dict.fromkeys(unitless)))
    if len(set(gains)) == 1:
        g, o = gains[0]
        return [Connection(src.comp, src.port, dst.comp, dst.port, src.index, dst.index, g, o,
                           loc)]
    return [Connection(src.comp, src.port, dst.comp, dst.port, (i,), (j,), g, o, loc)
            for (i, j), (g, o) in zip(zip(sidx, didx, strict=False), gains, strict=False)]


Port = tuple[str, str]
#: one action of a communication point: ("write", instance, input) or ("evaluate", instance, "")
Action = tuple[str, str, str]


def port_edges(comps: dict[str, Component], conns: list[Connection]) -> dict[Port, list[Port]]:
    """The port-level dependency graph (as Drake's): a wire is an edge from an output to an input;
    inside a component, an edge from an input to exactly the outputs that list it in
    `depends_on`. Nodes are every input and output of every component."""
    edges: dict[Port, list[Port]] = {}
    for name, comp in comps.items():
        for port, var in comp.variables.items():
            if var.kind in ("input", "output", "state"):
                edges[(name, port)] = []
        for port, var in comp.outputs.items():
            for dep in var.depends_on:
                edges[(name, dep)].append((name, port))
    for c in conns:
        succ = edges[(c.src, c.src_port)]
        if (c.dst, c.dst_port) not in succ:
            succ.append((c.dst, c.dst_port))
    return edges


def _topological(comps: dict[str, Component], edges: dict[Port, list[Port]]
                 ) -> tuple[list[Port], list[Port]]:
    """Ports in a topological order, stable in declaration order (component, then port), and
    the ports left over when there is a cycle."""
    rank = {node: i for i, node in enumerate(edges)}
    indeg = dict.fromkeys(edges, 0)
    for succ in edges.values():
        for node in succ:
            indeg[node] += 1
    ready = [rank[n] for n, d in indeg.items() if d == 0]
    heapq.heapify(ready)
    nodes = list(edges)
    done: list[Port] = []
    while ready:
        node = nodes[heapq.heappop(ready)]
        done.append(node)
        for nxt in edges[node]:
            indeg[nxt] -= 1
            if indeg[nxt] == 0:
                heapq.heappush(ready, rank[nxt])
    return done, [n for n in nodes if indeg[n] > 0]


@dataclass(frozen=True)
class Loop:
    """An algebraic loop to solve at each communication point (`experiment.loops: solve`): the
    ports of one strongly connected part of the port graph in the order of one pass through it,
    the inputs torn open (`tears`: their values are the unknowns of the iteration) and the writes
    and evaluations of that pass with the torn inputs held (`body`, the tears' own writes not
    included)."""

    ports: tuple[Port, ...]
    tears: tuple[Port, ...]
    body: tuple[Action, ...]

    @property
    def components(self) -> tuple[str, ...]:
        """The components the loop runs through, in the order of one pass."""
        return tuple(dict.fromkeys(n for n, _ in self.ports))


def strongly_connected(edges: dict[Port, list[Port]]) -> list[list[Port]]:
    """The strongly connected parts of a graph (Tarjan's algorithm, without recursion), each
    part a list of nodes; every node of `edges` is a key."""
    index: dict[Port, int] = {}
    low: dict[Port, int] = {}
    stack: list[Port] = []
    on_stack: set[Port] = set()
    parts: list[list[Port]] = []
    for root in edges:
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        work = [(root, iter(edges[root]))]
        while work:
            node, succ = work[-1]
            for nxt in succ:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(edges[nxt])))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    part: list[Port] = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        part.append(member)
                        if member == node:
                            break
                    parts.append(part)
    return parts


def _restrict(edges: dict[Port, list[Port]], nodes: Sequence[Port], cut: Sequence[Port]
              ) -> dict[Port, list[Port]]:
    """The subgraph on `nodes` (in their order) without the edges into the `cut` nodes."""
    keep, removed = set(nodes), set(cut)
    return {n: [m for m in edges[n] if m in keep and m not in removed] for n in nodes}


def _tear(comps: dict[str, Component], edges: dict[Port, list[Port]], nodes: list[Port]
          ) -> tuple[list[Port], list[Port]]:
    """(tears, []): Real inputs among `nodes` (a strongly connected part) whose incoming wires,
    cut, leave no cycle — chosen greedily, the input on most paths (in x out edges) of each
    remaining cycle first; or ([], a cycle that passes through no Real input)."""
    tears: list[Port] = []
    while True:
        sub = _restrict(edges, nodes, tears)
        cyclic = [set(p) for p in strongly_connected(sub) if len(p) > 1]
        if not cyclic:
            return tears, []
        for part in cyclic:
            candidates = [n for n in nodes if n in part and
                          comps[n[0]].variables[n[1]].kind == "input" and
                          comps[n[0]].variables[n[1]].type == "Real"]
            if not candidates:
                return [], _cycle(sub, [n for n in nodes if n in part])

            tears.append(max(candidates, key=functools.partial(_paths, part=part, graph=sub)))


def _paths(node: Port, part: set[Port], graph: dict[Port, list[Port]]) -> int:
    """Edges into `node` from `part` times edges from it into `part`."""
    into = sum(node in graph[m] for m in part)
    return into * sum(m in part for m in graph[node])


def find_loops(comps: dict[str, Component], conns: list[Connection]
               ) -> tuple[list[Loop], list[list[Port]]]:
    """(the algebraic loops of the port graph, in declaration order, each torn at Real inputs;
    the cycles that cannot be torn so, each as a closed walk of ports)."""
    edges = port_edges(comps, conns)
    rank = {node: i for i, node in enumerate(edges)}
    loops: list[Loop] = []
    stuck: list[list[Port]] = []
    parts = sorted((p for p in strongly_connected(edges) if len(p) > 1),
                   key=lambda p: min(rank[n] for n in p))
    for part in parts:
        members = set(part)
        nodes = [n for n in edges if n in members]
        tears, cycle = _tear(comps, edges, nodes)
        if cycle:
            stuck.append(cycle)
            continue
        ordered, _ = _topological(comps, _restrict(edges, nodes, tears))
        driven = {n for n in nodes if comps[n[0]].variables[n[1]].kind == "input"} - set(tears)
        loops.append(Loop(tuple(ordered), tuple(tears), tuple(_actions(comps, ordered, driven))))
    return loops, stuck


def _condensed(comps: dict[str, Component], edges: dict[Port, list[Port]],
               loops: Sequence[Loop]) -> list[Port | int]:
    """The ports in a topological order in which each loop's ports are one node, given as the
    loop's index; stable in declaration order."""
    group = {p: ("#loop", str(k)) for k, lp in enumerate(loops) for p in lp.ports}
    graph: dict[Port, list[Port]] = {}
    for node in edges:
        graph.setdefault(group.get(node, node), [])
    for node, succ in edges.items():
        a = group.get(node, node)
        graph[a] = list(dict.fromkeys([*graph[a], *(b for m in succ
                                                    if (b := group.get(m, m)) != a)]))
    ordered, _ = _topological(comps, graph)
    return [int(k) if g == "#loop" else (g, k) for g, k in ordered]


def _actions(comps: dict[str, Component], items: Sequence[Port | int], driven: set[Port],
             loops: Sequence[Loop] = (), feeding: set[Port] | None = None) -> list[Action]:
    """The writes and evaluations of ports visited in the order `items` (a loop's index: its
    solution, ("loop", index, ""), after which its components are final). With `feeding` (the
    outputs wired to an input), an output that feeds nothing and depends on no driven input
    evaluates nothing where it is visited: its value is the same wherever its component is
    evaluated in the point."""
    plan: list[Action] = []
    evaluated: set[str] = set()
    written: dict[str, set[str]] = {name: set() for name in comps}
    for item in items:
        if isinstance(item, int):
            plan.append(("loop", str(item), ""))
            for name in loops[item].components:
                evaluated.add(name)
                written[name].clear()
            continue
        name, port = item
        var = comps[name].variables[port]
        deps = getattr(var, "depends_on", ())
        if var.kind == "input":
            if item in driven:
                plan.append(("write", name, port))
                written[name].add(port)
        elif deps and (name not in evaluated or written[name] & set(deps)) and not (
                feeding is not None and item not in feeding and
                not any((name, d) in driven for d in deps)):
            plan.append(("evaluate", name, ""))
            evaluated.add(name)
            written[name].clear()
    return plan


def evaluation_plan(comps: dict[str, Component], conns: list[Connection],
                    loops: Sequence[Loop] = ()) -> tuple[list[Action], list[Port]]:
    """(actions of one Gauss-Seidel communication point, cycle).

    Ports are visited in topological order: a connected input is written once its sources are
    final; a component is evaluated when one of its feedthrough outputs is reached and it has not
    been evaluated at this point yet, or an input that output depends on was written since (an
    output that feeds nothing and depends on no wired input evaluates nothing: its component is
    evaluated later in the point, at the latest at its end). So a
    component is evaluated twice in a point when the wiring runs through it twice (y1 = f(u1)
    feeds a block that drives u2, and y2 = g(u2)). Each of `loops` (`find_loops`) is one node of
    that order, ("loop", index, ""): solved once everything it reads is final. With a cycle
    that is not one of `loops`, the plan is empty and the cycle is returned as a closed walk of
    ports."""
    edges = port_edges(comps, conns)
    items: list[Port | int]
    if loops:
        items = _condensed(comps, edges, loops)
    else:
        ordered, rest = _topological(comps, edges)
        if rest:
            return [], _cycle(edges, rest)
        items = list(ordered)
    driven = {(c.dst, c.dst_port) for c in conns}
    plan = _actions(comps, items, driven, loops, {(c.src, c.src_port) for c in conns})
    evaluated = {name for action, name, _ in plan if action == "evaluate"}
    evaluated |= {name for lp in loops for name in lp.components}
    # feedthrough blocks whose outputs depend on nothing wired, or feed nothing
    for name, comp in comps.items():
        if comp.has_feedthrough and name not in evaluated:
            plan.append(("evaluate", name, ""))
    return plan, []


def order(comps: dict[str, Component], conns: list[Connection], loops: Sequence[Loop] = ()
          ) -> tuple[list[str], list[Port]]:
    """(component order, cycle): components in the topological order of their outputs (a source
    before what it feeds; the ports of each of `loops` in the order of one pass), then those
    without outputs in declaration order; with a cycle of ports that is not one of `loops`,
    ([], cycle)."""
    edges = port_edges(comps, conns)
    if loops:
        ordered = [p for item in _condensed(comps, edges, loops)
                   for p in (loops[item].ports if isinstance(item, int) else (item,))]
    else:
        ordered, rest = _topological(comps, edges)
        if rest:
            return [], _cycle(edges, rest)
    outputs = [n for n, p in ordered if comps[n].variables[p].kind != "input"]
    return list(dict.fromkeys(outputs + list(comps))), []


def _cycle(edges: dict[Port, list[Port]], rest: list[Port]) -> list[Port]:
    """One cycle among the ports left after the topological sort, as a closed walk."""
    left = set(rest)
    node, seen = rest[0], []
    while node not in seen:
        seen.append(node)
        node = next(d for d in edges[node] if d in left)
    loop = seen[seen.index(node):]
    # start at an output (its successor lies in another component), so it reads out -> in => out
    first = next((i for i, p in enumerate(loop) if loop[(i + 1) % len(loop)][0] != p[0]), 0)
    loop = loop[first:] + loop[:first]
    return [*loop, loop[0]]


def describe_cycle(cycle: list[Port]) -> str:
    """'a.y -> b.u => b.y -> a.u' for a closed walk of ports: '->' a wire, '=>' a direct
    feedthrough inside a component."""
    text = f"{cycle[0][0]}.{cycle[0][1]}"
    for (a, _), (b, q) in itertools.pairwise(cycle):
        text += f" {'=>' if a == b else '->'} {b}.{q}"
    return text
