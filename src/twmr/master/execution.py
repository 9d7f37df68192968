"""`Execution`: runs a built `System` with an `Algorithm`, from setup to terminate, and feeds the
observers.

It owns the clock (an integer count of base steps), real-time pacing, chunking of the recorded
rows, error mapping (an exception or a NaN/Inf inside a component becomes a `ComponentError`
naming the instance, the call or port, and the time) and every stop path: normal end, error,
Ctrl-C, SIGTERM, SIGHUP or a failure to write the results. On each, every component is
terminated first (a drive's terminate sends zero torque and disables it) with those signals held
off, then the rows recorded so far go to the observers, then the observers are told the outcome;
a failing observer is reported after the stop, never instead of it.
"""
from __future__ import annotations

import contextlib
import dataclasses
import gc
import locale
import logging
import math
import signal
import sys
import threading
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import ComponentError, CosimError, FmuTerminated
from twmr.core.port import BINARY
from twmr.core.raised import described
from twmr.core.run import Options, RunContext
from twmr.core.warned import OncePerRun
from twmr.master.algorithm import Algorithm, NonFinite, admit, algorithm_for
from twmr.master.gate import Gate, RunStopped
from twmr.master.jacobi_start import propagate_start_values
from twmr.master.ticks import Event, Tick, TickEvents, binary_signals
from twmr.observers.base import Observer, Outcome, RunStart
from twmr.scenario.system import System

log = logging.getLogger("twmr.run")

#: wall time one chunk of steps aims at [s]: rows reach the observers (and the disk) this often
CHUNK_SECONDS = 0.1
#: the most a chunk grows over the one before (the first is `FIRST_CHUNK` steps): a fast run
#: (the compiled 30 s paper scenario: chunks of 64, 4,096 and 25,840 steps) pays the chunks'
#: fixed cost a few times only
FIRST_CHUNK, CHUNK_GROWTH = 64, 64
_STOP_SIGNALS = tuple(getattr(signal, n) for n in ("SIGINT", "SIGTERM", "SIGHUP")
                      if hasattr(signal, n))


@contextlib.contextmanager
def held_signals() -> Iterator[None]:
    """Ctrl-C, SIGTERM and SIGHUP ignored inside (main thread only): for stopping hardware and
    saving results, which a second signal must not cut short."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {sig: signal.signal(sig, signal.SIG_IGN) for sig in _STOP_SIGNALS}
    try:
        yield
    finally:
        for sig, handler in held.items():
            signal.signal(sig, handler)


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped by Ctrl-C, SIGTERM or SIGHUP (`signal_name`)."""

    def __init__(self, signal_name: str = "SIGINT"):
        super().__init__(signal_name)
        self.signal_name = signal_name


class ResultWriteError(CosimError):
    """Recording failed (disk full, folder removed...): the run stopped, components terminated."""



@contextlib.contextmanager
def kept_locale(who: str) -> Iterator[None]:
    """The process locale as it was before `who` ran: an FMU's library may set it (Modelica
    tools' FMUs set LC_ALL to "C"), which would make Python read and write text as ASCII."""
    before = locale.setlocale(locale.LC_ALL)
    try:
        yield
    finally:
        if locale.setlocale(locale.LC_ALL) != before:
            locale.setlocale(locale.LC_ALL, before)
            log.debug("%s changed the process locale; it is set back", who)

