"""`twmr diagram`: a built scenario drawn as SVG — each block with its kind, step number and ports
with their units, each wire from output to input (unit conversions in its tooltip), wires that
feed back against the step order dashed, wires of algebraic loops in red, and the blocks of each
subsystem framed — or, for a subsystem named in `closed`, drawn as one block whose ports are the
inner ports its wires cross. Laid out in layers: a block sits one layer right of the blocks that
feed it forward in the step order, and the blocks of a layer are ordered to cross fewer wires
(the barycentre heuristic of layered graph drawing). Every text from the scenario is escaped."""
from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field
from html import escape
from typing import Any

BLOCK_W = 230.0  # [px]
ROW_H = 17.0
HEAD_H = 40.0
GAP_X = 120.0
GAP_Y = 36.0
MARGIN = 40.0
FRAME_PAD = 14.0


CHAR_W = 6.3  # [px] of a character at the font size used, for widths
LANE = 12.0  # [px] between the lanes of wires that feed back


@dataclass
class _Box:
    name: str
    x: float
    y: float
    h: float
    inputs: list[str]
    outputs: list[str]
    w: float = BLOCK_W

    def port_y(self, port: str) -> float:
        rows = self.inputs if port in self.inputs else self.outputs
        return self.y + HEAD_H + ROW_H * (rows.index(port) + 0.5)


def subsystems(system: Any) -> list[str]:
    """The subsystems of `system` ('robot', 'robot.arm'), outer ones first."""
    found = {".".join(name.split(".")[:d]) for name in system.order
             for d in range(1, name.count(".") + 1)}
    return sorted(found, key=lambda n: (n.count("."), n))


def closed_subsystems(system: Any, names: Collection[str]) -> set[str]:
    """The subsystems `names` asks to close ('all': the outermost ones); ValueError names an
    unknown one, the subsystems there are and the fix."""
    known = subsystems(system)
    if "all" in names:
        return {n for n in known if "." not in n}
    unknown = [n for n in names if n not in known]
    if unknown:
        there = ", ".join(known) or "none"
        raise ValueError(f"--closed {unknown[0]}: the scenario has no subsystem of that name "
                         f"(its subsystems: {there}). Fix: name one of them, or all.")
    return set(names)


@dataclass
class _Node:
    """A block of the drawing: a component, or a closed subsystem of several."""

    name: str
    members: list[str]  #: the components it draws, in step order
    inputs: list[str] = field(default_factory=list)  #: its port names ('plant.torque' inside)
    outputs: list[str] = field(default_factory=list)
    ports: dict[str, tuple[str, str]] = field(default_factory=dict)  #: name -> (comp, port)


def _nodes(system: Any, closed: Collection[str]) -> tuple[dict[str, _Node], dict[str, str]]:
    """The drawing's blocks in step order (a closed subsystem where its first block steps) and
    the block each component is drawn in."""
    def node_of(name: str) -> str:
        parts = name.split(".")
        return next((".".join(parts[:d]) for d in range(1, len(parts))
                     if ".".join(parts[:d]) in closed), name)

    where = {name: node_of(name) for name in system.order}
    nodes: dict[str, _Node] = {}
    for name in system.order:
        node = nodes.setdefault(where[name], _Node(where[name], []))
        node.members.append(name)
        if where[name] == name:
            comp = system.components[name]
            for port, var in comp.variables.items():
                if var.kind in ("input", "state", "output"):
                    (node.inputs if var.kind == "input" else node.outputs).append(port)
                    node.ports[port] = (name, port)
    for c in system.connections:
        if c.src not in where or c.dst not in where or where[c.src] == where[c.dst]:
            continue
        for comp, port, rows in ((c.src, c.src_port, "outputs"), (c.dst, c.dst_port, "inputs")):
            node = nodes[where[comp]]
            key = _port_key(node, comp, port)
            if node.name != comp and key not in node.ports:
                getattr(node, rows).append(key)
                node.ports[key] = (comp, port)
    return nodes, where


