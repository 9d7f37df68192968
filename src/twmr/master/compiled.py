"""`CompiledStep`: the fixed-step Gauss-Seidel / Jacobi loop of `twmr.master.schedule`, compiled
with numba over the components' kernels, bit-identical to the Python schedule.

When every component of a system offers a kernel (`Component.kernel(h)` returns a `Kernel`), the
loop runs compiled, in one of two forms:

- the driver (`twmr.master.driver`): each kind of block (kernel functions and value shapes)
  compiled once, one driver loop for every scenario, never a compile per wiring or block count;
  the plan is laid out in flat arrays that the driver interprets. A rewired scenario of known
  kinds runs compiled at once.
- the loop generated for this system (below): every port value a local variable, one call per
  block, compiled per scenario. It runs the scenarios the driver does not hold: those with an FMU
  (called through its C functions), or a kernel value the driver's float vectors cannot hold
  (e.g. a complex number, an integer array, a NamedTuple that is not importable); and a system
  whose `own_loop_budget_s` covers loading or compiling it (`own_loop`: a built system run
  again and again, whose loop steps faster than the driver).

A kernel is two pure numba functions of the component's private state x (a tuple), its outputs y
(the tuple of its output and state ports, declared order), its inputs u (the tuple of its input
ports, declared order) and its parameters p (a tuple):

    evaluate(t, x, y, u, p) -> (x, y)        # the feedthrough outputs at t (FMI: get after set)
    step(t, h, x, y, u, p) -> (x, y)         # advance from t to t + h with u held

Either may be None (no feedthrough; nothing to advance). String parameters are resolved to codes
in `kernel()`, which runs after `initialize()`, so set-up decisions (a drive direction, a
discretisation) are made in Python once.

An FMI 2.0 or 3.0 co-simulation FMU joins the generated loop in mode 'on': the loop calls its C
functions itself, through what its `compiled_calls(h)` gives (`twmr.fmi.fmu.FmuComponent`,
`twmr.fmi.compiled_calls`), its Integer and Boolean ports carried as integers.

The generated module (a kind's adapters, or a scenario's loop) is written to the cache folder
(`TWMR_CACHE_DIR`, default ~/.cache/twmr/schedules) under a name hashing its source, the source
files of the kernels' packages and numba's version; numba's own cache (`cache=True`) then
reuses the machine code in every later process (sweep workers included). Parameters, initial
values, the step and the start time are arguments, so a sweep over parameter values compiles
once.

Selection: `TWMR_COMPILED=auto|on|off` (`twmr run --compiled`). `auto` (default) runs compiled
from the first step when every kind of the system is compiled already in this process, whatever
the run's length, or in numba's cache, for a run of at least `AUTO_MIN_STEPS` steps (loading it
imports numba: about half a second, more than a shorter run's Python steps); else it compiles a
run of at least `AUTO_MIN_STEPS` steps once the first chunk has run in Python, and runs a
shorter one in Python; FMUs and blocks without a kernel keep the Python schedule. `on` compiles
before the first step and makes a missing kernel an error; `off` always runs the Python
schedule.
"""
from __future__ import annotations

import logging
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.component import replaced_on_instance
from twmr.core.errors import CosimError, Location, Problem
from twmr.core.kernel import AUTO_MIN_STEPS, Kernel, compiled_pays
from twmr.core.port import CLOCK, TEXT_TYPES
from twmr.master import driver, stats
from twmr.master.algorithm import Algorithm, NonFinite
from twmr.master.plan import METHODS, Plan, Solve, Write, advancing, guard
from twmr.master.schedule import FixedStep
from twmr.master.ticks import binary_signals
from twmr.scenario.graph import find_loops
from twmr.scenario.system import System

MODES = ("auto", "on", "off")
log = logging.getLogger("twmr.run")
#: the recursion limit while numba compiles a generated loop (its SSA pass recurses per block)
SSA_RECURSION = 50_000
#: why a system with algebraic loops to solve keeps the Python schedule
LOOPS = "its algebraic loops are iterated by the Python schedule"
#: the most values (rows x columns) a run's recorded rows are written into one buffer for (a
#: longer run's chunks have buffers of their own: an observer that writes them to disk frees
#: them)
JOINED = 1 << 20
#: why a system that records Binary ports keeps the Python schedule
TICKS = "its recorded Binary ports are taken by the Python schedule"


class CompileError(CosimError):
    """`TWMR_COMPILED=on` but the system cannot run compiled (a block without a kernel...)."""


def compiled_mode() -> str:
    """The selection from `TWMR_COMPILED` ('auto' unless set)."""
    mode = os.environ.get("TWMR_COMPILED", "auto").strip().lower() or "auto"
    if mode not in MODES:
        raise CompileError(f"TWMR_COMPILED is '{mode}', which is not a mode of the compiled "
                           f"loop. Fix: set it to one of {', '.join(MODES)}, or unset it.")
    return mode


