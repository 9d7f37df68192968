"""`FixedStep`: the fixed-step Gauss-Seidel and Jacobi algorithms, with step multiples (multi-rate),
as one generated Python loop.

At every communication point t_n = start + n h (n an integer; h the base step):

- **Gauss-Seidel**: the ports are visited in the topological order of the port-level graph
  (`twmr.scenario.graph.evaluation_plan`): each connected input is written from its source once
  that source is final at t_n, and a feedthrough component is evaluated (`evaluate(t_n)`) once the
  inputs its outputs depend on are written — twice when the wiring passes through it twice. A
  chain of feedthrough blocks therefore sees every value at the same t_n (exact for a static
  cascade), and every input holds its source's value at t_n. Then every acting component runs
  `do_step(t_n, m h)`.
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

import linecache
import math
import traceback
from collections.abc import Callable
from typing import Any

from twmr.core.component import Component
from twmr.master.algorithm import Algorithm, NonFinite
from twmr.scenario.graph import evaluation_plan
from twmr.scenario.system import Connection, System

ALGORITHMS = ("gauss_seidel", "jacobi")


class _Writer:
    """Collects generated lines and the instance (and call) each line belongs to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.owner: dict[int, tuple[str, str]] = {}

    def add(self, indent: int, text: str, owner: tuple[str, str] | None = None) -> None:
        self.lines.append("    " * indent + text)
        if owner is not None:
            self.owner[len(self.lines)] = owner


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


class FixedStep(Algorithm):
    """Fixed base step h; 'gauss_seidel' or 'jacobi'; per-component step multiples.

    The step loop is generated as Python source once per system: inputs are written straight
    into the components' ``__dict__``, unit conversions and element selections are folded into
    the expressions, and nothing is looked up by name inside the loop. The source is registered
    with `linecache`, so tracebacks and pdb show it (`twmr check --schedule` prints it)."""

    def __init__(self, method: str = "gauss_seidel"):
        if method not in ALGORITHMS:
            raise ValueError(f"unknown algorithm {method!r}; use one of {ALGORITHMS}")
        self.method = method
        self.source = ""
        self.filename = ""
        self._owner: dict[int, tuple[str, str]] = {}
        self._run: Callable[[int, int, list[tuple[float, ...]]], None] | None = None
        self._finish: Callable[[int, list[tuple[float, ...]]], None] | None = None

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        self.source, self._owner, env = _generate(system, self.method, record, decimation,
                                                  check_finite)
        self.filename = f"<twmr schedule {system.source} {id(self):x}>"
        linecache.cache[self.filename] = (len(self.source), None,
                                          self.source.splitlines(True), self.filename)
        exec(compile(self.source, self.filename, "exec"), env)  # noqa: S102 - generated here
        self._run, self._finish = env["run"], env["finish"]

    def advance(self, n0: int, n1: int, rows: list[tuple[float, ...]]) -> int:
        self._run(n0, n1, rows)  # type: ignore[misc]
        return n1

    def finish(self, n: int, rows: list[tuple[float, ...]]) -> None:
        self._finish(n, rows)  # type: ignore[misc]

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        owner, t = ("?", "a call"), math.nan
        for frame, lineno in traceback.walk_tb(exc.__traceback__):
            if frame.f_code.co_filename == self.filename:
                owner = self._owner.get(lineno, owner)
                t = frame.f_locals.get("t", t)
        name, what = owner
        call = {"input": "writing its inputs", "evaluate": "evaluate()",
                "do_step": "do_step()"}.get(what, what)
        return name, call, t


def schedule_source(system: System, record: list[tuple[str, str]] | None = None) -> str:
    """The generated step loop of `system` as Python source (what `twmr check --schedule` shows)."""
    exp = system.experiment
    rec = list(system.record.signals) if record is None else record
    return _generate(system, exp.algorithm, rec, system.record.decimation, True)[0]