def _port_key(node: _Node, comp: str, port: str) -> str:
    """The name of `comp.port` on `node`'s block: the port, or inside a closed subsystem its
    path from there ('plant.torque')."""
    return port if node.name == comp else f"{comp[len(node.name) + 1:]}.{port}"


def _label(var: Any, name: str) -> str:
    unit = var.unit
    if isinstance(unit, tuple):
        unit = ", ".join(dict.fromkeys(u or "1" for u in unit)) if any(unit) else ""
    size = f"[{var.size}]" if getattr(var, "size", 1) and var.size > 1 else ""
    return f"{name}{size} [{unit}]" if unit else f"{name}{size}"


def _layers(system: Any, nodes: dict[str, _Node], where: dict[str, str]) -> dict[str, int]:
    """Layer of each block: 0 for a block no earlier block feeds, else one more than the
    deepest of the blocks before it in the step order that feed it."""
    rank = {n: i for i, n in enumerate(nodes)}
    feeds: dict[str, set[str]] = {n: set() for n in nodes}
    for c in system.connections:
        a, b = where.get(c.src), where.get(c.dst)
        if a is not None and b is not None and rank[a] < rank[b]:
            feeds[b].add(a)
    layer: dict[str, int] = {}
    for name in nodes:
        layer[name] = 1 + max((layer[s] for s in feeds[name]), default=-1)
    return layer


def _neighbours(system: Any, where: dict[str, str]) -> dict[str, list[str]]:
    """The blocks each block is wired to, either way (once per wire)."""
    found: dict[str, list[str]] = {n: [] for n in dict.fromkeys(where.values())}
    for c in system.connections:
        a, b = where.get(c.src), where.get(c.dst)
        if a is not None and b is not None and a != b:
            found[a].append(b)
            found[b].append(a)
    return found


def _fewer_crossings(columns: dict[int, list[str]], neighbours: dict[str, list[str]],
                     sweeps: int = 4) -> None:
    """Order the blocks of each layer by the mean place of the blocks they are wired to in the
    layer before (sweeping right), then after (sweeping left), as layered graph drawing does
    (the barycentre heuristic); ties keep the step order. In place."""
    layers = [columns[k] for k in sorted(columns)]
    for sweep in range(sweeps):
        order = range(1, len(layers)) if sweep % 2 == 0 else range(len(layers) - 2, -1, -1)
        for k in order:
            near = layers[k - 1] if sweep % 2 == 0 else layers[k + 1]
            place = {n: i for i, n in enumerate(near)}
            current = {n: i for i, n in enumerate(layers[k])}

            def centre(name: str, place: dict[str, int] = place,
                       current: dict[str, int] = current) -> tuple[float, int]:
                seen = [place[m] for m in neighbours[name] if m in place]
                return (sum(seen) / len(seen) if seen else float(current[name]),
                        current[name])

            layers[k].sort(key=centre)


def _loop_ports(system: Any) -> set[tuple[str, str]]:
    from twmr.scenario.graph import find_loops

    try:
        loops, stuck = find_loops(system.components, system.connections)
    except Exception:  # noqa: BLE001 - a drawing without the highlight is still a drawing
        return set()
    return {p for loop in loops for p in loop.ports} | {p for cycle in stuck for p in cycle}


