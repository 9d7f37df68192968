"""One plan of the fixed-step loop, built once from a `System`; the Python schedule
(`twmr.master.schedule`) and the compiled loop (`twmr.master.compiled`) both render it.

A plan says what happens at every base step n, in order: the Jacobi snapshot of the wired
outputs (Jacobi only), the point — input writes (each with its expression: unit gain and offset,
element selection) and feedthrough evaluations in the order of the port graph, each guarded by its
component's step multiple —, the NaN/Inf check over the outputs the run reads (in chunks of at
most `CHAIN` terms), the recorded ports (a Binary one at each tick of its clock:
`twmr.master.ticks`), and the steps with their multiples. A renderer only chooses how a port
value, an evaluation and a step are written in its language, so the two loops
compute the same expressions in the same order by construction.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

from twmr.core.component import Component
from twmr.core.port import BINARY
from twmr.master.ticks import Ticked, binary_signals
from twmr.scenario.graph import evaluation_plan, find_loops
from twmr.scenario.system import Connection, System

#: the fixed-step methods a plan can be built for
METHODS = ("gauss_seidel", "jacobi")
#: terms one chained expression may hold (Python's compiler recurses once per operator)
CHAIN = 64

#: (component, port)
Port = tuple[str, str]
#: writes a port's value in a renderer's language: (component, port) -> expression
Ref = Callable[[str, str], str]
T = TypeVar("T")


@dataclass(frozen=True)
class Write:
    """Input `port` of component `name` gets `template` with `{cur}` its present value and
    `{0}`, `{1}`, ... the values of `sources` (the template is a Python expression, numba's too)."""

    name: str
    port: str
    template: str
    sources: tuple[Port, ...]
    multiple: int = 1


@dataclass(frozen=True)
class Evaluate:
    """Component `name` computes its feedthrough outputs (`evaluate(t)`)."""

    name: str
    multiple: int = 1


@dataclass(frozen=True)
class Solve:
    """Algebraic loop `index` (`twmr.scenario.graph.Loop`) solved at this point by the master
    (`twmr.master.loops`): `body` is one pass through it with the torn inputs held, `tears`
    the writes of the torn inputs from their sources (g(x) of the iteration)."""

    index: int
    components: tuple[str, ...]
    body: tuple[Write | Evaluate, ...]
    tears: tuple[Write, ...]
    multiple: int = 1


@dataclass(frozen=True)
class Step:
    """Component `name` advances by its multiple m of base steps, at the last base step of each
    period, from the period's start (its new outputs show at the period's end)."""

    name: str
    multiple: int = 1

    @property
    def guard(self) -> str | None:
        """The condition on n under which it steps (None: every step)."""
        m = self.multiple
        return None if m == 1 else f"n % {m} == {m - 1}"

    @property
    def time(self) -> str:
        """The expression of the time it steps from."""
        m = self.multiple
        return "t" if m == 1 else f"t - {m - 1} * h"


@dataclass(frozen=True)
class Signal:
    """A port read by the check or recorded: `size` None for a scalar, else its element count."""

    name: str
    port: str
    size: int | None


def guard(action: Write | Evaluate | Solve) -> str | None:
    """The condition on n under which a write or evaluation happens (None: every step); a
    component with step multiple m samples its inputs and evaluates when n is a multiple of m."""
    m = action.multiple
    return None if m == 1 else f"n % {m} == 0"


@dataclass(frozen=True)
class Plan:
    """The step loop of one system: see the module docstring. Component i is `order[i]`."""

    method: str
    order: tuple[str, ...]
    snapshot: tuple[Port, ...]
    point: tuple[Write | Evaluate | Solve, ...]
    check: tuple[tuple[Signal, ...], ...]
    record: tuple[Signal, ...]
    decimation: int
    steps: tuple[Step, ...]
    #: the recorded Binary ports
    ticks: tuple[Ticked, ...] = ()

    @property
    def loops(self) -> tuple[Solve, ...]:
        """The algebraic loops solved at each point, in the order they are solved."""
        return tuple(a for a in self.point if isinstance(a, Solve))

    def index(self, name: str) -> int:
        """The number of component `name` in the loop (its place in `order`)."""
        return self.order.index(name)

    def assignment(self, write: Write, ref: Ref) -> str:
        """The statement of `write` with port values written by `ref`; under Jacobi the sources
        are read from the snapshot's locals `s0, s1, ...`."""
        snap = {key: f"s{k}" for k, key in enumerate(self.snapshot)}
        values = [snap[s] if snap else ref(*s) for s in write.sources]
        cur = ref(write.name, write.port)
        return f"{cur} = {write.template.format(*values, cur=cur)}"


def advancing(system: System, plan: Plan) -> frozenset[str]:
    """The components whose step may leave out what the next point's evaluation recomputes
    (`Kernel.advance`): each evaluated at every point after its steps (the same multiple)
    before any write reads one of its feedthrough outputs. None under Jacobi (its snapshot
    reads the outputs of the steps) or with a loop to solve."""
    if plan.snapshot or plan.loops:
        return frozenset()
    evaluated: dict[str, int] = {}
    read_early: set[str] = set()
    for action in plan.point:
        if isinstance(action, Evaluate):
            evaluated.setdefault(action.name, action.multiple)
        elif isinstance(action, Write):
            read_early.update(name for name, port in action.sources
                              if name not in evaluated and _feedthrough(system, name, port))
    return frozenset(s.name for s in plan.steps
                     if evaluated.get(s.name) == s.multiple and s.name not in read_early)


def _feedthrough(system: System, name: str, port: str) -> bool:
    """Whether output `port` of `name` depends on an input directly."""
    return bool(getattr(system.components[name].variables[port], "depends_on", None))


def chunks(items: Sequence[T]) -> list[Sequence[T]]:
    """`items` cut into runs of at most `CHAIN`."""
    return [items[i:i + CHAIN] for i in range(0, len(items), CHAIN)]


#: the attribute of a `System` holding its last plan: (key, what the key's ids refer to, plan)
_HELD_PLAN = "_held_plan"


def held_build(system: System, method: str, record: Sequence[Port], decimation: int,
               check_finite: bool = True) -> Plan:
    """`build`, kept on `system` and handed out again while everything a plan is made of is
    the same: the components (objects and classes), their variables (objects, and what each
    output depends on), the wires, the step multiples, the loop setting and the arguments (a
    built system run again with other values: `twmr.build`). The variables compared by
    identity are held with the plan, so no other object can take one's id."""
    comps = system.components
    variables = [v for c in comps.values() for v in c.variables.values()]
    key = (method, tuple(record), decimation, check_finite, tuple(system.order),
           tuple((n, id(c), type(c)) for n, c in comps.items()),
           tuple((id(v), getattr(v, "depends_on", None)) for v in variables),
           tuple(system.connections),
           tuple(sorted(system.step_multiples.items())), system.experiment.loops)
    held = system.__dict__.get(_HELD_PLAN)
    if held is not None and held[0] == key:
        return held[2]
    plan = build(system, method, record, decimation, check_finite)
    system.__dict__[_HELD_PLAN] = (key, (list(comps.values()), variables), plan)
    return plan


def build(system: System, method: str, record: Sequence[Port], decimation: int,
          check_finite: bool = True) -> Plan:
    """The plan of `system` under `method` ('gauss_seidel' | 'jacobi'), recording the `record`
    ports every `decimation` steps (a Binary port at its clock's ticks); `check_finite` adds the
    NaN/Inf check."""
    if method not in METHODS:
        raise ValueError(f"unknown fixed-step method {method!r}; use one of {METHODS}")
    comps = system.components
    binary = binary_signals(system, record)
    record = [s for s in record if comps[s[0]].variables[s[1]].type != BINARY]
    order = tuple(system.order)
    incoming: dict[Port, list[Connection]] = {}
    for conn in system.connections:
        incoming.setdefault((conn.dst, conn.dst_port), []).append(conn)
    loops = find_loops(comps, system.connections)[0] \
        if system.experiment.loops == "solve" and method == "gauss_seidel" else []
    if method == "gauss_seidel":
        actions, _ = evaluation_plan(comps, system.connections, loops)
        snapshot: tuple[Port, ...] = ()
    else:  # Jacobi: every input from one snapshot, one evaluation per component, any order
        actions = [("write", n, p) for n in order for p in comps[n].inputs if (n, p) in incoming]
        actions += [("evaluate", n, "") for n in order if comps[n].has_feedthrough]
        snapshot = tuple(sorted({(c.src, c.src_port) for c in system.connections}))

    def write(name: str, port: str) -> Write:
        sources: list[Port] = []

        def placeholder(c: Connection, _s: list[Port] = sources) -> str:
            _s.append((c.src, c.src_port))
            return f"{{{len(_s) - 1}}}"

        template = input_value(system, incoming[(name, port)], "{cur}", placeholder)
        return Write(name, port, template, tuple(sources), system.multiple(name))

    def act(action: str, name: str, port: str) -> Write | Evaluate:
        return Evaluate(name, system.multiple(name)) if action == "evaluate" \
            else write(name, port)

    point: list[Write | Evaluate | Solve] = []
    for action, name, port in actions:
        if action != "loop":
            point.append(act(action, name, port))
            continue
        lp = loops[int(name)]
        tears = tuple(write(*tear) for tear in lp.tears)
        point.append(Solve(int(name), lp.components, tuple(act(*a) for a in lp.body), tears,
                           system.multiple(lp.components[0])))
    # outputs that are read (wired or recorded): a NaN elsewhere cannot spread or be seen
    watched = list(dict.fromkeys([(c.src, c.src_port) for c in system.connections] +
                                 [s for s in record if comps[s[0]].variables[s[1]].kind
                                  in ("output", "state")]))
    terms = [_signal(system, n, p) for n, p in watched
             if comps[n].variables[p].type == "Real"] if check_finite else []
    check = tuple(tuple(c) for c in chunks(terms))
    steps = tuple(Step(n, system.multiple(n)) for n in order
                  if type(comps[n]).do_step is not Component.do_step)
    return Plan(method, order, snapshot, tuple(point), check,
                tuple(_signal(system, n, p) for n, p in record), decimation, steps,
                tuple(binary))


def _signal(system: System, name: str, port: str) -> Signal:
    return Signal(name, port, system.components[name].variables[port].size)


def _element(expr: str, index: int | None) -> str:
    return expr if index is None else f"{expr}[{index}]"


def input_value(system: System, conns: list[Connection], cur: str,
                source_of: Callable[[Connection], str]) -> str:
    """Expression of the new value of the input that `conns` write (all to one port, whose
    current value is the expression `cur`): the source as is for one whole-port wire, else a
    tuple of elements in which unconnected elements keep their value; unit gain and offset
    applied."""
    comps = system.components
    c0 = conns[0]
    var = comps[c0.dst].variables[c0.dst_port]
    if len(conns) == 1 and c0.dst_index is None:
        return _value_expr(c0, source_of(c0), comps[c0.src].variables[c0.src_port].size,
                           var.size)
    elems = [f"{cur}[{k}]" for k in range(var.width)]
    for c in conns:
        src_var = comps[c.src].variables[c.src_port]
        sidx = c.src_index if c.src_index is not None else (
            (None,) if src_var.size is None else tuple(range(src_var.width)))
        didx = c.dst_index if c.dst_index is not None else tuple(range(var.width))
        for s_, d in zip(sidx, didx, strict=False):
            e = _element(source_of(c), s_)
            if c.gain != 1.0 or c.offset != 0.0:
                e = f"({e} * {c.gain!r} + {c.offset!r})"
            elems[d] = e
    return "(" + ", ".join(elems) + ("," if len(elems) == 1 else "") + ")"


#: one element of an input write: (destination element, source component, source port, source
#: element (None: a scalar), unit gain and offset (None, 0.0: copied as is))
Element = tuple[int, str, str, int | None, float | None, float]


def input_elements(system: System, conns: list[Connection]) -> list[Element]:
    """The elements that `input_value(system, conns, ...)` writes, one by one, in its order and
    with its arithmetic (`e * gain + offset` where a wire has a gain or offset; elements it
    leaves at their value are not listed)."""
    comps = system.components
    c0 = conns[0]
    var = comps[c0.dst].variables[c0.dst_port]
    out: dict[int, Element] = {}
    for c in conns:
        src_var = comps[c.src].variables[c.src_port]
        sidx = c.src_index if c.src_index is not None else (
            (None,) if src_var.size is None else tuple(range(src_var.width)))
        if len(conns) == 1 and c.dst_index is None:
            didx: tuple[int, ...] = tuple(range(len(sidx) if var.size is not None else 1))
        else:
            didx = c.dst_index if c.dst_index is not None else tuple(range(var.width))
        scaled = c.gain != 1.0 or c.offset != 0.0
        for s_, d in zip(sidx, didx, strict=False):
            out[d] = (d, c.src, c.src_port, s_, c.gain if scaled else None,
                      c.offset if scaled else 0.0)
    return list(out.values())


def _value_expr(conn: Connection, src_expr: str, src_size: int | None,
                dst_size: int | None) -> str:
    """Expression giving the destination input's new value from `src_expr` (the source port
    value), with element selection, unit gain/offset and tuple/scalar shape applied."""
    scaled = conn.gain != 1.0 or conn.offset != 0.0
    if not scaled and conn.src_index is None and (src_size is None) == (dst_size is None):
        return src_expr  # whole port of one shape: share the tuple / scalar, no copy
    if conn.src_index is not None:
        idx: list[int | None] = list(conn.src_index)
    else:
        idx = [None] if src_size is None else list(range(src_size))
    parts = []
    for i in idx:
        e = _element(src_expr, i)
        if scaled:
            e = f"({e} * {conn.gain!r} + {conn.offset!r})"
        parts.append(e)
    if dst_size is None:
        return parts[0]
    return "(" + ", ".join(parts) + ("," if len(parts) == 1 else "") + ")"
