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

from twmr.master import loops, stats
from twmr.master.algorithm import Algorithm, NonFinite
from twmr.master.plan import METHODS, Plan, Ref, Solve, Write, build, chunks, guard
from twmr.scenario.system import System


class _Writer:
    """Collects generated lines and the instance (and call) each line belongs to."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.owner: dict[int, tuple[str, str]] = {}

    def add(self, indent: int, text: str, owner: tuple[str, str] | None = None) -> None:
        self.lines.append("    " * indent + text)
        if owner is not None:
            self.owner[len(self.lines)] = owner


class FixedStep(Algorithm):
    """Fixed base step h; 'gauss_seidel' or 'jacobi'; per-component step multiples.

    The step loop is generated as Python source once per system, from its `Plan`: inputs are
    written straight into the components' ``__dict__``, unit conversions and element selections
    are folded into the expressions, and nothing is looked up by name inside the loop. The source
    is registered with `linecache`, so tracebacks and pdb show it (`twmr check --schedule` prints
    it)."""

    def __init__(self, method: str = "gauss_seidel"):
        if method not in METHODS:
            raise ValueError(f"unknown fixed-step method {method!r}; use one of {METHODS}")
        self.method = method
        self.source = ""
        self.filename = ""
        self.plan: Plan | None = None
        self._owner: dict[int, tuple[str, str]] = {}
        self.loops: list[loops.LoopSolver] = []
        self.probe: stats.Probe | None = None
        self._run: Callable[[int, int, list[tuple[float, ...]]], None] | None = None
        self._finish: Callable[[int, list[tuple[float, ...]]], None] | None = None

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        self.plan = build(system, self.method, record, decimation, check_finite)
        self.source, self._owner, env = _generate(system, self.plan)
        self.filename = f"<twmr schedule {system.source} {id(self):x}>"
        linecache.cache[self.filename] = (len(self.source), None,
                                          self.source.splitlines(True), self.filename)
        exec(compile(self.source, self.filename, "exec"), env)  # noqa: S102 - generated here
        timing = stats.timing_wanted()
        self.probe = stats.Probe(timing) if timing else None
        if self.probe is not None:
            self.probe.wrap(env, self.plan.order)
        self.loops = loops.bind(env, system, self.plan, timing)
        self._run, self._finish = env["run"], env["finish"]

    def advance(self, n0: int, n1: int, rows: list[tuple[float, ...]]) -> int:
        self._run(n0, n1, rows)  # type: ignore[misc]
        return n1

    def finish(self, n: int, rows: list[tuple[float, ...]]) -> None:
        self._finish(n, rows)  # type: ignore[misc]

    def statistics(self, steps_done: int, finished: bool) -> dict[str, object]:
        assert self.plan is not None
        blocks = self.probe.blocks() if self.probe is not None else \
            stats.fixed_step(self.plan, steps_done, finished, self.loops)
        return stats.document(blocks, self.loops)

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        return locate_in(exc, self.filename, self._owner)


def locate_in(exc: BaseException, filename: str, owners: dict[int, tuple[str, str]]
              ) -> tuple[str, str, float]:
    """(component, call, t) of an exception raised in the generated loop `filename`, whose
    lines `owners` maps to (component, 'input' | 'evaluate' | 'do_step')."""
    owner, t = ("?", "a call"), math.nan
    for frame, lineno in traceback.walk_tb(exc.__traceback__):
        if frame.f_code.co_filename == filename:
            owner = owners.get(lineno, owner)
            t = frame.f_locals.get("t", t)
    name, what = owner
    call = {"input": "writing its inputs", "evaluate": "evaluate()",
            "do_step": "do_step()"}.get(what, what)
    return name, call, t


def _generate(system: System, plan: Plan) -> tuple[str, dict[int, tuple[str, str]],
                                                   dict[str, Any]]:
    """(source, line owners, globals) of the step loop rendered from `plan`: `run(n0, n1, rows)`
    executes base steps n0..n1-1 and appends a flat tuple (t, values...) of the recorded ports
    to `rows` every `plan.decimation` steps; `finish(n, rows)` writes inputs and evaluates at
    the final point."""
    comps = system.components
    ids = {name: i for i, name in enumerate(plan.order)}
    exp = system.experiment
    env: dict[str, Any] = {}
    for name, comp in comps.items():
        i = ids[name]
        env[f"d{i}"] = comp.__dict__
        env[f"ev{i}"] = comp.evaluate
        env[f"st{i}"] = comp.do_step

    def ref(name: str, port: str) -> str:
        return f"d{ids[name]}[{port!r}]"

    w = _Writer()
    for name in plan.order:
        i = ids[name]
        w.add(0, f"# d{i}, ev{i}, st{i}: {name} ({type(comps[name]).__name__}) values, evaluate, "
                 f"do_step")
    w.add(0, "def run(n0, n1, rows):")
    w.add(1, "for n in range(n0, n1):")
    w.add(2, "t = start + n * h")
    _point(w, 2, plan, ids, ref, final=False)
    _finite_check(w, 2, plan, ref)
    _record(w, 2, plan, ref, final=False)
    for s in plan.steps:
        i = ids[s.name]
        env[f"h{i}"] = s.multiple * exp.step
        line = f"st{i}({s.time}, h{i})"
        w.add(2, line if s.guard is None else f"if {s.guard}: {line}", (s.name, "do_step"))
    w.add(0, "def finish(n, rows):")
    w.add(1, "t = start + n * h")
    _point(w, 1, plan, ids, ref, final=True)
    _finite_check(w, 1, plan, ref)
    _record(w, 1, plan, ref, final=True)
    loops.render(w, plan, ids, ref)
    env.update(start=exp.start, h=exp.step, nonfinite=_nonfinite)
    return "\n".join(w.lines) + "\n", w.owner, env


def _point(w: _Writer, ind: int, plan: Plan, ids: dict[str, int], ref: Ref,
           final: bool) -> None:
    """Lines of one communication point: the Jacobi snapshot, then the plan's input writes and
    evaluations, each guarded by its component's step multiple (not at the final point)."""
    for k, (src, port) in enumerate(plan.snapshot):
        w.add(ind, f"s{k} = {ref(src, port)}")
    for action in plan.point:
        if isinstance(action, Write):
            line, owner = plan.assignment(action, ref), (action.name, "input")
        elif isinstance(action, Solve):
            line, owner = loops.call(action), (", ".join(action.components), "the loop solver")
        else:
            line, owner = f"ev{ids[action.name]}(t)", (action.name, "evaluate")
        cond = None if final else guard(action)
        w.add(ind, line if cond is None else f"if {cond}: {line}", owner)


