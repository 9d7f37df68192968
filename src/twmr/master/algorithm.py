"""Fixed-step master algorithms: `GaussSeidel` and `Jacobi`, with step multiples (multi-rate).

At every communication point t_n = start + n h (n an integer; h the base step):

- **Gauss-Seidel**: components with direct feedthrough are visited in the execution order
  (topological over the feedthrough edges); each gets its inputs from the outputs as they are now,
  then `evaluate(t_n)` recomputes its feedthrough outputs, so a chain of feedthrough blocks sees
  every value at the same t_n: exact for a static cascade. Then the components without
  feedthrough get their inputs, so every input holds its source's value at t_n. Then every acting
  component runs `do_step(t_n, m h)`.
- **Jacobi**: every input is taken from one snapshot of the outputs taken at t_n before any
  evaluation; feedthrough outputs are therefore those computed at the previous point, one step late
  along each feedthrough edge. The order of calls does not matter (the components could run in
  parallel).

A component with step multiple m samples its inputs (and evaluates) only when n is a multiple of m
and steps by m h from there; its new outputs become visible at the end of that period, t + m h, as
in libcosim. Between its communication points its inputs and outputs hold (zero-order hold).

The step loop is generated as Python source once per system (like a compiled schedule): inputs are
written straight into the components' ``__dict__``, unit conversions and element selections are
folded into the generated expressions, and there is no lookup by name inside the loop.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from twmr.core.component import Component
from twmr.scenario.system import Connection, System

ALGORITHMS = ("gauss_seidel", "jacobi")


@dataclass
class Schedule:
    """The generated step function and what is needed to map an error back to a component.

    `run(n0, n1, rows)` executes base steps n0..n1-1; `line_owner` maps a line of the generated
    source to the instance that line calls; `finish(n)` writes inputs and evaluates at the final
    point without stepping."""

    run: Callable[[int, int, list[tuple[float, ...]]], None]
    finish: Callable[[int, list[tuple[float, ...]]], None]
    source: str
    line_owner: dict[int, tuple[str, str]] = field(default_factory=dict)
    filename: str = "<twmr schedule>"


class _Writer:
    """Collects generated lines and remembers which instance (and what call) each line belongs to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.owner: dict[int, tuple[str, str]] = {}

    def add(self, indent: int, text: str, owner: tuple[str, str] | None = None) -> None:
        self.lines.append("    " * indent + text)
        if owner is not None:
            self.owner[len(self.lines)] = owner


def _element(expr: str, index: int | None) -> str:
    return expr if index is None else f"{expr}[{index}]"


def _value_expr(conn: Connection, src_expr: str, src_size: int | None,
                dst_size: int | None) -> str:
    """Expression giving the destination input's new value from `src_expr` (the source port
    value), with element selection, unit gain/offset and tuple/scalar shape applied."""
    scaled = conn.gain != 1.0 or conn.offset != 0.0
    if not scaled and conn.src_index is None:
        return src_expr  # whole port: share the tuple / scalar, no copy
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


def generate(system: System, algorithm: str, record: list[tuple[str, str]], decimation: int,
             check_finite: bool = True,
             pace: Callable[[int], None] | None = None) -> Schedule:
    """Generate and compile the step loop of `system` for `algorithm` ('gauss_seidel'|'jacobi').

    `record` lists the (instance, port) pairs appended to `rows` every `decimation` steps as one
    flat tuple (t, values...); `pace(n)` is called after each step when given (real time)."""
    if algorithm not in ALGORITHMS:
        raise ValueError(f"unknown algorithm {algorithm!r}; use one of {ALGORITHMS}")
    comps = system.components
    order = list(system.order)
    ids = {name: i for i, name in enumerate(order)}
    exp = system.experiment
    env: dict[str, Any] = {}
    for name, comp in comps.items():
        i = ids[name]
        env[f"d{i}"] = comp.__dict__
        env[f"ev{i}"] = comp.evaluate
        env[f"st{i}"] = comp.do_step

    def port_expr(name: str, port: str) -> str:
        return f"d{ids[name]}[{port!r}]"

    incoming: dict[str, list[Connection]] = {name: [] for name in order}
    for conn in system.connections:
        incoming[conn.dst].append(conn)

    def assignments(name: str, source_of: Callable[[Connection], str]) -> list[str]:
        """Lines writing every input of `name`; partial (element) writes are merged per port."""
        comp = comps[name]
        by_port: dict[str, list[Connection]] = {}
        for conn in incoming[name]:
            by_port.setdefault(conn.dst_port, []).append(conn)
        out = []
        for port, conns in by_port.items():
            var = comp.variables[port]
            if len(conns) == 1 and conns[0].dst_index is None:
                c = conns[0]
                src_var = comps[c.src].variables[c.src_port]
                expr = _value_expr(c, source_of(c), src_var.size, var.size)
                out.append(f"{port_expr(name, port)} = {expr}")
                continue
            # element-wise: build the full tuple from pieces, unconnected elements keep their value
            cur = port_expr(name, port)
            elems = [f"{cur}[{k}]" for k in range(var.width)]
            for c in conns:
                src_var = comps[c.src].variables[c.src_port]
                src = source_of(c)
                sidx = c.src_index if c.src_index is not None else (
                    (None,) if src_var.size is None else tuple(range(src_var.width)))
                didx = c.dst_index if c.dst_index is not None else tuple(range(var.width))
                for s, d in zip(sidx, didx):
                    e = _element(src, s)
                    if c.gain != 1.0 or c.offset != 0.0:
                        e = f"({e} * {c.gain!r} + {c.offset!r})"
                    elems[d] = e
            out.append(f"{cur} = (" + ", ".join(elems) + ("," if len(elems) == 1 else "") + ")")
        return out

    mult = {name: system.multiple(name) for name in order}
    # outputs that are read (wired or recorded): a NaN elsewhere cannot spread or be seen
    watched = list(dict.fromkeys([(c.src, c.src_port) for c in system.connections] +
                                 [s for s in record if comps[s[0]].variables[s[1]].kind
                                  in ("output", "state")]))
    w = _Writer()
    w.add(0, "def run(n0, n1, rows):")
    w.add(1, "for n in range(n0, n1):")
    w.add(2, "t = start + n * h")
    _point(w, 2, order, comps, mult, ids, algorithm, system.connections, assignments,
           port_expr)
    if check_finite:
        _finite_check(w, 2, watched, comps, port_expr)
    _record(w, 2, record, decimation, comps, port_expr)
    for name in order:
        i = ids[name]
        if type(comps[name]).do_step is Component.do_step:
            continue  # nothing to advance (sources of time only, static blocks)
        m = mult[name]
        env[f"h{i}"] = m * exp.step
        if m == 1:
            w.add(2, f"st{i}(t, h{i})", (name, "do_step"))
        else:  # step from the period's start with its held inputs; outputs show at its end
            w.add(2, f"if n % {m} == {m - 1}: st{i}(t - {m - 1} * h, h{i})", (name, "do_step"))
    if pace is not None:
        w.add(2, "pace(n + 1)")
    # final communication point: inputs and feedthrough outputs at stop, recorded, no step
    w.add(0, "def finish(n, rows):")
    w.add(1, "t = start + n * h")
    _point(w, 1, order, comps, {k: 1 for k in order}, ids, algorithm, system.connections,
           assignments, port_expr)
    if check_finite:
        _finite_check(w, 1, watched, comps, port_expr)
    _record(w, 1, record, 1, comps, port_expr)
    source = "\n".join(w.lines) + "\n"
    env.update(start=exp.start, h=exp.step, nonfinite=_nonfinite, pace=pace)
    filename = f"<twmr schedule {system.source}>"
    exec(compile(source, filename, "exec"), env)  # noqa: S102 - our own generated code
    return Schedule(run=env["run"], finish=env["finish"], source=source, line_owner=w.owner,
                    filename=filename)