def cache_dir() -> Path:
    """Where the generated modules (and numba's cache of them) are kept."""
    env = os.environ.get("TWMR_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "twmr" / "schedules"


def _port_value(var: Any, value: Any, kind: str) -> Any:
    """A port's value as the compiled loop holds it (`kind` from `_carried`): a float, an
    int64 or a uint64 (wrapped into its range), a tuple of them, or 0.0 for a port the loop
    does not carry."""
    if kind == "x":
        return 0.0
    if var.size is None:
        return _number(value, kind)
    return tuple(_number(v, kind) for v in value)


def _number(value: Any, kind: str) -> Any:
    if kind == "f":
        return float(value)
    if kind == "u":
        return np.uint64(int(value) % 2**64)
    return np.int64((int(value) + 2**63) % 2**64 - 2**63)


def _carried(system: System, kernels: dict[str, Kernel]) -> dict[tuple[str, str], str]:
    """How the loop carries each port: 'f' float64, 'i' int64, 'u' uint64, 'b' int64 as a bool
    (`compiled_calls.carried`; an integer input as its source, so it holds the same value) or 'x'
    not at all (a String, Binary or Clock port of an FMU that the run neither sets nor
    reads)."""
    from twmr.fmi.compiled_calls import carried

    out: dict[tuple[str, str], str] = {}
    for name in system.order:
        comp = system.components[name]
        fmu = kernels[name].fmu
        fmi = {p.name: p.fmi_type for p in getattr(comp, "ports", ())} if fmu else {}
        for port, var in {**comp.outputs, **comp.inputs}.items():
            out[name, port] = "x" if var.type in (*TEXT_TYPES, CLOCK) else \
                carried(fmi.get(port, "Real"), bool(fmu and fmu.fmi3)) if var.type != "Real" \
                else "f"
    for conn in system.connections:
        dst = (conn.dst, conn.dst_port)
        if out[dst] in ("i", "u", "b") and conn.dst_index is None and conn.src_index is None:
            out[dst] = out[conn.src, conn.src_port]
    return out


class CompiledStep(Algorithm):
    """Fixed base step h, 'gauss_seidel' or 'jacobi', compiled with numba when every component
    offers a kernel (`mode` 'auto' | 'on'); else the Python `FixedStep` runs (mode 'auto')."""

    def __init__(self, method: str = "gauss_seidel", mode: str = "auto", use_driver: bool = True):
        if method not in METHODS:
            raise ValueError(f"unknown fixed-step method {method!r}; use one of {METHODS}")
        self.method = method
        self.outputs_as_stepped = method == "jacobi"
        self.mode = mode
        #: False: the loop generated for this scenario even where the driver would
        #: run (the benchmark's "before")
        self.use_driver = use_driver
        self.python = FixedStep(method)
        self.compiled = False
        self._pending = False
        self.reason = ""
        self.compile_seconds = float("nan")
        #: the driver's loop (`twmr.master.driver_loop`; None: the generated loop, or Python)
        self._driver: Any = None
        #: whether numba compiled (or loaded from its cache) a kind's adapters or the driver for
        #: this run
        self.driver_compiled = False
        self._source: str | None = ""
        #: the kinds the driver runs (their adapters are the source shown)
        self._kinds_run: list[driver.KindSpec] = []

    # -- Algorithm ---------------------------------------------------------------------------
    def refuse(self, system: System) -> Problem | None:
        binary = binary_signals(system, system.record.signals) if self.mode == "on" else []
        if binary:
            names = ", ".join(f"'{b.name}.{b.port}'" for b in binary)
            return Problem(Location(system.source, 0, "record.signals"),
                           f"the compiled loop (--compiled on) does not record Binary ports "
                           f"({names}): {TICKS}.", "run with --compiled auto or off "
                           "(TWMR_COMPILED), or leave those ports out of 'record: signals'.")
        if self.mode != "on" or self.method != "gauss_seidel" or \
                system.experiment.loops != "solve" or \
                not find_loops(system.components, system.connections)[0]:
            return None
        return Problem(Location(system.source, 0, "experiment.loops"),
                       f"the compiled loop (--compiled on) does not run 'loops: solve': "
                       f"{LOOPS}.", "run with --compiled auto or off (TWMR_COMPILED).")

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        self.python.timing = self.timing
        self.python.prepare(system, record, decimation, check_finite)
        held = system.__dict__.get(_HELD_LOOP)
        if held is not None:  # a lock on compiling it that a run took and did not compile under
            held.release()
        self._source, self._kinds_run = None, []
        self.compiled, self._driver = False, None  # chosen again by this run's `start`
        #: the run's recorded rows (`_buffer`), made at its first compiled chunk
        self._rows: np.ndarray | None = None
        self._taken = 0
        self._system, self._record, self._decimation = system, record, decimation
        self._check = check_finite

    def start(self) -> None:
        """Compile now (mode 'on', or a paced run: never while the clock runs), or once the
        first chunk has run in Python (mode 'auto': a stop signal during compilation then
        finds rows saved), or not at all (a run shorter than `AUTO_MIN_STEPS`). Mode 'auto'
        compiles from the first step when every kind is compiled already: held by this process
        (any run), or in numba's cache (a run of at least `AUTO_MIN_STEPS`: loading it imports
        numba, which costs a short run more than its Python steps). A run that starts on the
        Python schedule starts it now (`FixedStep.start`)."""
        self._pending = False
        long = compiled_pays(self._system.experiment.n_steps)
        if self.mode == "on" or self._system.paced:
            self._compile()
        elif (ready := self._ready(long)) is not None:
            self._compile(ready)
        elif long:
            self._pending = True
        else:
            self.reason = f"a short run ({self._system.experiment.n_steps} < " \
                          f"{AUTO_MIN_STEPS} steps) with kinds not held by this process"
        if not self.compiled:
            self.python.start()

    def _ready(self, cached: bool
               ) -> tuple[dict[str, Kernel], dict[str, driver.KindSpec] | None] | None:
        """Mode 'auto': the kernels and kinds of the system when every kind of it is compiled
        already (held by this process, or, if `cached`, in numba's cache), or the system's own
        loop that it takes (`own_loop`) is, so the whole run can be compiled from its first
        step (kinds None: the loop runs, they are made only if it fails); else None."""
        plan = self.python.plan
        assert plan is not None
        if plan.ticks:
            return None
        kernels, _ = _kernels(self._system, self._record, False)
        if kernels is None or not self.use_driver:
            return None
        loop = own_loop(self._system, plan, kernels)
        if loop is not None and (loop.typed or (cached and loop.in_cache())):
            return kernels, None
        kinds = _kinds(self._system, kernels)
        if kinds is None:
            return None
        found = list(kinds.values())
        return (kernels, kinds) if driver.held(found) or (
            cached and driver.cached(found, cache_dir())) else None

    def _compile(self, ready: tuple[dict[str, Kernel], dict[str, driver.KindSpec] | None]
                 | None = None) -> None:
        """Collect the kernels from the components as they are now (initialized, maybe stepped
        by the Python schedule; `ready`: those and their kinds just collected) and compile the
        loop; on failure keep the Python schedule (mode 'auto') or raise `CompileError` (mode
        'on')."""
        system = self._system
        assert self.python.plan is not None
        if self.python.plan.loops or self.python.plan.ticks:
            self.reason = LOOPS if self.python.plan.loops else TICKS
            return
        kernels, self.reason = (ready[0], "") if ready is not None else \
            _kernels(system, self._record, self.mode == "on")
        if kernels is None:
            if self.mode == "on":
                raise CompileError(
                    f"the run cannot be compiled: {self.reason}. Fix: run with "
                    f"TWMR_COMPILED=auto (or --compiled auto) to use the Python schedule.")
            return
        t0 = time.perf_counter()
        order = list(system.order)
        comps = system.components
        self._kernels = [kernels[n] for n in order]
        self._comps = [comps[n] for n in order]
        kinds = ready[1] if ready is not None else \
            _kinds(system, kernels) if self.use_driver else None
        if kinds is not None and own_loop(system, self.python.plan, kernels) is None:
            self._compile_driver(kinds, kernels, t0)
            return
        failure = self._compile_loop(kernels, t0)
        if failure is not None and kinds is None and self.use_driver:  # `_ready`'s own loop
            kinds = _kinds(system, kernels)
        if failure is not None and kinds is not None:
            log.debug("the system's own loop did not compile (%s); the driver runs it", failure)
            self._compile_driver(kinds, kernels, t0)
        elif failure is not None:
            self._refuse(failure)

    def _compile_loop(self, kernels: dict[str, Kernel], t0: float) -> Exception | None:
        """Take (or generate and compile) the loop generated for the system (`held_loop`); the
        failure, if numba cannot compile it."""
        assert self.python.plan is not None
        try:
            loop = held_loop(self._system, self.python.plan, kernels)
        except Exception as exc:  # noqa: BLE001 - a kernel the loop cannot be made of
            return exc
        try:
            return self._take_loop(loop, t0)
        finally:
            loop.release()

    def _take_loop(self, loop: HeldLoop, t0: float) -> Exception | None:
        """Load `loop` (compiled now, or from numba's cache, for this run's argument types);
        the failure, if numba cannot compile it."""
        system = self._system
        order = list(system.order)
        comps = system.components
        exp = system.experiment
        try:
            self._run, self._finish = loop.functions()
        except Exception as exc:  # noqa: BLE001 - a kernel the loop cannot be made of
            return exc
        self._P = tuple(k.params for k in self._kernels)
        self._X = tuple(k.state for k in self._kernels)
        carried = loop.carried
        self._writes = loop.writes
        self._Y = tuple(tuple(_port_value(v, comps[n].__dict__[p], carried[n, p])
                              for p, v in comps[n].outputs.items()) for n in order)
        self._U = tuple(tuple(_port_value(v, comps[n].__dict__[p], carried[n, p])
                              for p, v in comps[n].inputs.items()) for n in order)
        self._H = tuple(system.multiple(n) * exp.step for n in order)
        self._ncols = 1 + sum(comps[n].variables[p].width for n, p in self._record)
        if not loop.typed:  # compiled for this system's argument types before (else on call)
            # compile (or load from numba's cache) now, for the argument types of this run
            from numba import typeof

            buf = np.empty((1, self._ncols))
            # numba's SSA pass recurses once per block of the loop: every FMU call is a branch
            limit = sys.getrecursionlimit()
            sys.setrecursionlimit(max(limit, SSA_RECURSION))
            try:
                self._run.compile(tuple(typeof(a) for a in (
                    0, 0, exp.start, exp.step, self._H, self._P, self._X, self._Y, self._U,
                    buf, self._decimation)))
                self._finish.compile(tuple(typeof(a) for a in (
                    0, exp.start, exp.step, self._P, self._X, self._Y, self._U, buf)))
            except Exception as exc:  # noqa: BLE001 - a kernel numba cannot compile
                return exc
            finally:
                sys.setrecursionlimit(limit)
            loop.typed = True
        self.compile_seconds = time.perf_counter() - t0
        self._source = loop.source
        self.compiled = True
        return None

    def _compile_driver(self, kinds: dict[str, driver.KindSpec], kernels: dict[str, Kernel],
                        t0: float) -> None:
        """Take (or compile) the adapters of the system's kinds and lay the plan out for the
        driver."""
        try:
            addresses, fresh = driver.load(list(kinds.values()), cache_dir)
            from twmr.master import driver_loop
        except Exception as exc:  # noqa: BLE001 - a kernel numba cannot compile
            self._refuse(exc)
            return
        assert self.python.plan is not None
        self._layout = driver.held_layout(self._system, self.python.plan, kernels, addresses,
                                          kinds)
        self._ncols = 1 + len(self._layout.rec) if self._record else 1
        self._driver = driver_loop
        self.driver_compiled = fresh > 0
        self.compile_seconds = time.perf_counter() - t0
        self._kinds_run = list(kinds.values())
        self.compiled = True

    @property
    def source(self) -> str:  # type: ignore[override]
        """The loop running: the generated one, the driver's adapters of the system's kinds
        (rendered when asked), or the Python schedule's."""
        if self._source is None:
            if not self.compiled:
                return self.python.source
            self._source = "\n".join(dict.fromkeys(driver.generate(k)[0]
                                                   for k in self._kinds_run))
        return self._source

    def _refuse(self, exc: Exception) -> None:
        """numba failed on the loop: the Python schedule (mode 'auto') or `CompileError`."""
        self.reason = f"numba could not compile it ({type(exc).__name__}: " \
                      f"{str(exc).splitlines()[0] if str(exc) else ''})"
        if self.mode == "on":
            raise CompileError(
                f"the run cannot be compiled: {self.reason}. Fix: correct the kernel or run "
                f"with TWMR_COMPILED=auto to use the Python schedule.") from exc
        log.warning("running the Python schedule: %s", self.reason)

    def _run_driver(self, drv: Any, n0: int, n1: int, buf: np.ndarray,
                    rows: list[Any]) -> None:
        lay, exp = self._layout, self._system.experiment
        k, bad = drv.run(n0, n1, exp.start, exp.step, lay.S, lay.X, lay.P, lay.ops,
                                  lay.gains, lay.blocks, lay.steps, lay.H, lay.chk, lay.rec, buf,
                                  self._decimation)
        self._sync_driver(rows, buf, k, bad)

    def _sync_driver(self, rows: list[Any], buf: np.ndarray, k: int, bad: int) -> None:
        """As `_sync`, from the driver's vectors."""
        lay = self._layout
        values, states = lay.S.tolist(), lay.X.tolist()
        for comp, kern, ports, (xo, shape) in zip(self._comps, self._kernels, lay.ports,
                                                  lay.state, strict=True):
            d = comp.__dict__
            for port, o, size in ports:
                d[port] = values[o] if size is None else tuple(values[o:o + size])
            if kern.sync is not None:
                kern.sync(driver.rebuild(states, xo, shape)[0])
        if k and self._record:
            rows.append(buf[:k])
        if bad >= 0:
            exp = self._system.experiment
            raise NonFinite(exp.start + bad * exp.step)

    def _call(self, fn: Any, n0: int, n1: int, buf: np.ndarray) -> tuple[int, int, int, int]:
        exp = self._system.experiment
        self._X, self._Y, self._U, *rest = fn(n0, n1, exp.start, exp.step, self._H, self._P,
                                              self._X, self._Y, self._U, buf, self._decimation)
        return tuple(rest)

    def _sync(self, rows: list[Any], buf: np.ndarray, k: int, bad: int, fail: int = -1,
              status: int = 0) -> None:
        """Port values back into the components, their `sync`, the rows to `rows`; a NaN/Inf
        found at step `bad` raises `NonFinite` (the components then hold the values seen)."""
        for comp, kern, x, y, u, writes in zip(self._comps, self._kernels, self._X, self._Y,
                                               self._U, self._writes, strict=True):
            d = comp.__dict__
            for (names, some), values in zip(writes, (y, u), strict=True):
                if some is None:
                    d.update(zip(names, values, strict=False))
                    continue
                for port, j, flag in some:
                    value = values[j]
                    d[port] = bool(value) if flag and not isinstance(value, tuple) else value
            if kern.sync is not None:
                kern.sync(x)
        if k and self._record:
            rows.append(buf[:k])
        if bad >= 0:
            exp = self._system.experiment
            t = exp.start + bad * exp.step
            if fail >= 0:
                from twmr.fmi.compiled_calls import CALLS, call_names

                fmu = self._kernels[fail // CALLS].fmu
                assert fmu is not None
                raise fmu.error(call_names(fmu)[fail % CALLS], status, t)
            raise NonFinite(t)

    def advance(self, n0: int, n1: int, rows: list[Any]) -> int:
        if self._pending and n0 > 0:
            self._pending = False
            self._compile()
        if not self.compiled:
            return self.python.advance(n0, n1, rows)
        d = self._decimation
        count = len(range(-(-n0 // d) * d, n1, d)) if self._record else 0
        if self._rows is None and self._record:  # the first compiled chunk
            left = len(range(-(-n0 // d) * d, self._system.experiment.n_steps, d)) + 1
            self._rows = np.empty((left if left * self._ncols <= JOINED else 0, self._ncols))
        buf = self._buffer(count)
        if self._driver is not None:
            self._run_driver(self._driver, n0, n1, buf, rows)
        else:
            self._sync(rows, buf, *self._call(self._run, n0, n1, buf))
        return n1

    def _buffer(self, count: int) -> np.ndarray:
        """Room for the next `count` recorded rows: the rows of the run's one buffer after those
        handed out (consecutive views, which `ResultStore.data` joins without a copy), or a
        buffer of their own."""
        start, whole = self._taken, self._rows
        if whole is None or start + count > len(whole):  # (None: no row recorded)
            return np.empty((count, self._ncols))
        self._taken = start + count
        return whole[start:start + count]

    def finish(self, n: int, rows: list[Any]) -> None:
        if not self.compiled:
            self.python.finish(n, rows)
            return
        exp = self._system.experiment
        buf = self._buffer(1)
        if self._driver is not None:
            lay = self._layout
            self._sync_driver(rows, buf, *self._driver.finish(
                n, exp.start, exp.step, lay.S, lay.X, lay.P, lay.ops, lay.gains, lay.blocks,
                lay.chk, lay.rec, buf))
            return
        self._X, self._Y, self._U, *rest = self._finish(n, exp.start, exp.step, self._P,
                                                        self._X, self._Y, self._U, buf)
        self._sync(rows, buf, *rest)

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        return self.python.locate(exc)

    def statistics(self, steps_done: int, finished: bool) -> dict[str, object]:
        if not self.compiled:
            return self.python.statistics(steps_done, finished)
        assert self.python.plan is not None
        return stats.document(stats.fixed_step(self.python.plan, steps_done, finished, []), [])

    def report(self) -> dict[str, Any]:
        out: dict[str, Any] = {"compiled": self.compiled}
        if self.compiled:
            out["compile_s"] = self.compile_seconds
            out["driver"] = self._driver is not None
            if self._driver is not None:
                out["driver_compiled"] = self.driver_compiled
        elif self.reason:
            out["not_compiled"] = self.reason
        return out


def fixed_step(method: str, compiled: str = "auto") -> Algorithm:
    """The fixed-step `method` ('gauss_seidel' | 'jacobi'): the Python schedule when `compiled`
    is 'off', else compiled with numba as `compiled` ('auto' | 'on') says."""
    return FixedStep(method) if compiled == "off" else CompiledStep(method, compiled)


def gauss_seidel(compiled: str = "auto") -> Algorithm:
    """Fixed-step Gauss-Seidel (registered as 'gauss_seidel' in `twmr.algorithms`)."""
    return fixed_step("gauss_seidel", compiled)


def jacobi(compiled: str = "auto") -> Algorithm:
    """Fixed-step Jacobi (registered as 'jacobi' in `twmr.algorithms`)."""
    return fixed_step("jacobi", compiled)


#: the kinds of variable that are ports (`Component.inputs` and `Component.outputs`)
_PORTS = ("input", "output", "state")


def _kernels(system: System, record: list[tuple[str, str]], fmus: bool
             ) -> tuple[dict[str, Kernel] | None, str]:
    from twmr.fmi.compiled_calls import NotCompilable

    """Every component's kernel, or None and why not; FMU blocks get one when `fmus` (mode
    'on': in 'auto' an FMU keeps the Python loop, whose chunks of steps are smaller — a crash
    inside the FMU's code then loses fewer rows)."""
    comps = system.components
    for name, port in record:
        if comps[name].variables[port].kind not in ("input", "output", "state"):
            return None, f"'{name}.{port}' is recorded but is not a port"
    kernels: dict[str, Kernel] = {}
    h = system.experiment.step
    for name in system.order:
        comp = comps[name]
        make = getattr(comp, "kernel", None)
        if make is None and fmus:
            make = getattr(comp, "compiled_calls", None)
        if replaced_on_instance(comp):
            return None, f"'{name}' has its methods replaced on the instance"
        owner = next((k for k in type(comp).__mro__ if "kernel" in vars(k)), None)
        if owner is not None and any(getattr(type(comp), m) is not getattr(owner, m)
                                     for m in ("evaluate", "do_step")):
            return None, f"'{name}' ({type(comp).__name__}) overrides the methods its " \
                         f"kernel mirrors"
        try:
            kern = make(system.multiple(name) * h) if make is not None else None
        except NotCompilable as exc:
            return None, str(exc)
        if kern is None:
            return None, f"'{name}' ({type(comp).__name__}) offers no compiled kernel " \
                         f"with these parameters"
        if kern.fmu is None and any(v.type != "Real" and v.kind in _PORTS
                                    for v in comp.variables.values()):
            port, var = next((p, v) for p, v in {**comp.inputs, **comp.outputs}.items()
                             if v.type != "Real")
            return None, f"port '{name}.{port}' is {var.type}, not Real"
        if kern.evaluate is None and kern.fmu is None and comp.has_feedthrough:
            return None, f"'{name}' has feedthrough but its kernel no evaluate"
        kernels[name] = kern
    return kernels, ""


def _kinds(system: System, kernels: dict[str, Kernel]) -> dict[str, driver.KindSpec] | None:
    """Every component's kind for the driver, or None: an FMU among them, or a value the
    driver cannot hold (the generated loop then runs it)."""
    if any(k.fmu is not None for k in kernels.values()):
        return None
    try:
        return {n: driver.kind_of(system.components[n], kernels[n]) for n in system.order}
    except driver.Unsupported as exc:
        log.debug("compiling the loop of this scenario (not the driver): %s", exc)
        return None


class _Lines:
    def __init__(self) -> None:
        self.lines: list[str] = []

    def add(self, indent: int, text: str) -> None:
        self.lines.append("    " * indent + text)


def _tuple(items: list[str]) -> str:
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def _generate(system: System, plan: Plan, kernels: dict[str, Kernel],
              kinds: dict[tuple[str, str], str]) -> tuple[str, dict[str, Any]]:
    """(source, {name: kernel function}) of `run(n0, n1, start, h, H, P, X, Y, U, buf, dec)` and
    `finish(n, start, h, P, X, Y, U, buf)` rendered from `plan` over `kernels`; both return (X, Y,
    U, rows written, the step of a NaN/Inf or of a failed FMU call or -1, `compiled_calls.CALLS` *
    component index + the call's index (`compiled_calls.call_names`) of that failure or -1, its
    status). Port values are carried as `kinds` says; a Real input written from an Integer or
    Boolean source gets the source's value as a float."""
    from twmr.fmi.compiled_calls import call_lines

    comps = system.components
    order = plan.order
    ids = {name: i for i, name in enumerate(order)}
    outs = {n: list(comps[n].outputs) for n in order}
    ins = {n: list(comps[n].inputs) for n in order}
    names: dict[str, Any] = {}
    for name in order:
        i, k = ids[name], kernels[name]
        if k.evaluate is not None:
            names[f"ev{i}"] = k.evaluate
        if k.step is not None:
            names[f"st{i}"] = k.step
    lean = {n for n in advancing(system, plan) if kernels[n].advance is not None}
    for name in lean:
        names[f"ad{ids[name]}"] = kernels[name].advance

    def local(name: str, port: str) -> str:
        if port in outs[name]:
            return f"y{ids[name]}_{outs[name].index(port)}"
        return f"u{ids[name]}_{ins[name].index(port)}"

    def call(name: str, fn: str, args: str) -> list[str]:
        fmu = kernels[name].fmu
        if fmu is not None:
            return call_lines(fmu, ids[name], None if fn == "ev" else args,
                              not comps[name].has_feedthrough, lambda p: local(name, p),
                              lambda p: comps[name].variables[p].size is None)
        i = ids[name]
        ys = [f"y{i}_{k}" for k in range(len(outs[name]))]
        us = [f"u{i}_{k}" for k in range(len(ins[name]))]
        lines = [f"r = {fn}{i}({args}, x{i}, {_tuple(ys)}, {_tuple(us)}, p{i})",
                 f"x{i} = r[0]"]
        lines += [f"{y} = r[1][{k}]" for k, y in enumerate(ys)]
        return lines

    def write(action: Write) -> str:
        text = plan.assignment(action, local)
        if kinds[action.name, action.port] == "f" and \
                comps[action.name].variables[action.port].size is None and \
                any(kinds[s] != "f" for s in action.sources):
            cur, value = text.split(" = ", 1)
            return f"{cur} = float({value})"
        return text

    def point(w: _Lines, ind: int, final: bool) -> None:
        for k, (src, port) in enumerate(plan.snapshot):
            w.add(ind, f"s{k} = {local(src, port)}")
        for action in plan.point:
            assert not isinstance(action, Solve), "a loop to solve is refused before"
            lines = [write(action)] if isinstance(action, Write) \
                else call(action.name, "ev", "t")
            cond = None if final else guard(action)
            if cond is not None:
                w.add(ind, f"if {cond}:")
            for line in lines:
                w.add(ind + (cond is not None), line)

    def check(w: _Lines, ind: int, then: str) -> None:
        if not plan.check:
            return
        # the association of the Python schedule's `sum(port) + ...`, chunk by chunk
        sums = [" + ".join("(" + (" + ".join(f"{local(s.name, s.port)}[{k}]"
                                             for k in range(s.size))
                                  if s.size is not None else local(s.name, s.port)) + ")"
                           for s in chunk) for chunk in plan.check]
        if len(sums) == 1:
            w.add(ind, "v = " + sums[0])
        else:
            w.add(ind, "v = 0.0")
            for chunk_sum in sums:
                w.add(ind, f"v = v + ({chunk_sum})")
        w.add(ind, f"if v - v != 0.0: {then}")

    def rec(w: _Lines, ind: int) -> None:
        if not plan.record:
            return
        w.add(ind, "buf[k, 0] = t")
        col = 1
        for s in plan.record:
            v = local(s.name, s.port)
            if s.size is None:
                w.add(ind, f"buf[k, {col}] = {v}")
                col += 1
            else:
                for e in range(s.size):
                    w.add(ind, f"buf[k, {col}] = {v}[{e}]")
                    col += 1
        w.add(ind, "k += 1")

    def unpack(w: _Lines) -> None:
        for name in order:
            i = ids[name]
            w.add(1, f"x{i} = X[{i}]")
            w.add(1, f"p{i} = P[{i}]")
            for k in range(len(outs[name])):
                w.add(1, f"y{i}_{k} = Y[{i}][{k}]")
            for k in range(len(ins[name])):
                w.add(1, f"u{i}_{k} = U[{i}][{k}]")
        w.add(1, "k = 0")
        w.add(1, "bad = -1")
        w.add(1, "fail = -1")
        w.add(1, "fstat = 0")

    def pack(w: _Lines) -> None:
        xs = _tuple([f"x{ids[n]}" for n in order])
        ys = _tuple([_tuple([f"y{ids[n]}_{k}" for k in range(len(outs[n]))]) for n in order])
        us = _tuple([_tuple([f"u{ids[n]}_{k}" for k in range(len(ins[n]))]) for n in order])
        w.add(1, f"return {xs}, {ys}, {us}, k, bad, fail, fstat")

    def steps(w: _Lines, ind: int, lean: set[str]) -> None:
        for st in plan.steps:
            if kernels[st.name].step is None and kernels[st.name].fmu is None:
                continue
            fn = "ad" if st.name in lean else "st"
            lines = call(st.name, fn, f"{st.time}, h{ids[st.name]}")
            if st.guard is not None:
                w.add(ind, f"if {st.guard}:")
            for line in lines:
                w.add(ind + (st.guard is not None), line)

    w = _Lines()
    w.add(0, f"# generated by twmr.master.compiled: {plan.method}")
    for name in order:
        w.add(0, f"# component {ids[name]}: {name} ({type(comps[name]).__name__})")
    w.add(0, "from numba import njit")
    if any(k.fmu is not None for k in kernels.values()):
        w.add(0, "from numpy import float64, int64, uint64")
    for key, fn in names.items():
        w.add(0, f"from {fn.__module__} import {fn.__qualname__} as {key}")
    w.add(0, "")
    w.add(0, "")
    w.add(0, "@njit(cache=True, error_model='numpy')")
    w.add(0, "def run(n0, n1, start, h, H, P, X, Y, U, buf, dec):")
    unpack(w)
    for name in order:
        w.add(1, f"h{ids[name]} = H[{ids[name]}]")
    w.add(1, "for n in range(n0, n1):")
    w.add(2, "t = start + n * h")
    point(w, 2, final=False)
    check(w, 2, "bad = n; break")
    if plan.record:
        w.add(2, "if n % dec == 0:")
        rec(w, 3)
    if lean:  # the last step of a call whole, as the driver's chunks end
        w.add(2, "if n != n1 - 1:")
        steps(w, 3, lean)
        w.add(2, "else:")
    steps(w, 3 if lean else 2, set())
    pack(w)
    w.add(0, "")
    w.add(0, "")
    w.add(0, "@njit(cache=True, error_model='numpy')")
    w.add(0, "def finish(n, start, h, P, X, Y, U, buf):")
    unpack(w)
    w.add(1, "t = start + n * h")
    w.add(1, "for _ in range(1):  # a block to break out of")
    point(w, 2, final=True)
    check(w, 2, "bad = n; break")
    rec(w, 2)
    pack(w)
    return "\n".join(w.lines) + "\n", names


def _writes(system: System, carried: dict[tuple[str, str], str]) -> list[tuple[Any, ...]]:
    """Per component of the system's order, how `CompiledStep._sync` writes the loop's port
    values back, for its outputs and for its inputs: (names, None) when it writes every one as
    the loop holds it, else (names, ((port, index, as a bool), ...)) of those it writes."""
    out = []
    for name in system.order:
        comp, row = system.components[name], []
        for ports in (comp.outputs, comp.inputs):
            kinds = [carried[name, p] for p in ports]
            some = None if all(k not in ("x", "b") for k in kinds) else tuple(
                (p, j, k == "b") for j, (p, k) in enumerate(zip(ports, kinds, strict=True))
                if k != "x")
            row.append((tuple(ports), some))
        out.append(tuple(row))
    return out


#: where `held_loop` keeps a system's loop
_HELD_LOOP = "_twmr_held_loop"


class HeldLoop:
    """A system's generated loop (`_generate`): its source, kernel functions and port carriage,
    for the plan and kernel functions it was made for, and `run`/`finish` once loaded; `typed`:
    compiled for the system's argument types (a later run with other types compiles on call)."""

    def __init__(self, system: System, plan: Plan, key: tuple, source: str,
                 names: dict[str, Any], carried: dict[tuple[str, str], str]):
        self.plan, self.key, self.source, self.names, self.carried = plan, key, source, names, \
            carried
        self.loaded: tuple[Any, Any] | None = None
        self.cached: bool | None = None
        self._asked = 0.0  # when `cached` was asked [s, time.monotonic]
        self._claim: Any = None  # the lock on compiling the loop (`claim`)
        self.typed = False
        self.writes = _writes(system, carried)

    def functions(self) -> tuple[Any, Any]:
        """(run, finish), loaded on first use (`_load`)."""
        if self.loaded is None:
            self.loaded = _load(self.source, self.names)
        return self.loaded

    def in_cache(self) -> bool:
        """Whether the loop's machine code is at hand without compiling: loaded by this process
        or in numba's cache (a 'no' is asked again after `RECHECK_S`: another process may
        have compiled it since)."""
        if self.cached is None or (not self.cached and
                                   time.monotonic() - self._asked >= RECHECK_S):
            from twmr.master import schedule_cache

            self._asked = time.monotonic()
            self.cached = self.loaded is not None or (
                self._shared() and
                schedule_cache.has_machine_code(self.source, self.names, cache_dir()))
        return self.cached

    def claim(self) -> bool:
        """Take the lock on compiling the loop (`schedule_cache.claim`, held until `release`):
        False while another process holds it, i.e. compiles the loop into the cache folder,
        where this process finds it later (`in_cache`). A loop compiled per process
        (a kernel not importable) needs no lock."""
        if self._claim is None:
            from twmr.master import schedule_cache

            self._claim = schedule_cache.claim(self.source, self.names, cache_dir()) \
                if self._shared() else True
        return self._claim is not None

    def release(self) -> None:
        """Let go of the lock on compiling the loop (`claim`), if held."""
        if self._claim is not None and self._claim is not True:
            self._claim.close()
        self._claim = None

    def _shared(self) -> bool:
        """Whether the loop is compiled into the cache folder, for every process."""
        return all(_importable(fn) for fn in self.names.values())


def held_loop(system: System, plan: Plan, kernels: dict[str, Kernel]) -> HeldLoop:
    """The loop generated for `system` under `plan` over `kernels`, kept on the system and
    handed out again (loaded once, compiled once) for the same plan object
    (`plan.held_build`: the same variables and wires), kernel functions and FMU calls (what
    the port carriage, `_carried`, depends on besides), as for a built system run again with
    other values (`twmr.build`)."""
    key = tuple((k.evaluate, k.step, k.advance, k.fmu) for k in (kernels[n] for n in plan.order))
    held = system.__dict__.get(_HELD_LOOP)
    if held is None or held.plan is not plan or held.key != key:
        carried = _carried(system, kernels)
        source, names = _generate(system, plan, kernels, carried)
        held = system.__dict__[_HELD_LOOP] = HeldLoop(system, plan, key, source, names,
                                                            carried)
    return held


#: what taking a system's own loop costs [s] in a process that has run the system (its kernels
#: loaded and in numba's cache): loaded from numba's cache, compiled afresh (the paper
#: scenario's: 0.02-0.03 s and 2.1-2.5 s, `benchmarks/compiled_schedule.py`: `own_loop_load_s`,
#: `own_loop_compile_s`)
OWN_LOOP_LOAD_S, OWN_LOOP_COMPILE_S = 0.03, 2.5
#: how long a process runs the driver before asking numba's cache again for a loop it did not
#: find there [s]
RECHECK_S = 1.0
#: the part of the driver's stepping time a system's own loop saves, at least (the paper
#: scenario's: 0.270 against 0.352 us a step, `benchmarks/compiled_schedule.py`)
OWN_LOOP_SAVING = 0.2


def own_loop(system: System, plan: Plan, kernels: dict[str, Kernel]) -> HeldLoop | None:
    """The loop generated for a system the driver can run, when the system takes it instead:
    its `own_loop_budget_s` covers loading it when numba's cache (or this process) holds it,
    or compiling it, unless another process is compiling it (`HeldLoop.claim`: the driver
    runs until that process has put it in the cache); else None (a loop that cannot be made
    too)."""
    budget = system.own_loop_budget_s
    if budget < OWN_LOOP_LOAD_S:
        return None
    try:
        loop = held_loop(system, plan, kernels)
    except Exception:  # noqa: BLE001 - a loop that cannot be made: the driver runs
        return None
    if loop.in_cache():
        return loop
    return loop if budget >= OWN_LOOP_COMPILE_S and loop.claim() else None


def _importable(fn: Any) -> bool:
    mod = sys.modules.get(getattr(fn, "__module__", ""), None)
    name = getattr(fn, "__qualname__", "<none>")
    return mod is not None and getattr(mod, name, None) is fn and "<" not in name


def _load(source: str, names: dict[str, Any]) -> tuple[Any, Any]:
    """(run, finish) from `source`: as a module file in the cache folder, verified, so numba's
    cache holds across processes (`twmr.master.schedule_cache`), when every kernel is
    importable; else exec'd, compiled per process."""
    if all(_importable(fn) for fn in names.values()):
        from twmr.master import schedule_cache

        try:
            return schedule_cache.load(source, names, cache_dir())
        except OSError as exc:  # a cache folder we cannot write: compile in this process
            log.debug("schedule cache not usable (%s); compiling without it", exc)
    env: dict[str, Any] = dict(names)
    body = "\n".join(line for line in source.splitlines()
                     if not line.startswith("from ") or line.startswith(("from numba",
                                                                         "from numpy")))
    exec(compile(body.replace("cache=True", "cache=False"),  # noqa: S102 - generated here
                 "<twmr compiled schedule>", "exec"), env)
    return env["run"], env["finish"]