def _finite_check(w: _Writer, ind: int, plan: Plan, ref: Ref) -> None:
    """One sum over the watched Real outputs; a NaN or Inf in any makes `x - x` non-zero."""
    if not plan.check:
        return
    sums = [" + ".join(f"sum({ref(s.name, s.port)})" if s.size is not None
                       else ref(s.name, s.port) for s in chunk) for chunk in plan.check]
    w.add(ind, "x = " + (sums[0] if len(sums) == 1 else _sum_of(sums, "0.0")))
    w.add(ind, "if x - x != 0.0: nonfinite(t)")


def _sum_of(sums: list[str], zero: str) -> str:
    """`sum(((a + b), (c + d),), zero)`: chunks summed without one deep chained expression."""
    return f"sum(({', '.join(f'({c})' for c in sums)},), {zero})"


def _record(w: _Writer, ind: int, plan: Plan, ref: Ref, final: bool) -> None:
    """`rows.append(...)` of one flat tuple (t, the recorded values), every `decimation` steps
    (at the final point always)."""
    if not plan.record:
        return
    parts: list[str] = []
    scalars = ["t"]  # consecutive scalars go into one tuple literal
    for s in plan.record:
        if s.size is None:
            scalars.append(ref(s.name, s.port))
            continue
        if scalars:
            parts.append("(" + ", ".join(scalars) + ",)")
            scalars = []
        parts.append(ref(s.name, s.port))
    if scalars:
        parts.append("(" + ", ".join(scalars) + ",)")
    pieces = [" + ".join(c) for c in chunks(parts)]
    line = f"rows.append({pieces[0] if len(pieces) == 1 else _sum_of(pieces, '()')})"
    if final or plan.decimation == 1:
        w.add(ind, line)
    else:
        w.add(ind, f"if n % {plan.decimation} == 0: {line}")


def _nonfinite(t: float) -> None:
    raise NonFinite(t)