class Pacer:
    """Holds step n until wall time t0 + n h: sleep, then spin on perf_counter_ns for the last
    `spin` seconds. Records each step's release time; lateness is how far past its deadline a
    step was released, period error how far the interval between two releases was from h."""

    def __init__(self, h: float, spin: float = 3e-4):
        self.h = h
        self.h_ns = round(h * 1e9)
        self.spin_ns = int(spin * 1e9)
        self.t0 = time.perf_counter_ns()
        self.t0_unix_ns = time.time_ns()
        self.released_ns: list[int] = []
        self.deadline_ns: list[int] = []
        self.overruns = 0

    def start(self) -> None:
        self.t0, self.t0_unix_ns = time.perf_counter_ns(), time.time_ns()

    def shift(self, seconds: float) -> None:
        """Every deadline from now on `seconds` later (the run was paused that long)."""
        if seconds > 0:
            self.t0 += round(seconds * 1e9)

    def __call__(self, n: int) -> None:
        target = self.t0 + n * self.h_ns
        now = time.perf_counter_ns()
        if target - now > self.spin_ns:
            time.sleep((target - now - self.spin_ns) * 1e-9)
        while (now := time.perf_counter_ns()) < target:
            pass
        self.released_ns.append(now)
        self.deadline_ns.append(target)
        if now - target > self.h_ns:
            self.overruns += 1

    def lateness_us(self) -> np.ndarray:
        """Per paced step: release time past its own deadline t0 + n h [us]."""
        released = np.asarray(self.released_ns, dtype=np.int64)
        return (released - np.asarray(self.deadline_ns, dtype=np.int64)) / 1e3

    def stats(self) -> dict[str, float]:
        """Lateness and |period error| p50/p99/max [us], missed deadlines (released more than one
        step late), paced steps, and the wall-clock time of t = start (`start_unix_s`, seconds
        since the epoch: what puts a frame log's times on the run's time axis)."""
        if not self.released_ns:
            return {}
        late = self.lateness_us()
        period = np.abs(np.diff(np.asarray(self.released_ns, dtype=np.int64)) - self.h_ns) / 1e3
        period = period if period.size else np.zeros(1)
        return {"lateness_p50_us": float(np.percentile(late, 50)),
                "lateness_p99_us": float(np.percentile(late, 99)),
                "lateness_max_us": float(late.max()),
                "period_error_p50_us": float(np.percentile(period, 50)),
                "period_error_p99_us": float(np.percentile(period, 99)),
                "period_error_max_us": float(period.max()),
                "missed_deadlines": self.overruns, "paced_steps": int(late.size),
                "start_unix_s": self.t0_unix_ns / 1e9}


class _Relay:
    """Delivers row blocks from a worker thread, in order; the first failure is raised by the
    next `put` or by `close`."""

    def __init__(self, deliver: Any):
        import queue

        self._queue: Any = queue.SimpleQueue()
        self._error: BaseException | None = None
        self._deliver = deliver
        self._thread = threading.Thread(target=self._work, name="twmr-observers", daemon=True)
        self._thread.start()

    def _work(self) -> None:
        while (item := self._queue.get()) is not None:
            if self._error is None:
                try:
                    self._deliver(*item)
                except BaseException as exc:  # noqa: BLE001 - handed to the stepping thread
                    self._error = exc

    def put(self, block: np.ndarray, n: int, events: list[Event]) -> None:
        if self._error is not None:
            raise self._error
        self._queue.put((block, n, events))

    def close(self, check: bool = True) -> None:
        """Deliver what is queued and end the thread; raise its failure when `check`."""
        self._queue.put(None)
        self._thread.join()
        if check and self._error is not None:
            raise self._error


def columns_of(system: System, signals: Sequence[tuple[str, str]]
               ) -> tuple[list[str], list[str]]:
    """Column names and units of the recorded signals, time first; vector ports as
    `inst.port[1]..inst.port[n]` (1-based, as Modelica tools name them). Binary ports are
    recorded at their ticks instead (`twmr.master.ticks`)."""
    names, units = ["time"], ["s"]
    for inst, port in signals:
        var = system.components[inst].variables[port]
        if var.type == BINARY:
            continue
        if var.size is None:
            names.append(f"{inst}.{port}")
            units.append(var.element_unit(0))
        else:
            for i in range(var.width):
                names.append(f"{inst}.{port}[{i + 1}]")
                units.append(var.element_unit(i))
    return names, units


