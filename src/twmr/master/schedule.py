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

The step loop is generated as Python source once per system (like a compiled schedule). A block
that runs its kernel (`twmr.core.kernel`) is called through its kernel functions with its ports,
private state and parameters held in local variables of the loop, as the compiled loop holds
them; any other block gets its inputs written straight into its ``__dict__`` and its
`evaluate`/`do_step` called. Unit conversions and element selections are folded into the
generated expressions, and there is no lookup by name inside the loop.
"""
from __future__ import annotations

import contextlib
import linecache
import math
import traceback
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from twmr.core.component import (
    KERNEL_STATE,
    Component,
    PythonKernel,
    bound_kernel,
    python_kernel,
    runs_kernel,
)
from twmr.core.errors import CosimError
from twmr.master import loops, stats
from twmr.master.algorithm import Algorithm
from twmr.master.plan import (
    METHODS,
    Plan,
    advancing,
    held_build,
)
from twmr.master.render import Writer, finite_check, nonfinite, point, record, tuple_of
from twmr.master.ticks import Tick
from twmr.scenario.system import System


class FixedStep(Algorithm):
    """Fixed base step h; 'gauss_seidel' or 'jacobi'; per-component step multiples.

    The step loop is generated as Python source once per system, from its `Plan`: a block that
    runs its kernel (`twmr.core.component.python_kernel`) has its ports, private state and
    parameters as local variables of the loop, which calls the kernel's functions itself (a
    step by its `advance` where `twmr.master.plan.advancing` allows it, but the last step of a
    chunk; the state handed back to the component, and the port values written to its
    ``__dict__``, when the chunk of steps ends); any other block has its inputs written straight
    into its ``__dict__`` and its `evaluate`/`do_step` called. Unit conversions and element
    selections are folded into the expressions, and nothing is looked up by name inside the
    loop. The source is registered with `linecache`, so tracebacks and pdb show it (`twmr check
    --schedule` prints it; it is generated again, for the kernels the components offer, when
    the run starts)."""

    def __init__(self, method: str = "gauss_seidel"):
        if method not in METHODS:
            raise ValueError(f"unknown fixed-step method {method!r}; use one of {METHODS}")
        self.method = method
        self.outputs_as_stepped = method == "jacobi"
        self._source: str | None = ""
        self.filename = ""
        self.plan: Plan | None = None
        self._system: System | None = None
        self._owner: dict[int, tuple[str, str]] = {}
        self.loops: list[loops.LoopSolver] = []
        self.probe: stats.Probe | None = None
        self._shapes: dict[str, Shape] = {}
        self._run: Callable[[int, int, list[tuple[float, ...]]], None] | None = None
        self._finish: Callable[[int, list[tuple[float, ...]]], None] | None = None

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        self.plan = held_build(system, self.method, record, decimation, check_finite)
        self._system = system
        self._run = self._finish = None
        self._source = None

    @property
    def source(self) -> str:  # type: ignore[override]
        """The generated loop: the one running, else (rendered when asked) the loop before the
        components are initialized, where every block that may run its kernel does."""
        if self._source is None:
            system, plan = self._system, self.plan
            assert system is not None and plan is not None
            shapes = {n: Shape(True, True, True) for n, c in system.components.items()
                      if runs_kernel(c) and self._kernels_wanted()}
            self._source, self._owner, _ = _generate(system, plan, shapes)
        return self._source

    def _kernels_wanted(self) -> bool:
        """Whether blocks may run their kernels in the loop: not when an algebraic loop is solved
        (its solver reaches the blocks through their values and methods) nor when every block's
        calls are timed (`twmr.master.stats`)."""
        assert self.plan is not None
        return not self.timing and not self.plan.loops

    def start(self) -> None:
        """Generate the loop now, before the clock runs, and call each block's kernel once on
        the values it holds (pure functions; the results dropped): the kernel functions a long
        run calls compiled (`twmr.core.kernel.KernelFunction.python`) are loaded from numba's
        cache (or compiled) here, not in the first step."""
        self._load()
        system = self._system
        assert system is not None
        for name in self._shapes:
            _warm(system.components[name], _step_of(system, name), system.experiment.start)

    def _load(self) -> None:
        """Generate and compile the loop for the kernels the initialized components offer."""
        system, plan = self._system, self.plan
        assert system is not None and plan is not None
        shapes = {}
        for name, comp in system.components.items() if self._kernels_wanted() else ():
            k = python_kernel(comp, _step_of(system, name))
            if k is not None:
                shapes[name] = Shape.of(k)
        self._source, self._owner, env = _generate(system, plan, shapes)
        self._shapes = shapes
        self.filename = f"<twmr schedule {system.source} {id(self):x}>"
        linecache.cache[self.filename] = (len(self._source), None,
                                          self._source.splitlines(True), self.filename)
        exec(compile(self._source, self.filename, "exec"), env)  # noqa: S102 - generated here
        timing = self.timing
        self.probe = stats.Probe(timing) if timing else None
        if self.probe is not None:
            self.probe.wrap(env, plan.order)
        self.loops = loops.bind(env, system, plan, timing)
        self._run, self._finish = env["run"], env["finish"]

    def advance(self, n0: int, n1: int, rows: list[tuple[float, ...]]) -> int:
        if self._run is None:
            self._load()
        self._run(n0, n1, rows)  # type: ignore[misc]
        return n1

    def finish(self, n: int, rows: list[tuple[float, ...]]) -> None:
        if self._finish is None:
            self._load()
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


class Shape(NamedTuple):
    """Which functions the kernel a block runs in the loop has (the loop skips a missing one,
    as the block's own calls do)."""

    evaluate: bool
    step: bool
    advance: bool = False

    @classmethod
    def of(cls, k: PythonKernel) -> Shape:
        return cls(k.evaluate is not None, k.step is not None, k.advance is not None)


def _step_of(system: System, name: str) -> float:
    """The communication step of component `name` [s]: its multiple of the base step."""
    return system.multiple(name) * system.experiment.step


def _warm(comp: Component, h: float, t: float) -> None:
    """Call the kernel `comp` runs with steps of `h` [s] once at `t` [s] on the values it
    holds, dropping the results (a call its values do not suit yet: left to the loop)."""
    k = bound_kernel(comp, h)
    if k is None:
        return
    d = comp.__dict__
    args = (d[KERNEL_STATE], tuple(d[p] for p in comp.outputs), tuple(d[p] for p in comp.inputs),
            k.params)
    with contextlib.suppress(Exception):
        if k.evaluate is not None:
            k.evaluate(t, *args)
        if k.step is not None:
            k.step(t, h, *args)


def _binder(comp: Component, h: float, shape: Shape) -> Callable[[], PythonKernel]:
    """`bind()`: the kernel `comp` runs with steps of `h` [s], which must still have `shape`."""
    def bind() -> PythonKernel:
        k = bound_kernel(comp, h)
        if k is None or Shape.of(k) != shape:
            raise CosimError(
                f"component '{comp.name}' ({type(comp).__name__}) offers another kernel than "
                f"when this run's step loop was generated. Fix: keep the parameters that "
                f"choose its kernel fixed during a run (or prepare the algorithm again).")
        return k
    return bind


def _generate(system: System, plan: Plan, kernels: Mapping[str, Shape]
              ) -> tuple[str, dict[int, tuple[str, str]], dict[str, Any]]:
    """(source, line owners, globals) of the step loop rendered from `plan`: `run(n0, n1, rows)`
    executes base steps n0..n1-1 and appends a flat tuple (t, values...) of the recorded ports
    to `rows` every `plan.decimation` steps; `finish(n, rows)` writes inputs and evaluates at
    the final point. The blocks in `kernels` are called through their kernels (ports in local
    variables y<i>_<k>, u<i>_<k>, state x<i>, parameters p<i>; see `_Kernels`), the others
    through their methods."""
    comps = system.components
    ids = {name: i for i, name in enumerate(plan.order)}
    env: dict[str, Any] = {}
    for name, comp in comps.items():
        i = ids[name]
        env[f"d{i}"] = comp.__dict__
        if name in kernels:
            env[f"bind{i}"] = _binder(comp, _step_of(system, name), kernels[name])
        else:
            env[f"ev{i}"] = comp.evaluate
            env[f"st{i}"] = comp.do_step
    kern = _Kernels(system, ids, kernels)

    w = Writer()
    for name in plan.order:
        i = ids[name]
        what = "kernel (x, p, ev, st; ports y_k, u_k)" if name in kernels else \
            "values, evaluate, do_step"
        w.add(0, f"# {i}: {name} ({type(comps[name]).__name__}): {what}")
    w.add(0, "def run(n0, n1, rows):")
    kern.prologue(w, 1)
    w.add(1, "try:")
    w.add(2, "for n in range(n0, n1):")
    w.add(3, "t = start + n * h")
    point(w, 3, plan, ids, kern.ref, final=False, evaluate=kern.evaluate)
    finite_check(w, 3, plan, kern.ref, kern.kernels.__contains__)
    record(w, 3, plan, kern.ref, final=False)
    lean = {n for n in advancing(system, plan) if n in kernels and kernels[n].advance}
    if lean:  # the last step of a call whole, as the compiled driver's chunks end
        w.add(3, "if n != n1 - 1:")
        _steps(w, 4, system, plan, ids, kern, env, lean)
        w.add(3, "else:")
    _steps(w, 4 if lean else 3, system, plan, ids, kern, env, set())
    kern.epilogue(w, 1)
    w.add(0, "def finish(n, rows):")
    kern.prologue(w, 1)
    w.add(1, "try:")
    w.add(2, "t = start + n * h")
    point(w, 2, plan, ids, kern.ref, final=True, evaluate=kern.evaluate)
    finite_check(w, 2, plan, kern.ref, kern.kernels.__contains__)
    record(w, 2, plan, kern.ref, final=True)
    kern.epilogue(w, 1)
    loops.render(w, plan, ids, kern.ref)
    env.update(start=system.experiment.start, h=system.experiment.step, nonfinite=nonfinite,
               Tick=Tick)
    return "\n".join(w.lines) + "\n", w.owner, env


def _steps(w: Writer, ind: int, system: System, plan: Plan, ids: dict[str, int],
           kern: _Kernels, env: dict[str, Any], lean: set[str]) -> None:
    """The lines of the steps after a point; the blocks in `lean` by their kernels' advance."""
    for s in plan.steps:
        i = ids[s.name]
        env[f"h{i}"] = s.multiple * system.experiment.step
        line = kern.step(s.name, s.time, s.name in lean) if s.name in kern.kernels else \
            f"st{i}({s.time}, h{i})"
        if line is not None:
            w.add(ind, line if s.guard is None else f"if {s.guard}: {line}", (s.name, "do_step"))


class _Kernels:
    """How the loop writes the blocks that run their kernels: their ports as locals y<i>_<k>
    (outputs and states, declared order) and u<i>_<k> (inputs), read from the component when a
    call of the loop starts and written back (with the state, through `sync<i>`) when it ends;
    the other blocks' ports as ``d<i>[port]``. Y<i> holds the tuple of outputs the kernel
    returned last, handed to its next call as it is."""

    def __init__(self, system: System, ids: dict[str, int], kernels: Mapping[str, Shape]):
        self.ids, self.kernels = ids, kernels
        comps = system.components
        self.outs = {n: list(comps[n].outputs) for n in kernels}
        self.ins = {n: list(comps[n].inputs) for n in kernels}

    def ref(self, name: str, port: str) -> str:
        i = self.ids[name]
        if name not in self.kernels:
            return f"d{i}[{port!r}]"
        if port in self.outs[name]:
            return f"y{i}_{self.outs[name].index(port)}"
        return f"u{i}_{self.ins[name].index(port)}"

    def _ports(self, name: str) -> list[tuple[str, str]]:
        """(port, local) of every port of kernel block `name`."""
        return [(p, self.ref(name, p)) for p in self.outs[name] + self.ins[name]]

    def prologue(self, w: Writer, ind: int) -> None:
        for name in self.kernels:
            i = self.ids[name]
            w.add(ind, f"p{i}, ev{i}, st{i}, ad{i}, sync{i} = bind{i}()", (name, "its kernel"))
            ports = [(KERNEL_STATE, f"x{i}"), *self._ports(name)]
            w.add(ind, ", ".join(v for _, v in ports) + " = " +
                  ", ".join(f"d{i}[{p!r}]" for p, _ in ports))
            w.add(ind, f"Y{i} = {tuple_of([self.ref(name, p) for p in self.outs[name]])}")

    def epilogue(self, w: Writer, ind: int) -> None:
        w.add(ind, "finally:")
        for name in self.kernels:
            i = self.ids[name]
            ports = self._ports(name)
            if ports:
                w.add(ind + 1, ", ".join(f"d{i}[{p!r}]" for p, _ in ports) + " = " +
                      ", ".join(v for _, v in ports))
            w.add(ind + 1, f"sync{i}(x{i})", (name, "its kernel's sync"))
        if not self.kernels:
            w.add(ind + 1, "pass")

    def _call(self, name: str, fn: str, args: str) -> str:
        """`x<i>, Y<i> = fn(args, x<i>, Y<i>, inputs, p<i>)` and the outputs unpacked: Y<i>, the
        tuple of outputs the kernel returned, goes back to it as it is."""
        i = self.ids[name]
        ys = [self.ref(name, p) for p in self.outs[name]]
        us = tuple_of([self.ref(name, p) for p in self.ins[name]])
        line = f"x{i}, Y{i} = {fn}{i}({args}, x{i}, Y{i}, {us}, p{i})"
        return f"{line}; {', '.join(ys)}{',' if len(ys) == 1 else ''} = Y{i}" if ys else line

    def evaluate(self, name: str) -> str | None:
        """The line of an evaluation of `name` (None: its kernel has no evaluate)."""
        if name not in self.kernels:
            return f"ev{self.ids[name]}(t)"
        return self._call(name, "ev", "t") if self.kernels[name].evaluate else None

    def step(self, name: str, time: str, lean: bool = False) -> str | None:
        """The line of a step of kernel block `name` from `time` (None: its kernel has none);
        `lean`: by its `advance` when it has one."""
        i, shape = self.ids[name], self.kernels[name]
        if not shape.step:
            return None
        return self._call(name, "ad" if lean and shape.advance else "st", f"{time}, h{i}")