def _point(w: _Writer, ind: int, order: list[str], comps: dict[str, Any], mult: dict[str, int],
           ids: dict[str, int], algorithm: str, connections: list[Connection],
           assignments: Callable[..., list[str]], port_expr: Callable[[str, str], str]) -> None:
    """Lines of one communication point: write inputs, evaluate feedthrough components.

    Gauss-Seidel reads each source as it is now (already evaluated at t when it comes earlier in
    the order); Jacobi first copies every source into a local snapshot and reads only that."""
    if algorithm == "gauss_seidel":
        def source_of(c: Connection) -> str:
            return port_expr(c.src, c.src_port)
    else:
        keys = sorted({(c.src, c.src_port) for c in connections})
        snap = {key: f"s{k}" for k, key in enumerate(keys)}
        for (src, port), local in snap.items():
            w.add(ind, f"{local} = {port_expr(src, port)}")

        def source_of(c: Connection) -> str:
            return snap[(c.src, c.src_port)]
    # feedthrough components first, in order, each reading the values just computed; then the
    # inputs of the others, which therefore see every output at t whatever their place
    late = [n for n in order if not comps[n].has_feedthrough]
    for name in [n for n in order if comps[n].has_feedthrough] + late:
        lines = assignments(name, source_of)
        ev = comps[name].has_feedthrough
        if not lines and not ev:
            continue
        body = ind
        if mult[name] != 1:
            w.add(ind, f"if n % {mult[name]} == 0:")
            body = ind + 1
        for line in lines:
            w.add(body, line, (name, "input"))
        if ev:
            w.add(body, f"ev{ids[name]}(t)", (name, "evaluate"))


def _finite_check(w: _Writer, ind: int, watched: list[tuple[str, str]], comps: dict[str, Any],
                  port_expr: Callable[[str, str], str]) -> None:
    """One sum over the watched Real outputs; a NaN or Inf in any makes `x - x` non-zero."""
    terms = []
    for name, port in watched:
        var = comps[name].variables[port]
        if var.type != "Real":
            continue
        terms.append(f"sum({port_expr(name, port)})" if var.size is not None
                     else port_expr(name, port))
    if terms:
        w.add(ind, "x = " + " + ".join(terms))
        w.add(ind, "if x - x != 0.0: nonfinite(t)")


def _record(w: _Writer, ind: int, record: list[tuple[str, str]], decimation: int,
            comps: dict[str, Any], port_expr: Callable[[str, str], str]) -> None:
    if not record:
        return
    parts: list[str] = []
    scalars = ["t"]  # consecutive scalars go into one tuple literal
    for name, port in record:
        var = comps[name].variables[port]
        if var.size is None:
            scalars.append(port_expr(name, port))
            continue
        if scalars:
            parts.append("(" + ", ".join(scalars) + ",)")
            scalars = []
        parts.append(port_expr(name, port))
    if scalars:
        parts.append("(" + ", ".join(scalars) + ",)")
    line = "rows.append(" + " + ".join(parts) + ")"
    if decimation == 1:
        w.add(ind, line)
    else:
        w.add(ind, f"if n % {decimation} == 0: {line}")


class NonFinite(Exception):
    """Raised by the generated loop when some output is NaN or Inf at time `t`."""

    def __init__(self, t: float):
        super().__init__(t)
        self.t = t


def _nonfinite(t: float) -> None:
    raise NonFinite(t)