def _recorded_vectors(owner: str, vectors: Sequence[dict[str, Any]], columns: set[str]
                      ) -> list[dict[str, Any]]:
    """The vectors (`Component.vectors`) of `owner`'s vehicle whose element is recorded, each
    with its `column` ('plant.slip_rate[1]') in place of its port and element."""
    drawn = []
    for vector in vectors:
        port, element = f"{owner}.{vector['port']}", int(vector["element"])
        column = next((c for c in (f"{port}[{element + 1}]", port if element == 0 else "")
                       if c in columns), None)
        if column is not None:
            drawn.append({"label": str(vector["label"]), "column": column,
                          "at": [float(v) for v in vector["at"]],
                          "along": [float(v) for v in vector["along"]],
                          "scale": float(vector["scale"]),
                          "colour": str(vector.get("colour", "#009E73"))})
    return drawn


class Execution:
    """One run of `system`: `run()` returns the `Outcome` (or raises after the stop).

    Rows are handed to `observers` in chunks of about `CHUNK_SECONDS` of wall time (a paced run:
    of simulated time), so a crash loses at most the last chunk."""

    def __init__(self, system: System, observers: Sequence[Observer] = (),
                 folder: str | Path | None = None, check_finite: bool = True,
                 algorithm: Algorithm | None = None, options: Options | None = None,
                 gate: Gate | None = None):
        self.system = system
        self.gate = gate  # pauses, steps and stops the run from another thread
        if gate is not None:
            gate.execution = self
        self.options = options or Options()
        self.observers = list(observers)
        self.folder = Path(folder) if folder is not None else None
        exp = system.experiment
        self.pacer = Pacer(exp.step / system.pace_factor) if system.paced else None
        if algorithm is None:
            self.algorithm = algorithm_for(system, self.options.compiled)
        else:
            admit(system, algorithm)
            self.algorithm = algorithm
        self.signals = list(system.record.signals)
        self.columns, self.units = columns_of(system, self.signals)
        self.ticks = TickEvents(system, binary_signals(system, self.signals))
        self.algorithm.timing = self.options.timing
        self.algorithm.prepare(system, self.signals, system.record.decimation, check_finite)
        self.outcome = Outcome(n_steps=exp.n_steps)
        self._relay: _Relay | None = None
        self._changes = list(system.changes)  # and those the condition events add
        self._seen = {w.block: 0.0 for w in system.watches}  # each watch's firings handled
        self._n = 0
        self._rows: list[tuple[float, ...]] = []
        self._finished = False

    def run(self) -> Outcome:
        """Set up, initialize, step to the stop time, terminate. Raises `CosimError` or
        `KeyboardInterrupt` (`RunInterrupted`) after every component is terminated and the
        observers have what was recorded."""
        exp = self.system.experiment
        error: BaseException | None = None
        once = OncePerRun().attach()
        previous = self._catch_stop_signals()
        paced = self.pacer is not None
        frozen = False
        self._wall0 = math.nan
        try:
            start = RunStart(tuple(self.columns), tuple(self.units), exp.step, exp.n_steps,
                             self.folder, self.system.source,
                             {"ports": self._recorded_ports(),
                              "events": [m.plain() for m in self.system.events]},
                             tuple(self.ticks.names), self.system)
            for obs in self.observers:
                self._write(obs.started, start)
            context = RunContext(
                self.folder, exp.step, paced,
                frozenset((c.dst, c.dst_port) for c in self.system.connections),
                frozenset([(c.src, c.src_port) for c in self.system.connections]
                          + list(self.signals)),
                outputs_as_stepped=self.algorithm.outputs_as_stepped,
                steps_retaken=self.algorithm.needs_state_rollback,
                fmu_log=self.options.fmu_log)
            if paced:
                # collect now, before hardware starts (a full collection stalls every thread
                # for tens of ms), and freeze: a collection during the paced run scans only
                # what the run allocates; other threads (bus notifiers, emulated drives) hand
                # the GIL back within 0.2 ms instead of 5 ms
                gc.collect()
                gc.freeze()
                frozen, switch = True, sys.getswitchinterval()
                sys.setswitchinterval(2e-4)
            self._lifecycle("prepare", lambda c: c.prepare(context))
            self._lifecycle("setup", lambda c: c.setup(exp.start, exp.stop))
            self._lifecycle("initialize", lambda c: c.initialize(), self._hardware_last())
            if self.algorithm.outputs_as_stepped:
                propagate_start_values(self.system)
            self.algorithm.start()
            self._signal_swallowed()
            if paced:
                gc.freeze()  # what set-up created too; no collection once drives run
                self._relay = _Relay(self._deliver)
            self._wall0 = time.perf_counter()
            if paced:
                self._paced_loop(exp.n_steps)
            else:
                self._loop(exp.n_steps)
            self._guarded(self.algorithm.finish, exp.n_steps)
            self._finished = True
        except FmuTerminated as exc:
            error = self._fmu_ended(exc)
        except RunStopped:
            self.outcome.status = "stopped"
            self.outcome.error = ""
        except BaseException as exc:  # noqa: BLE001 - every stop path ends the same way below
            error = exc
        finally:
            self._stopping = True  # from here on, a further signal is ignored
            wall = time.perf_counter() - self._wall0
            with kept_locale("terminate"):
                self._terminate_all()
            if frozen:
                gc.unfreeze()
                sys.setswitchinterval(switch)
        try:
            error = self._conclude(error, wall if math.isfinite(wall) else 0.0)
        finally:
            self._restore_signals(previous)
            once.detach()
            if self.gate is not None:
                self.gate.end()
        if error is not None:
            raise error
        return self.outcome

    # -- stepping ------------------------------------------------------------------------------
    def _loop(self, n_steps: int) -> None:
        chunk = FIRST_CHUNK
        variable = self.algorithm.variable_step  # its steps must not depend on the chunks
        watching = bool(self.system.watches)
        while self._n < n_steps:
            limit = self._allowed()
            upcoming = self._changed()
            n1 = min(n_steps, limit) if variable else min(n_steps, self._n + chunk, upcoming,
                                                          limit)
            t0 = time.perf_counter()
            if watching:  # a step at a time: the conditions are looked at between steps
                while self._n < n1:
                    self._n = self._advance(self._n + 1)
                    if self._watched():
                        break
            else:
                self._n = self._advance(n1)
            if self.gate is not None:
                self.gate.reached(self._n)
            dt = time.perf_counter() - t0
            self._emit()
            chunk = int(min(max(1, chunk * CHUNK_GROWTH), 200_000,
                            max(1.0, chunk * CHUNK_SECONDS / max(dt, 1e-9))))

    def _paced_loop(self, n_steps: int) -> None:
        pacer = self.pacer
        assert pacer is not None
        every = max(1, round(CHUNK_SECONDS / self.system.experiment.step))
        pacer.start()
        while self._n < n_steps:
            if self.gate is not None:
                before = self.gate.paused_s
                self._allowed()
                pacer.shift(self.gate.paused_s - before)  # no catching up after a pause
            self._changed()
            self._n = self._advance(self._n + 1)
            self._watched()
            if self.gate is not None:
                self.gate.reached(self._n)
            pacer(self._n)
            if self._n % every == 0:
                self._emit()

    def _signal_swallowed(self) -> None:
        """Raise the stop a signal asked for, where its handler's exception was swallowed (by a
        C callback it interrupted, such as numba's compiler in llvmlite): the run goes on only
        while no stop signal came."""
        if self._signalled:
            raise RunInterrupted(self._signalled)

    def _allowed(self) -> int:
        """The step the gate lets the run reach (waiting while it is paused, every component
        held safe meanwhile: `Component.hold`); no gate: the end of time."""
        if self.gate is None:
            return 1 << 62
        if self.gate.paused and self._rows:
            self._emit()  # what was taken is seen while the run waits
        return self.gate.allowed(self._n, self._hold)

    def _hold(self) -> None:
        """Each component's `hold` while the run is paused; a CosimError (a drive's fault)
        ends the run as a step's would."""
        t = self._time(self._n)
        for name in self.system.order:
            try:
                self.system.components[name].hold(t)
            except CosimError:
                raise
            except Exception as exc:  # noqa: BLE001 - a user block's own code
                raise ComponentError(name, t, described("hold()", exc, "check the block's "
                                                        "hold().")) from exc

    def request_change(self, name: str, value: Any) -> None:
        """Set parameter `name` ('comp.parameter') to `value` before the next step, as a set
        event does; CosimError when it cannot (call it while the run waits at its gate)."""
        from twmr.core.errors import Location
        from twmr.scenario.events import parameter_change

        problems: list[Any] = []
        change = parameter_change(name, value, self._time(self._n), self.system.components,
                         self.system.experiment, Location(), problems)
        if change is None:
            problem = problems[0]
            raise CosimError(problem.message.replace("events: ", "", 1)
                             + (f" Fix: {problem.hint}" if problem.hint else ""))
        self._changes.append(dataclasses.replace(change, step=self._n))

    def _watched(self) -> bool:
        """Whether a condition event fired in the step just taken (its watch block counted):
        its action's changes are then due before the next step, and the firing is kept in the
        outcome (`Outcome.fired`)."""
        fired = False
        for watch in self.system.watches:
            block = self.system.components[watch.block]
            count = float(block.get("count"))
            if count <= self._seen[watch.block]:
                continue
            self._seen[watch.block] = count
            at = self._time(self._n)
            self._changes += watch.fired(self._n, at)
            record = {"when": watch.condition, "action": watch.action, "target": watch.target,
                      "located": float(block.get("located")), "at": at,
                      "until": at + watch.duration if watch.change is None else None,
                      **({"value": watch.value} if math.isfinite(watch.value) else {})}
            self.outcome.fired.append(record)
            for obs in self.observers:
                self._write(obs.fired, record)
            fired = True
        return fired

    def _changed(self) -> int:
        """Set the parameters due before the present step (`System.changes` and those of the
        condition events fired), the algorithm told which components changed; the step of the
        next change (a chunk ends there), or the end of time."""
        changes = self._changes
        due = [c for c in changes if c.step == self._n]
        if due:
            from twmr.scenario.events import apply_change

            if self.algorithm.variable_step:
                raise CosimError(f"events: set events need a fixed-step master; "
                                 f"{type(self.algorithm).__name__} varies its steps. Fix: use "
                                 f"algorithm: gauss_seidel or jacobi.")
            for change in due:
                apply_change(self.system.components[change.comp], change)
            self.algorithm.reparameterized({c.comp for c in due})
        return min((c.step for c in changes if c.step > self._n), default=1 << 62)

    def _advance(self, n1: int) -> int:
        """The algorithm's advance from the present step towards `n1`; the step it reached must be
        n1, or (`variable_step`) one after the present step and not past n1."""
        self._signal_swallowed()
        n0 = self._n
        n = self._guarded(self.algorithm.advance, n0, n1)
        if n != n1 and not (self.algorithm.variable_step and n0 < n < n1):
            name = type(self.algorithm).__name__
            raise CosimError(
                f"the master algorithm {name} was asked to advance from base step {n0} to {n1} "
                f"and reached step {n}. Fix: a fixed-step algorithm returns n1; one that may "
                f"fall short declares variable_step = True and returns a step in "
                f"({n0}, {n1}].")
        return n

    def _emit(self) -> None:
        """Hand the rows recorded since the last call to every observer (in a paced run, to the
        relay thread, so a slow disk never delays a step); the ticks of recorded Binary ports
        apart from them."""
        rows: list[Any] = self._rows
        events: list[Event] = []
        if self.ticks.names:
            events = self.ticks.events([r for r in rows if type(r) is Tick])
            rows = [r for r in rows if type(r) is not Tick]
        if not rows:
            block = np.zeros((0, len(self.columns)))
        elif isinstance(rows[0], np.ndarray):  # blocks of rows (the compiled loop)
            block = rows[0] if len(rows) == 1 else np.concatenate(rows)
        else:
            block = np.array(rows, dtype=float)
        self._rows.clear()
        if self._relay is not None:
            self._relay.put(block, self._n, events)
            return
        self._deliver(block, self._n, events)

    def _deliver(self, block: np.ndarray, n: int, events: list[Event]) -> None:
        for obs in self.observers:
            if events:
                self._write(obs.ticks, events, n)
            self._write(obs.rows, block, n)

    def _write(self, fn: Any, *args: Any) -> None:
        try:
            fn(*args)
        except CosimError:
            raise
        except Exception as exc:  # noqa: BLE001 - a failing observer stops the run cleanly
            owner = type(getattr(fn, "__self__", fn)).__name__
            raise ResultWriteError(
                f"recording the results failed in {owner} ({type(exc).__name__}: {exc}) at "
                f"t = {self._time(self._n):g} s; the run was stopped and every component "
                f"terminated. Fix: free disk space or choose another results folder; the rows "
                f"written before are readable.") from exc

    def _guarded(self, fn: Any, *args: Any) -> Any:
        try:
            return fn(*args, self._rows)
        except NonFinite as nf:
            self._n = self._step_of(nf.t)
            raise self._nonfinite_error(nf.t) from None
        except CosimError as exc:
            self._n = self._completed(exc)
            raise
        except KeyboardInterrupt:
            raise
        except (Exception, SystemExit) as exc:  # noqa: BLE001 - a block's exit() too
            name, call, t = self.algorithm.locate(exc)
            if math.isfinite(t):
                self._n = self._step_of(t)
            if isinstance(exc, SystemExit):
                raise ComponentError(
                    name, t, f"{call} called exit ({exc.code!r}), which would end twmr with "
                    f"nothing said. Fix: raise an exception (or return) instead of exiting; "
                    f"the results up to it are saved.") from None
            raise ComponentError(name, t, described(
                call, exc, "check the component's inputs and parameters at that time (the "
                "results up to it are saved).")) from exc

    def _completed(self, error: CosimError) -> int:
        """The base steps completed when `error` stopped a chunk: up to the time it was raised
        at (in the step loop, or the time the error names), else up to the last row recorded
        (those rows are kept, so the count agrees with them)."""
        _name, _call, t = self.algorithm.locate(error)
        if not math.isfinite(t):
            named = getattr(error, "time", None)
            t = float(named) if isinstance(named, int | float) else math.nan
        if not math.isfinite(t) and self._rows:
            last = self._rows[-1]
            t = float(last[-1, 0] if isinstance(last, np.ndarray) else last[0])
        return max(self._n, self._step_of(t)) if math.isfinite(t) else self._n

    # -- the end -------------------------------------------------------------------------------
    def _fmu_ended(self, request: FmuTerminated) -> FmuTerminated | None:
        """An FMU's request to end the simulation: the run's failure, or with
        `experiment.fmu_terminate: stop` its normal end (noted in the outcome)."""
        if self.system.experiment.fmu_terminate != "stop":
            return request
        self.outcome.stopped_by = {"component": request.instance, "time": self._time(self._n)}
        log.info("%s asked to end the simulation at t = %g s; the run ends there "
                 "(experiment.fmu_terminate: stop)", request.instance, self._time(self._n))
        return None

    def _conclude(self, error: BaseException | None, wall: float) -> BaseException | None:
        """Rows left to the observers, the outcome filled in and announced; the error to raise."""
        out = self.outcome
        if isinstance(error, KeyboardInterrupt):
            _name, _, t = self.algorithm.locate(error)
            if math.isfinite(t):
                self._n = self._step_of(t)
            how = getattr(error, "signal_name", "SIGINT")
            out.status, out.error = "interrupted", \
                f"interrupted ({'Ctrl-C' if how == 'SIGINT' else how}) at t = " \
                f"{self._time(self._n):g} s"
        elif error is not None:
            out.status, out.error = "failed", str(error) or type(error).__name__
        if not isinstance(error, ResultWriteError):
            try:
                self._emit()
                if self._relay is not None:
                    self._relay.close()
            except ResultWriteError as exc:
                error = error or exc
                out.status, out.error = ("failed", str(exc)) if out.status == "completed" \
                    else (out.status, out.error)
        if self._relay is not None and self._relay._thread.is_alive():
            self._relay.close(check=False)  # the thread ends whatever failed
        out.steps_done = self._n
        out.wall_time = wall
        out.realtime_factor = (self._n * self.system.experiment.step / out.wall_time
                               if out.wall_time else 0.0)
        if self.gate is not None and self.gate.paused_s:
            out.extra["paused_s"] = round(self.gate.paused_s, 3)
        if self.pacer is not None and self.pacer.released_ns:
            out.extra.update(self.pacer.stats())
            out.lateness_us = self.pacer.lateness_us()
        self._report_all()
        self.outcome.extra.update({f"algorithm.{k}": v for k, v in self.algorithm.report().items()})
        try:
            out.statistics = self.algorithm.statistics(self._n, self._finished)
        except Exception:  # noqa: BLE001 - statistics never hide the run's own outcome
            log.debug("the algorithm's statistics failed", exc_info=True)
        failures = []
        for obs in self.observers:
            try:
                obs.finished(out)
            except Exception as exc:  # noqa: BLE001 - every observer is told; failures listed
                failures.append(f"{type(obs).__name__}: {type(exc).__name__}: {exc}")
                log.debug("observer %s failed", type(obs).__name__, exc_info=True)
        if failures and error is None:
            error = ResultWriteError(
                f"the run completed but saving its results failed ({'; '.join(failures)}). Fix: "
                f"free disk space or choose another results folder.")
        elif failures:
            log.error("saving the results also failed: %s", "; ".join(failures))
        return error

    def _lifecycle(self, call: str, fn: Any, order: Sequence[str] | None = None) -> None:
        t = self.system.experiment.start
        for name in self.system.order if order is None else order:
            comp = self.system.components[name]
            try:
                with kept_locale(name):
                    fn(comp)
                self._signal_swallowed()
            except (CosimError, KeyboardInterrupt):
                raise
            except Exception as exc:  # noqa: BLE001 - every component failure is reported
                raise ComponentError(name, t, described(
                    f"{call}()", exc, f"check the parameters of '{name}'.")) from exc

    def _hardware_last(self) -> list[str]:
        """The components in order, those that need real time (drives, buses) last: started
        hardware hears nothing until the first step, so another block's initialize (a numba
        compile, an FMU instantiation: seconds) must not come in between."""
        comps = self.system.components
        return sorted(self.system.order, key=lambda name: comps[name].needs_realtime)

    def _time(self, n: int) -> float:
        exp = self.system.experiment
        return exp.start + n * exp.step

    def _step_of(self, t: float) -> int:
        exp = self.system.experiment
        return round((t - exp.start) / exp.step)

    def _nonfinite_error(self, t: float) -> ComponentError:
        for name in self.system.order:
            comp = self.system.components[name]
            for port, var in comp.outputs.items():
                value = comp.__dict__[port]
                values = value if isinstance(value, tuple) else (value,)
                for i, v in enumerate(values):
                    if isinstance(v, float) and not math.isfinite(v):
                        label = port if var.size is None else f"{port}[{i + 1}]"
                        return ComponentError(
                            name, t, f"output '{label}' is {v} (not finite). Fix: check the "
                            f"inputs of '{name}' just before this time in the saved results, its "
                            f"parameters, or reduce the step.")
        return ComponentError("?", t, "an output became NaN or Inf")

    def _report_all(self) -> None:
        """Each component's own figures, as 'instance.key' in the outcome's `extra`."""
        for name in self.system.order:
            try:
                figures = self.system.components[name].report()
            except Exception:  # noqa: BLE001 - a report never hides the run's own outcome
                continue
            self.outcome.extra.update({f"{name}.{k}": v for k, v in figures.items()})

    def _terminate_all(self) -> None:
        """Terminate every component, even if one fails, with Ctrl-C, SIGTERM and SIGHUP held
        off until all are done (a drive's terminate sends zero torque and disables it), in the
        order of their `terminate_stage` (a bus after the hosts whose last frames it carries)."""
        components = self.system.components
        with held_signals():
            for name in self.system.order:
                try:
                    components[name].stopping()
                except BaseException:  # noqa: BLE001 - every component is told whatever fails
                    log.warning("stopping() of '%s' failed", name, exc_info=True)
            for name in sorted(self.system.order, key=lambda n: components[n].terminate_stage):
                try:
                    components[name].terminate()
                except BaseException:  # noqa: BLE001 - terminate every component whatever fails
                    log.warning("terminate() of '%s' failed", name, exc_info=True)

    def _recorded_ports(self) -> dict[str, dict[str, Any]]:
        """Description, type, limits and body (when its block has them) of each recorded port
        ('plant.pose'), for plots, 3D views and readers."""
        ports: dict[str, dict[str, Any]] = {}
        for column in self.columns[1:] + self.ticks.names:
            name = column.partition("[")[0]
            owner, _, port = name.rpartition(".")
            var = self.system.components[owner].variables.get(port) \
                if owner in self.system.components else None
            if var is not None and name not in ports:
                ports[name] = {"description": var.description, "type": var.type}
                comp = self.system.components[owner]
                limits = comp.limits().get(port)
                if limits is not None:
                    ports[name]["limits"] = list(limits)
                body = self.system.bodies.get(name) or comp.bodies().get(port)
                if body is not None:
                    ports[name]["body"] = dict(body)
                    drawn = _recorded_vectors(owner, comp.vectors().get(port, []),
                                              set(self.columns))
                    if drawn:
                        ports[name]["vectors"] = drawn
        return ports

    def _catch_stop_signals(self) -> dict[int, Any]:
        """Ctrl-C, SIGTERM and SIGHUP stop the run (main thread only); once it is stopping,
        a further one (a second Ctrl-C) is ignored until the results are handed over. What to
        restore: the previous handlers by signal, and (key 0) `sys.unraisablehook`."""
        self._stopping = False
        self._signalled = ""
        if threading.current_thread() is not threading.main_thread():
            return {}

        def stop(signum: int, frame: Any) -> None:
            if not self._stopping:
                self._stopping = True
                self._signalled = signal.Signals(signum).name
                raise RunInterrupted(self._signalled)

        hook = sys.unraisablehook

        def quiet(unraisable: Any) -> None:  # the stop is raised again: no traceback for it
            if not isinstance(unraisable.exc_value, RunInterrupted):
                hook(unraisable)

        sys.unraisablehook = quiet
        return {sig: signal.signal(sig, stop) for sig in _STOP_SIGNALS} | {0: hook}

    @staticmethod
    def _restore_signals(previous: dict[int, Any]) -> None:
        for sig, handler in previous.items():
            if sig == 0:
                sys.unraisablehook = handler
            else:
                signal.signal(sig, handler)
