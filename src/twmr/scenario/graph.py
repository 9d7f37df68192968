"""The scenario as a graph: wires resolved and checked, execution order, algebraic loops.

Checks: ports exist (with "did you mean"), a wire goes from an output to an input, every input is
driven exactly once (or listed in `open:`), sizes and types agree after element selection, units
are compatible; a scale between compatible units (mm -> m, deg -> rad) becomes a gain folded into
the wire once, here. The Gauss-Seidel order is topological over the direct-feedthrough edges; a
cycle of such edges is an algebraic loop, reported with the cycle printed.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

from twmr.core.component import Component
from twmr.core.errors import Location, Problem, UnitError
from twmr.core.port import Variable
from twmr.core.units import conversion
from twmr.registry import suggest
from twmr.scenario.system import Connection

_END = re.compile(r"^\s*([A-Za-z_]\w*)\.([A-Za-z_][\w]*)\s*(\[\s*([0-9:,\s]+)\s*\])?\s*$")


@dataclass(frozen=True)
class End:
    """One end of a wire as written: instance, port, 0-based selected elements (None = all)."""

    comp: str
    port: str
    index: tuple[int, ...] | None
    text: str


def parse_end(text: str) -> End:
    """'plant.pose[1:2]' -> End('plant', 'pose', (0, 1)). ValueError with a plain message."""
    m = _END.match(text)
    if not m:
        raise ValueError(f"'{text.strip()}' is not of the form component.port or "
                         f"component.port[i] / [i:j] / [i,j]")
    index = None
    if m.group(4):
        index = []
        for part in m.group(4).split(","):
            a, sep, b = part.strip().partition(":")
            lo, hi = int(a), int(b) if sep else int(a)
            if lo < 1 or hi < lo:
                raise ValueError(f"element selection [{m.group(4)}] must be 1-based and "
                                 f"increasing, e.g. [1:2]")
            index.extend(range(lo - 1, hi))
        index = tuple(index)
    return End(m.group(1), m.group(2), index, text.strip())


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
    if var is None or var.kind == "parameter":
        ports = [n for n, v in comp.variables.items() if v.kind in ("input", "output")]
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


def wire(comps: dict[str, Component], src: End, dst: End, loc: Location,
         problems: list[Problem]) -> list[Connection]:
    """Checked Connection(s) for one wire (split per element when units need per-element gains)."""
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
    if a.type != b.type and not (a.type in ("Integer", "Boolean") and b.type == "Real"):
        problems.append(Problem(loc, f"type mismatch: '{src.text}' is {a.type}, '{dst.text}' is "
                                f"{b.type}.", "connect ports of the same type."))
        return []
    gains = []
    for i, j in zip(sidx, didx):
        su, du = a.element_unit(i), b.element_unit(j)
        if not su or not du:  # unspecified on one side (a generic block): no check, no scale
            gains.append((1.0, 0.0))
            continue
        try:
            gains.append(conversion(su, du))
        except UnitError:
            problems.append(Problem(
                loc, f"unit mismatch: '{src.comp}.{src.port}' element {i + 1} is in '{su}' but "
                f"'{dst.comp}.{dst.port}' element {j + 1} expects '{du}'; these units measure "
                f"different quantities.", "connect a port that measures the same quantity, or "
                "fix the unit declared by one of the components."))
            return []
    if len(set(gains)) == 1:
        g, o = gains[0]
        return [Connection(src.comp, src.port, dst.comp, dst.port, src.index, dst.index, g, o,
                           loc)]
    return [Connection(src.comp, src.port, dst.comp, dst.port, (i,), (j,), g, o, loc)
            for (i, j), (g, o) in zip(zip(sidx, didx), gains)]


def feedthrough_edges(comps: dict[str, Component], conns: list[Connection]
                      ) -> dict[str, dict[str, tuple[str, str]]]:
    """Component-level edges src -> dst when the wire ends at an input some output of dst depends
    on directly; value: (src output, dst input) for printing the cycle."""
    edges: dict[str, dict[str, tuple[str, str]]] = {n: {} for n in comps}
    for c in conns:
        dst = comps[c.dst]
        if any(c.dst_port in o.depends_on for o in dst.outputs.values()):
            edges[c.src].setdefault(c.dst, (c.src_port, c.dst_port))
    return edges


def order(comps: dict[str, Component], conns: list[Connection]) -> tuple[list[str], list[str]]:
    """(execution order, cycle) — a topological order stable in declaration order, or the nodes of
    one cycle of direct-feedthrough edges (order then empty)."""
    edges = feedthrough_edges(comps, conns)
    indeg = {n: 0 for n in comps}
    for src in edges:
        for dst in edges[src]:
            indeg[dst] += 1
    names = list(comps)
    done: list[str] = []
    ready = [n for n in names if indeg[n] == 0]
    while ready:
        n = ready.pop(0)
        done.append(n)
        for dst in edges[n]:
            indeg[dst] -= 1
            if indeg[dst] == 0:
                ready.append(dst)
                ready.sort(key=names.index)
    if len(done) == len(names):
        return done, []
    return [], _cycle(edges, [n for n in names if n not in done])


def _cycle(edges: dict[str, dict[str, tuple[str, str]]], rest: list[str]) -> list[str]:
    """One cycle among the nodes left after the topological sort, as a closed walk."""
    node, seen = rest[0], []
    while node not in seen:
        seen.append(node)
        node = next(d for d in edges[node] if d in rest)
    return seen[seen.index(node):] + [node]


def describe_cycle(edges: dict[str, dict[str, tuple[str, str]]], cycle: list[str]) -> str:
    """'a.y -> b.u -> b.y -> a.u' for a cycle [a, b, a]."""
    parts = []
    for a, b in zip(cycle, cycle[1:]):
        out, inp = edges[a][b]
        parts.append(f"{a}.{out} -> {b}.{inp}")
    return " => ".join(parts)