def _generate(system: System, algorithm: str, record: list[tuple[str, str]], decimation: int,
              check_finite: bool) -> tuple[str, dict[int, tuple[str, str]], dict[str, Any]]:
    """(source, line owners, globals) of the step loop: `run(n0, n1, rows)` executes base steps
    n0..n1-1 and appends a flat tuple (t, values...) of the `record` ports to `rows` every
    `decimation` steps; `finish(n, rows)` writes inputs and evaluates at the final point."""
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

    incoming: dict[tuple[str, str], list[Connection]] = {}
    for conn in system.connections:
        incoming.setdefault((conn.dst, conn.dst_port), []).append(conn)

    def assignment(name: str, port: str, source_of: Callable[[Connection], str]) -> str:
        """The line writing input `port` of `name`; element writes are merged into one tuple."""
        cur = port_expr(name, port)
        return f"{cur} = {input_value(system, incoming[(name, port)], cur, source_of)}"

    if algorithm == "gauss_seidel":
        plan, _ = evaluation_plan(comps, system.connections)
    else:  # Jacobi: every input from one snapshot, one evaluation per component, any order
        plan = [("write", n, p) for n in order for p in comps[n].inputs
                if (n, p) in incoming]
        plan += [("evaluate", n, "") for n in order if comps[n].has_feedthrough]
    # outputs that are read (wired or recorded): a NaN elsewhere cannot spread or be seen
    watched = list(dict.fromkeys([(c.src, c.src_port) for c in system.connections] +
                                 [s for s in record if comps[s[0]].variables[s[1]].kind
                                  in ("output", "state")]))
    w = _Writer()
    for name in order:
        i = ids[name]
        w.add(0, f"# d{i}, ev{i}, st{i}: {name} ({type(comps[name]).__name__}) values, evaluate, "
                 f"do_step")
    w.add(0, "def run(n0, n1, rows):")
    w.add(1, "for n in range(n0, n1):")
    w.add(2, "t = start + n * h")
    mult = {name: system.multiple(name) for name in order}
    _point(w, 2, plan, mult, ids, algorithm, system.connections, assignment, port_expr)
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
    w.add(0, "def finish(n, rows):")
    w.add(1, "t = start + n * h")
    _point(w, 1, plan, dict.fromkeys(order, 1), ids, algorithm, system.connections, assignment,
           port_expr)
    if check_finite:
        _finite_check(w, 1, watched, comps, port_expr)
    _record(w, 1, record, 1, comps, port_expr)
    env.update(start=exp.start, h=exp.step, nonfinite=_nonfinite)
    return "\n".join(w.lines) + "\n", w.owner, env


def _point(w: _Writer, ind: int, plan: list[tuple[str, str, str]], mult: dict[str, int],
           ids: dict[str, int], algorithm: str, connections: list[Connection],
           assignment: Callable[..., str], port_expr: Callable[[str, str], str]) -> None:
    """Lines of one communication point: the plan's input writes and evaluations, each guarded by
    its component's step multiple. Jacobi first copies every source into a local snapshot and
    reads only that."""
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
    for action, name, port in plan:
        if action == "write":
            line, owner = assignment(name, port, source_of), (name, "input")
        else:
            line, owner = f"ev{ids[name]}(t)", (name, "evaluate")
        m = mult[name]
        w.add(ind, line if m == 1 else f"if n % {m} == 0: {line}", owner)


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
        w.add(ind, "x = " + _flat_sum(terms, "0.0"))
        w.add(ind, "if x - x != 0.0: nonfinite(t)")


#: terms one chained expression may hold (Python's compiler recurses once per operator)
_CHAIN = 64


def _flat_sum(terms: list[str], zero: str) -> str:
    """`a + b + c` for a few terms; for many, `sum((chunk, chunk, ...), zero)` over chained
    chunks, so the expression stays shallow."""
    if len(terms) <= _CHAIN:
        return " + ".join(terms)
    chunks = [" + ".join(terms[i:i + _CHAIN]) for i in range(0, len(terms), _CHAIN)]
    return f"sum(({', '.join(f'({c})' for c in chunks)},), {zero})"


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
    line = f"rows.append({_flat_sum(parts, '()')})"
    if decimation == 1:
        w.add(ind, line)
    else:
        w.add(ind, f"if n % {decimation} == 0: {line}")


def _nonfinite(t: float) -> None:
    raise NonFinite(t)