def diagram_svg(system: Any, title: str = "", closed: Collection[str] = ()) -> str:
    """The SVG text of `system` (a built `twmr.scenario.system.System`), each subsystem named
    in `closed` ('robot', 'robot.arm') drawn as one block."""
    nodes, where = _nodes(system, set(closed))
    layer = _layers(system, nodes, where)
    columns: dict[int, list[str]] = {}
    for name in nodes:
        columns.setdefault(layer[name], []).append(name)
    _fewer_crossings(columns, _neighbours(system, where))
    boxes: dict[str, _Box] = {}
    x = MARGIN
    for _, names in sorted(columns.items()):
        y = MARGIN + 30.0
        made = []
        for name in names:
            node = nodes[name]
            ins, outs = node.inputs, node.outputs
            h = HEAD_H + ROW_H * max(len(ins), len(outs), 1) + 6.0
            longest = [max((len(_label(_var(system, node, p), p)) for p in ports), default=0)
                       for ports in (ins, outs)]
            w = max(BLOCK_W, CHAR_W * (sum(longest) + 4), CHAR_W * (len(name) + 8))
            made.append(_Box(name, x, y, h, ins, outs, w))
            y += h + GAP_Y
        span = max(b.w for b in made)
        for box in made:
            boxes[box.name] = box
        x += span + GAP_X
    rank = {n: i for i, n in enumerate(nodes)}
    wires = [c for c in system.connections
             if c.src in where and c.dst in where and where[c.src] != where[c.dst]]
    back = [c for c in wires if rank[where[c.src]] >= rank[where[c.dst]]]
    bottom = max((b.y + b.h for b in boxes.values()), default=100.0) + GAP_Y
    width = x - GAP_X + MARGIN
    height = bottom + LANE * len(back) + MARGIN
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" '
           f'height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" '
           f'font-family="sans-serif" font-size="11">',
           "<style>.block rect.body{fill:#fff;stroke:#333}.block text.head{font-weight:bold}"
           ".block.closed rect.body{fill:#f3f3f8;stroke-width:2}"
           ".wire{fill:none;stroke:#0072B2;stroke-width:1.3}.wire.feedback{stroke-dasharray:5 3}"
           ".wire.loop{stroke:#D55E00;stroke-width:2}.frame{fill:none;stroke:#999;"
           "stroke-dasharray:4 3}</style>",
           f'<text x="{MARGIN}" y="{MARGIN - 14}" font-size="14">{escape(title)}</text>']
    out += _frames(boxes)
    loop = _loop_ports(system)
    for c in wires:
        na, nb = nodes[where[c.src]], nodes[where[c.dst]]
        a, b = boxes[na.name], boxes[nb.name]
        x0, y0 = a.x + a.w, a.port_y(_port_key(na, c.src, c.src_port))
        x1, y1 = b.x, b.port_y(_port_key(nb, c.dst, c.dst_port))
        feedback = c in back
        if feedback:  # out to the right, along a lane under the blocks, in from the left
            lane = bottom + LANE * back.index(c)
            step = 8.0 + 3.0 * (back.index(c) % 6)
            path = (f"M{x0:.1f},{y0:.1f} H{x0 + step:.1f} V{lane:.1f} H{x1 - step:.1f} "
                    f"V{y1:.1f} H{x1:.1f}")
        else:
            bend = max(40.0, (x1 - x0) / 2)
            path = (f"M{x0:.1f},{y0:.1f} C{x0 + bend:.1f},{y0:.1f} {x1 - bend:.1f},{y1:.1f} "
                    f"{x1:.1f},{y1:.1f}")
        classes = "wire" + (" feedback" if feedback else "") + \
            (" loop" if (c.src, c.src_port) in loop and (c.dst, c.dst_port) in loop else "")
        tip = str(c) + (f" (converted: x {c.gain:g}{f' + {c.offset:g}' if c.offset else ''})"
                        if (c.gain, c.offset) != (1.0, 0.0) else "")
        out.append(f'<path class="{classes}" data-src="{escape(c.src)}.{escape(c.src_port)}" '
                   f'data-dst="{escape(c.dst)}.{escape(c.dst_port)}" d="{path}">'
                   f'<title>{escape(tip)}</title></path>')
    steps = {n: i + 1 for i, n in enumerate(system.order)}
    for name, node in nodes.items():
        out.append(_block(system, node, boxes[name], steps))
    out.append("</svg>")
    return "\n".join(out)


def _var(system: Any, node: _Node, port: str) -> Any:
    comp, name = node.ports[port]
    return system.components[comp].variables[name]


