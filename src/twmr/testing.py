"""`Harness`: drive one component by hand, as the master would, in a unit test.

    from twmr.testing import Harness

    with Harness("asmc", parameters={"lookahead": -0.05}) as ctrl:   # a kind or a class
        ctrl.set(pose=(0, 0, 0), wheel_speed=(0, 0))                  # inputs, checked
        ctrl.initialize()
        ctrl.evaluate()                     # feedthrough outputs at the current time
        torque = ctrl["torque"]
        ctrl.step()                         # evaluate (if feedthrough), do_step(t, h), t += h

The harness keeps the life cycle in order (prepare, setup, initialize before any step; terminate
once, also when the test fails inside `with`), checks every value through the port that takes it
(size, type, min/max), and keeps time as start + n h like the master, so what passes here behaves
the same inside a scenario.

`assert_matches(run, reference, abs=, rel=, shift=)`: a run stays inside the tolerance tubes
around a reference result (what `twmr verify` checks).
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.run import RunContext


class Harness:
    """One component under test: `kind` is a registered kind name ('asmc', 'fmu', ...) or a
    `Component` subclass; `parameters` may include construction parameters (an FMU's `path`);
    `initial` sets inputs' and states' start values; step h [s]."""

    def __init__(self, kind: str | type[Component], name: str = "dut",
                 parameters: dict[str, Any] | None = None, initial: dict[str, Any] | None = None,
                 start: float = 0.0, stop: float | None = None, step: float = 1e-3,
                 folder: str | Path | None = None, base_dir: str | Path = "."):
        if isinstance(kind, str):
            from twmr.registry import lookup

            cls: type[Component] = lookup(kind)
        else:
            cls = kind
        params = dict(parameters or {})
        construction = {k: params.pop(k) for k in cls.construction_parameters if k in params}
        self.component: Component = cls.create(name, Path(base_dir), **construction)
        values = {**params, **(initial or {})}
        for key, value in sorted(values.items(), key=lambda kv: kv[0] not in
                                 self.component.sizing_parameters):
            self._check(key, ("parameter",) if key in params else ("input", "state"))
            self.component.set_parameter(key, value)
        self.start, self.stop, self.h = start, stop, step
        self.folder = Path(folder) if folder is not None else None
        self.n = 0
        self._initialized = False
        self._terminated = False

    @property
    def t(self) -> float:
        """The current communication point [s]: start + n h."""
        return self.start + self.n * self.h

    def _check(self, name: str, kinds: tuple[str, ...]) -> None:
        var = self.component.variables.get(name)
        if var is None or var.kind not in kinds:
            known = [n for n, v in self.component.variables.items() if v.kind in kinds]
            raise KeyError(f"'{self.component.name}' has no {' or '.join(kinds)} '{name}'; "
                           f"known: {', '.join(known)}")

    def set(self, **inputs: Any) -> Harness:
        """Write inputs (coerced and checked by their ports), as the master does before a call."""
        values = {}
        for name, value in inputs.items():  # all checked before any is written
            self._check(name, ("input",))
            values[name] = self.component.variables[name].coerce(value)
        self.component.__dict__.update(values)
        return self

    def initialize(self) -> Harness:
        """prepare, setup and initialize: the outputs then hold their values at `start`."""
        if self._initialized:
            raise RuntimeError("initialize() was already called")
        c = self.component
        c.prepare(RunContext(self.folder, self.h, False))
        c.setup(self.start, self.stop)
        c.initialize()
        self._initialized = True
        return self

    def evaluate(self) -> Harness:
        """Recompute the feedthrough outputs from the inputs at the current time."""
        self._ready()
        self.component.evaluate(self.t)
        return self

    def step(self, n: int = 1, **inputs: Any) -> Harness:
        """`n` communication steps: write `inputs`, evaluate (a feedthrough component), then
        do_step(t, h) and advance the time, as the master's Gauss-Seidel loop does."""
        self._ready()
        for _ in range(n):
            if inputs:
                self.set(**inputs)
            if self.component.has_feedthrough:
                self.component.evaluate(self.t)
            self.component.do_step(self.t, self.h)
            self.n += 1
        return self

    def _ready(self) -> None:
        if not self._initialized:
            raise RuntimeError("call initialize() before evaluate() or step()")
        if self._terminated:
            raise RuntimeError("the component is terminated")

    def __getitem__(self, name: str) -> Any:
        """The current value of any port, parameter or state."""
        self._check(name, ("input", "output", "state", "parameter"))
        return self.component.get(name)

    @property
    def outputs(self) -> dict[str, Any]:
        """Every output and state by name."""
        return {n: self.component.get(n) for n in self.component.outputs}

    def terminate(self) -> None:
        """Terminate once (later calls do nothing)."""
        if not self._terminated:
            self._terminated = True
            self.component.terminate()

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.terminate()


def assert_matches(run: str | Path | Any, reference: str | Path | Any, *, abs: float = 0.0,
                   rel: float = 1e-3, shift: float = 0.0,
                   signals: list[str] | None = None) -> Any:
    """Assert that `run` (a run's folder, a result file or a `Result`) stays inside the
    tolerance tubes around `reference` (`twmr.verify`: abs + rel |reference|, time shift
    [s]); AssertionError with the table `twmr verify` prints. Returns the verdict."""
    from twmr.verify import Tolerance, verify

    verdict = verify(run, reference, Tolerance(abs, rel, shift), signals)
    if not verdict.passed:
        raise AssertionError(verdict.text())
    return verdict
