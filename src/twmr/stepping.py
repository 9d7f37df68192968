"""`Stepping`: a run taken step by step from Python, as libcosim's execution is — `step(n)`,
`simulate_until(t)`, a port's value or a parameter set between steps, and `stop()` or
`finish()` for its `Result`:

    with twmr.Stepping("scenarios/paper_trajectory1_asmc.yaml") as run:
        run.simulate_until(10.0)
        x, y, heading = run.value("plant.pose")
        run.set("plant.scale", 1.6)          # a payload, from the next step on
        run.step(100)
        result = run.finish()                # to the stop time (run.stop(): here)

The run goes in a thread of its own (`twmr.simulate` with a `twmr.master.gate.Gate`), paused
between the calls: the components hold their values (and hardware keeps itself safe,
`Component.hold`), so reading them and setting parameters is safe. A failure of the run is
raised by the call that was waiting for it; leaving the `with` block stops the run.
"""
from __future__ import annotations

import math
import threading
from pathlib import Path
from typing import Any

from twmr.api import Scenario, load, simulate
from twmr.core.errors import CosimError
from twmr.result import Result


class Stepping:
    """A run of `scenario` (a `Scenario` or a path) paused at its start; `out` and the keywords
    as `twmr.simulate` takes them."""

    def __init__(self, scenario: Scenario | str | Path, out: str | Path | None = None,
                 **keywords: Any):
        from twmr.master.gate import Gate

        self.scenario = scenario if isinstance(scenario, Scenario) else load(scenario)
        self._gate = Gate(paused=True)
        self._result: Result | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(out, keywords),
                                        name="twmr-stepping", daemon=True)
        self._thread.start()
        self._gate.wait_for(0)
        self._raise()

    def _run(self, out: str | Path | None, keywords: dict[str, Any]) -> None:
        try:
            self._result = simulate(self.scenario, out, gate=self._gate, **keywords)
        except BaseException as exc:  # noqa: BLE001 - handed to the caller's thread
            self._error = exc
        finally:
            self._gate.end()

    # -- where the run is ----------------------------------------------------------------------
    @property
    def steps(self) -> int:
        """Base steps taken."""
        return self._gate.position

    @property
    def time(self) -> float:
        """The simulated time reached [s]."""
        exp = self._system.experiment
        return exp.start + self.steps * exp.step

    @property
    def ended(self) -> bool:
        return self._gate.ended

    @property
    def _system(self) -> Any:
        execution = self._gate.execution
        if execution is None:
            raise CosimError("the run has not started (its set-up failed?). Fix: see the "
                             "error the call before raised.")
        return execution.system

    # -- stepping ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> float:
        """Take `n` base steps (fewer if the run ends first); the time reached [s]."""
        if n < 0:
            raise CosimError(f"step({n}): a run steps forward only. Fix: give n >= 0.")
        return self._go_to(self.steps + int(n))

    def simulate_until(self, t: float) -> float:
        """Step until the simulated time `t` [s] (the first communication point at or after
        it, within 1e-9 of a step; at most the stop time); the time reached [s]."""
        exp = self._system.experiment
        if not math.isfinite(t) or t < self.time - 1e-9 * exp.step:
            raise CosimError(f"simulate_until({t!r}): the run is at t = {self.time:g} s and "
                             f"steps forward only. Fix: give a time from {self.time:g} s to "
                             f"{exp.stop:g} s.")
        return self._go_to(math.ceil((t - exp.start) / exp.step - 1e-9))

    def _go_to(self, step: int) -> float:
        step = min(step, self._system.experiment.n_steps)
        if step > self.steps and not self.ended:
            self._gate.grant_to(step)
            self._gate.wait_for(step)
        self._raise()
        return self.time

    # -- between steps -------------------------------------------------------------------------
    def value(self, port: str) -> Any:
        """The value of `comp.port` (an input, output or state) where the run is: a number or
        a tuple."""
        comp, _, name = port.rpartition(".")
        components = self._system.components
        if comp not in components or name not in components[comp].variables:
            raise CosimError(f"value({port!r}): no such port in this scenario. Fix: give "
                             f"comp.port, e.g. {next(iter(components), 'plant')}.pose.")
        return components[comp].get(name)

    def set(self, parameter: str, value: Any) -> None:
        """Set `comp.parameter` to `value` from the next step on, as a set event does (checked
        as `--set` checks it)."""
        if self.ended:
            raise CosimError(f"set({parameter!r}): the run has ended. Fix: set it before.")
        self._gate.execution.request_change(parameter, value)

    # -- the end -------------------------------------------------------------------------------
    def finish(self) -> Result:
        """Run to the stop time; its `Result`."""
        self._gate.resume()
        return self._ended()

    def stop(self) -> Result:
        """End the run where it is; its `Result` (status 'stopped', unless it had ended)."""
        self._gate.stop()
        return self._ended()

    def _ended(self) -> Result:
        self._thread.join()
        self._raise()
        assert self._result is not None
        return self._result

    def _raise(self) -> None:
        if self._error is not None:
            error, self._error = self._error, None
            raise error

    def __enter__(self) -> Stepping:
        return self

    def __exit__(self, *exc: object) -> None:
        if self._thread.is_alive():
            self._gate.stop()
            self._thread.join()
