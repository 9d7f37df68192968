"""`Execution`: runs a built `System` with a master algorithm, from setup to terminate.

It owns the clock (an integer count of base steps), real-time pacing, progress, error mapping (an
exception or a NaN/Inf inside a component becomes a `ComponentError` naming the instance, the call
or port, and the time) and the guarantee that the recorder is flushed and every component is
terminated, whatever happens.
"""
from __future__ import annotations

import gc
import math
import signal
import sys
import threading
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from twmr.core.errors import ComponentError, CosimError
from twmr.master.algorithm import NonFinite, Schedule, generate
from twmr.master.recorder import Recorder
from twmr.scenario.system import System


class Pacer:
    """Holds step n until wall time t0 + n h: sleep, then spin on perf_counter_ns for the last
    `spin` seconds. Records each step's release time; lateness is how far past its deadline a
    step was released, period error how far the interval between two releases was from h."""

    def __init__(self, h: float, spin: float = 3e-4):
        self.h = h
        self.h_ns = int(round(h * 1e9))
        self.spin_ns = int(spin * 1e9)
        self.t0 = time.perf_counter_ns()
        self.released_ns: list[int] = []
        self.overruns = 0

    def start(self) -> None:
        self.t0 = time.perf_counter_ns()

    def __call__(self, n: int) -> None:
        target = self.t0 + n * self.h_ns
        now = time.perf_counter_ns()
        if target - now > self.spin_ns:
            time.sleep((target - now - self.spin_ns) * 1e-9)
        while (now := time.perf_counter_ns()) < target:
            pass
        self.released_ns.append(now)
        if now - target > self.h_ns:
            self.overruns += 1

    def lateness_us(self) -> np.ndarray:
        """Per paced step: release time past its deadline [us]."""
        released = np.asarray(self.released_ns, dtype=np.int64)
        if not released.size:
            return np.zeros(0)
        first = int(round((released[0] - self.t0) / self.h_ns))
        deadlines = self.t0 + (first + np.arange(released.size)) * self.h_ns
        return (released - deadlines) / 1e3

    def stats(self) -> dict[str, float]:
        """Lateness and |period error| p50/p99/max [us], missed deadlines (released more than one
        step late), paced steps."""
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
                "missed_deadlines": self.overruns, "paced_steps": int(late.size)}


@dataclass
class RunInfo:
    """What a run did: steps, wall time [s], real-time factor, pacing overruns, error if any."""

    n_steps: int = 0
    steps_done: int = 0
    wall_time: float = 0.0
    realtime_factor: float = 0.0
    overruns: int = 0
    error: str = ""
    extra: dict[str, Any] = field(default_factory=dict)