def _frames(boxes: dict[str, _Box]) -> list[str]:
    """A dashed frame around the blocks of each subsystem ('robot.plant', 'robot.slip': robot),
    outer subsystems first."""
    groups: dict[str, list[_Box]] = {}
    for box in boxes.values():
        parts = box.name.split(".")
        for depth in range(1, len(parts)):
            groups.setdefault(".".join(parts[:depth]), []).append(box)
    out = []
    for name, members in sorted(groups.items(), key=lambda kv: kv[0].count(".")):
        pad = FRAME_PAD * (1 + 0.5 * (3 - min(3, name.count("."))))
        x0 = min(b.x for b in members) - pad
        y0 = min(b.y for b in members) - pad - 14
        x1 = max(b.x + b.w for b in members) + pad
        y1 = max(b.y + b.h for b in members) + pad
        out.append(f'<g class="subsystem" data-name="{escape(name)}"><rect class="frame" '
                   f'x="{x0:.1f}" y="{y0:.1f}" width="{x1 - x0:.1f}" height="{y1 - y0:.1f}" '
                   f'rx="8"/><text x="{x0 + 8:.1f}" y="{y0 + 13:.1f}" fill="#666">subsystem '
                   f'{escape(name)}</text></g>')
    return out


def _block(system: Any, node: _Node, box: _Box, steps: dict[str, int]) -> str:
    """A block: a component with its kind and step number, or a closed subsystem with its
    number of blocks and their steps."""
    if node.members == [node.name]:
        comp = system.components[node.name]
        kind = str(getattr(comp, "kind", "") or type(comp).__name__)
        multiple = system.multiple(node.name)
        step = steps[node.name]
        what = f"{kind} · step {step}" + (f", every {multiple} steps" if multiple > 1 else "")
        klass, corner = "block", f"#{step}"
    else:
        kind = "subsystem"
        first, last = steps[node.members[0]], steps[node.members[-1]]
        what = f"subsystem of {len(node.members)} blocks · steps {first}-{last}"
        klass, corner = "block closed", "+"
        step = first
    parts = [f'<g class="{klass}" id="block-{escape(box.name)}" data-name="{escape(box.name)}" '
             f'data-kind="{escape(kind)}" data-step="{step}">',
             f'<rect class="body" x="{box.x:.1f}" y="{box.y:.1f}" width="{box.w:.0f}" '
             f'height="{box.h:.1f}" rx="4"/>',
             f'<text class="head" x="{box.x + 8:.1f}" y="{box.y + 16:.1f}">'
             f'{escape(box.name)}</text>',
             f'<text x="{box.x + 8:.1f}" y="{box.y + 31:.1f}" fill="#555">{escape(what)}</text>',
             f'<text x="{box.x + box.w - 8:.1f}" y="{box.y + 16:.1f}" text-anchor="end" '
             f'fill="#999">{corner}</text>']
    for port in box.inputs:
        y = box.port_y(port)
        comp, name = node.ports[port]
        parts.append(f'<g class="port input" data-port="{escape(comp)}.{escape(name)}">'
                     f'<circle cx="{box.x:.1f}" cy="{y:.1f}" r="3" fill="#333"/><text '
                     f'x="{box.x + 8:.1f}" y="{y + 4:.1f}">'
                     f'{escape(_label(_var(system, node, port), port))}</text></g>')
    for port in box.outputs:
        y = box.port_y(port)
        comp, name = node.ports[port]
        parts.append(f'<g class="port output" data-port="{escape(comp)}.{escape(name)}">'
                     f'<circle cx="{box.x + box.w:.1f}" cy="{y:.1f}" r="3" fill="#333"/><text '
                     f'x="{box.x + box.w - 8:.1f}" y="{y + 4:.1f}" text-anchor="end">'
                     f'{escape(_label(_var(system, node, port), port))}</text></g>')
    parts.append("</g>")
    return "".join(parts)
