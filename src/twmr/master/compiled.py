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
import sys
import time
from collections.abc import Collection
from typing import Any

import numpy as np

from twmr.core.errors import Location, Problem
from twmr.core.kernel import AUTO_MIN_STEPS, Kernel, compiled_pays
from twmr.master import driver, scenario_loop, stats
from twmr.master.algorithm import Algorithm, CompileError, NonFinite
from twmr.master.compile_progress import compile_progress
from twmr.master.plan import METHODS
from twmr.master.scenario_loop import (
    HELD_LOOP,
    HeldLoop,
    held_loop,
    kernels_of,
    kinds_of,
    own_loop,
    port_value,
)
from twmr.master.schedule import FixedStep
from twmr.master.ticks import binary_signals
from twmr.scenario.graph import find_loops
from twmr.scenario.system import System

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
        #: why the run was compiled (mode, kinds compiled already, a long run)
        self.why = ""
        self.compile_seconds = float("nan")
        #: the step at which the loop was compiled during the run (0: before it, mode 'auto'
        #: compiles once a first chunk has run in Python when nothing is cached)
        self.compiled_in_run = 0
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
        held = system.__dict__.get(HELD_LOOP)
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
        n = self._system.experiment.n_steps
        long = compiled_pays(n)
        if self.mode == "on" or self._system.paced:
            self.why = "--compiled on" if self.mode == "on" else \
                "a paced run (compiled before its clock starts)"
            self._compile()
        elif (ready := self._ready(long)) is not None:
            self.why = "every kind compiled already (held by this process, or in numba's " \
                       f"cache for a run of {n} >= {AUTO_MIN_STEPS} steps)"
            self._compile(ready)
        elif long:
            self.why = f"a run of {n} >= {AUTO_MIN_STEPS} steps, compiled after its first " \
                       f"chunk in Python"
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
        kernels, _ = kernels_of(self._system, self._record, False)
        if kernels is None or not self.use_driver:
            return None
        loop = own_loop(self._system, plan, kernels)
        if loop is not None and (loop.typed or (cached and loop.in_cache())):
            return kernels, None
        kinds = kinds_of(self._system, kernels)
        if kinds is None:
            return None
        found = list(kinds.values())
        return (kernels, kinds) if driver.held(found) or (
            cached and driver.cached(found, scenario_loop.cache_dir())) else None

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
            kernels_of(system, self._record, self.mode == "on")
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
            kinds_of(system, kernels) if self.use_driver else None
        held = kinds is not None and driver.held(list(kinds.values()))
        with compile_progress("the step loop", likely=not held):
            if kinds is not None and own_loop(system, self.python.plan, kernels) is None:
                self._compile_driver(kinds, kernels, t0)
                return
            failure = self._compile_loop(kernels, t0)
            if failure is not None and kinds is None and self.use_driver:  # `_ready`'s loop
                kinds = kinds_of(system, kernels)
            if failure is not None and kinds is not None:
                log.debug("the system's own loop did not compile (%s); the driver runs it",
                          failure)
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
        self._Y = tuple(tuple(port_value(v, comps[n].__dict__[p], carried[n, p])
                              for p, v in comps[n].outputs.items()) for n in order)
        self._U = tuple(tuple(port_value(v, comps[n].__dict__[p], carried[n, p])
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
            addresses, fresh = driver.load(list(kinds.values()), scenario_loop.cache_dir)
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
    def fmu_components(self) -> list[Any]:
        """The FMU components the compiled loop calls through their C functions (none before it
        is compiled): a stop signal while one hangs ends the process (`twmr.fmi.guard`)."""
        if not self.compiled:
            return []
        return [c for c, k in zip(getattr(self, "_comps", ()), getattr(self, "_kernels", ()),
                                  strict=True) if k.fmu is not None]

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
        self._sync_driver(rows, buf, *drv.run(
            n0, n1, exp.start, exp.step, lay.S, lay.X, lay.P, lay.ops, lay.gains, lay.blocks,
            lay.steps, lay.H, lay.chk, lay.rec, buf, self._decimation))

    def _sync_driver(self, rows: list[Any], buf: np.ndarray, k: int, bad: int, block: int = -1,
                     code: int = 0) -> None:
        """As `_sync`, from the driver's vectors; an FMU call that failed at step `bad` (in
        `block`, with the adapter's `code`) raises the FMU's error."""
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
            t = exp.start + bad * exp.step
            fmu = self._kernels[block].fmu if block >= 0 else None
            if fmu is not None:
                from twmr.fmi.driver_kind import failure

                raise fmu.error(*failure(fmu, code), t)
            raise NonFinite(t)

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
            self.compiled_in_run = n0
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

    def reparameterized(self, names: Collection[str]) -> None:
        """The compiled loop's parameters (and states, ports) laid out anew from the components
        as they are now, as when a run switches to it after Python steps; the Python schedule
        makes the kernels of `names` anew itself."""
        self.python.reparameterized(names)
        if self.compiled:
            self._compile()

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
            out["compiled_at_step"] = self.compiled_in_run
            out["driver"] = self._driver is not None
            out["why"] = self.why
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