class Execution:
    """One run of `system`. `run()` returns the recorded structured array; `info` tells the rest.

    The steps run in chunks of `chunk_steps`; after each the recorder flushes to disk, the progress
    bar moves and `on_chunk(n)` (if given) is called with the number of steps done."""

    def __init__(self, system: System, result_path: str | Path | None = None,
                 progress: bool = False, check_finite: bool = True, chunk_steps: int = 20000,
                 on_chunk: Callable[[int], None] | None = None):
        self.system = system
        self.on_chunk = on_chunk
        self.recorder = Recorder(system, result_path)
        self.progress = progress
        self.chunk_steps = chunk_steps
        exp = system.experiment
        self.pacer = Pacer(exp.step) if system.paced else None
        self.schedule: Schedule = generate(system, exp.algorithm, self.recorder.signals,
                                           self.recorder.decimation, check_finite, self.pacer)
        self.info = RunInfo(n_steps=exp.n_steps)
        self._n = 0

    def run(self) -> np.ndarray:
        """Set up, initialize, step to the stop time, terminate. Raises `ComponentError` (results
        up to the failure are on disk in `recorder.path`)."""
        exp = self.system.experiment
        rows = self.recorder.rows
        bar = _progress_bar(exp.n_steps) if self.progress else None
        wall0 = time.perf_counter()
        if self.pacer is not None:
            # the objects alive now (libraries, components) leave the collector's view, so a
            # full collection during the paced run scans only what the run allocates
            gc.collect()
            gc.freeze()
            # other threads (bus notifiers, emulated drives) hand the GIL back within 0.2 ms
            # instead of 5 ms, so a paced step is not held behind them
            switch = sys.getswitchinterval()
            sys.setswitchinterval(2e-4)
        try:
            if not self.recorder.temporary:
                for comp in self.system.components.values():
                    comp.output_dir = Path(self.recorder.path).parent
            self._lifecycle("setup", lambda c: c.setup(exp.start, exp.stop))
            self._lifecycle("initialize", lambda c: c.initialize())
            if self.pacer is not None:
                self.pacer.start()
            while self._n < exp.n_steps:
                n1 = min(exp.n_steps, self._n + self.chunk_steps)
                self._guarded(self.schedule.run, self._n, n1, rows)
                if bar is not None:
                    bar.update(n1 - self._n)
                self._n = n1
                self.recorder.flush()
                if self.on_chunk is not None:
                    self.on_chunk(n1)
            self._guarded(self.schedule.finish, exp.n_steps, rows)
        except CosimError as err:
            self.info.error = str(err)
            raise
        except KeyboardInterrupt as stop:
            t = self._locate(stop)[2]
            if math.isfinite(t):
                self._n = self._step_of(t)
            self.info.error = f"interrupted (Ctrl-C) at t = {exp.start + self._n * exp.step:g} s"
            raise
        finally:
            self.info.steps_done = self._n
            self.info.wall_time = time.perf_counter() - wall0
            simulated = self._n * exp.step
            self.info.realtime_factor = simulated / self.info.wall_time if self.info.wall_time else 0
            self.info.overruns = self.pacer.overruns if self.pacer else 0
            if self.pacer is not None:
                self.info.extra.update(self.pacer.stats())
            if self.pacer is not None:
                gc.unfreeze()
                sys.setswitchinterval(switch)
            self.recorder.close()
            if bar is not None:
                bar.close()
            self._report_all()
            self._terminate_all()
        return self.recorder.result()

    # -- helpers -----------------------------------------------------------------------------
    def _lifecycle(self, call: str, fn: Any) -> None:
        t = self.system.experiment.start
        for name in self.system.order:
            comp = self.system.components[name]
            try:
                fn(comp)
            except CosimError:
                raise
            except Exception as exc:  # noqa: BLE001 - every component failure is reported
                raise ComponentError(name, t, f"{call}() raised {type(exc).__name__}: {exc}. "
                                     f"Fix: check the parameters of '{name}'.") from exc

    def _guarded(self, fn: Any, *args: Any) -> None:
        try:
            fn(*args)
        except NonFinite as nf:
            self._n = self._step_of(nf.t)
            raise self._nonfinite_error(nf.t) from None
        except CosimError:
            raise
        except Exception as exc:  # noqa: BLE001
            name, call, t = self._locate(exc)
            self._n = self._step_of(t)
            raise ComponentError(
                name, t, f"{call} raised {type(exc).__name__}: {exc}. Fix: check the component's "
                f"inputs and parameters at that time (the results up to it are saved)."
            ) from exc

    def _step_of(self, t: float) -> int:
        exp = self.system.experiment
        return int(round((t - exp.start) / exp.step))

    def _locate(self, exc: BaseException) -> tuple[str, str, float]:
        """The instance and call on the generated line where `exc` passed, and the time."""
        owner, t = ("?", "a call"), math.nan
        for frame, lineno in traceback.walk_tb(exc.__traceback__):
            if frame.f_code.co_filename == self.schedule.filename:
                owner = self.schedule.line_owner.get(lineno, owner)
                t = frame.f_locals.get("t", t)
        name, what = owner
        call = {"input": "writing its inputs", "evaluate": "evaluate()",
                "do_step": "do_step()"}.get(what, what)
        return name, call, t

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
        """Each component's own figures, as 'instance.key' in `info.extra`."""
        for name in self.system.order:
            try:
                figures = self.system.components[name].report()
            except Exception:  # noqa: BLE001 - a report never hides the run's own outcome
                continue
            self.info.extra.update({f"{name}.{k}": v for k, v in figures.items()})

    def _terminate_all(self) -> None:
        """Terminate every component, even if one fails; a second Ctrl-C waits until the end (a
        drive's terminate sends zero torque)."""
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            for name in self.system.order:
                try:
                    self.system.components[name].terminate()
                except Exception:  # noqa: BLE001 - terminate every component even if one fails
                    pass
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)


def _progress_bar(total: int) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, unit="step", unit_scale=True, mininterval=0.5, leave=False,
                disable=None)
