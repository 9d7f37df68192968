"""`Adaptive`: a Gauss-Seidel master whose communication step H grows and shrinks from a
step-doubling error estimate, rolling every component back on a rejected step (as OMSimulator's
adaptive master).

H is always a whole number k of base steps h (time stays an integer count of base steps; k
between `min_step / h` and `max_step / h`). From the communication point t with every
component's state saved:

1. one macro step: inputs written and feedthrough evaluated at t, every component steps by H;
   the outputs y_H of the stepping components that the run reads (wired or recorded) are kept;
2. every state restored, then two steps of k // 2 and k - k // 2 base steps (Gauss-Seidel at t
   and at the middle point): outputs y_H/2;
3. the error err = max_i |y_H - y_H/2|_i / (atol + rtol max(|y_H|_i, |y_H/2|_i)). A
   feedthrough output holds its value from the last point (t after the whole step, t + H/2
   after the halves), so its term is the change of that coupled signal over half a step: an
   input-extrapolation term beside the step-doubling one. It makes the estimate see a
   block's hidden states through the signals they drive (outputs alone, the velocity of a
   second-order plant behind its position would go unseen, and the error end several times
   past the tolerance).

err <= 1 accepts the two half steps (the more accurate result) at t + H; err > 1 restores the
saved states and retries with a smaller H. The next H is k fac with fac = 0.9 err^(-1/2) (the
local error of a zero-order-hold coupling is O(H^2)), bounded to [0.2, 2] and not grown right
after a rejection. A step ends at the grid point at or after a component's next time event
(`Component.next_event`, e.g. a step source's switching time), so a jump between two points is
not missed; a step in which a component met an event it could not announce (an FMU's early
return, `Component.early_event`) is taken again to end at the grid point at or after it. A
step of one base step has no half step: it is taken once, unchecked (after a step of two was
rejected, 1, 2, 4, ... up to `MAX_WAIT` of them before two is tried again); a step at
`min_step` over the tolerance is accepted (counted as forced).

A row is recorded at every accepted communication point t (not at the middle points), so the
time column is uneven; the result store and the writers take any time column.
"""
from __future__ import annotations

import linecache
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from twmr.core.errors import CosimError, Location, Problem
from twmr.master.algorithm import Algorithm
from twmr.master.plan import Plan, build
from twmr.master.schedule import _finite_check, _nonfinite, _point, _record, _Writer, locate_in
from twmr.scenario.system import System

log = logging.getLogger("twmr.adaptive")

#: the step factor's safety margin and bounds per step (grow at most x2, shrink at most x5)
SAFETY, GROW, SHRINK = 0.9, 2.0, 0.2
#: accepted macro steps per `advance` call (the rows reach the observers after each call)
PER_CALL = 64
#: most unchecked one-base-step steps in a row after a step of two was rejected (the wait
#: doubles with each such rejection, from 1)
MAX_WAIT = 64


@dataclass(frozen=True)
class Attempt:
    """One macro step tried from base step `n` over `k` base steps; `err` its scaled error
    estimate (NaN: unchecked, k = 1)."""

    n: int
    k: int
    err: float
    accepted: bool


class Adaptive(Algorithm):
    """Step-size control by step doubling with rollback of every component (see the module
    docstring); registered as 'adaptive' in `twmr.algorithms`."""

    needs_state_rollback = True
    variable_step = True

    def __init__(self) -> None:
        self.source = ""
        self.filename = ""
        self.history: list[Attempt] = []
        self._owner: dict[int, tuple[str, str]] = {}
        self._fns: dict[str, Callable[..., Any]] = {}

    def refuse(self, system: System) -> Problem | None:
        where = Location(system.source, 0, "experiment.algorithm")
        multi = [n for n in system.components if system.multiple(n) != 1]
        if multi:
            return Problem(where, f"the adaptive master steps every component by the same "
                           f"communication step, but {', '.join(map(repr, multi))} "
                           f"{'has' if len(multi) == 1 else 'have'} a step_multiple.",
                           "remove step_multiple, or use gauss_seidel.")
        if system.paced:
            return Problem(where, "the adaptive master cannot run paced to the wall clock "
                           "(realtime): its steps are retried.",
                           "set 'realtime: false', or use gauss_seidel.")
        return None

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        exp = system.experiment
        self.h, self.start0 = exp.step, exp.start
        self.k_min = max(1, round((exp.min_step or exp.step) / exp.step))
        self.k_max = max(self.k_min, round((exp.max_step or exp.stop - exp.start) / exp.step))
        self.rtol, self.atol = exp.rtol, exp.atol
        self.k, self.held = self.k_min, False
        self.wait, self.backoff = 0, 1
        self.comps = [system.components[n] for n in system.order]
        plan = build(system, "gauss_seidel", record, 1, check_finite)
        read = {(c.src, c.src_port) for c in system.connections} | set(record)
        stepping = {s.name for s in plan.steps}
        self.watched = [(n, p) for n in plan.order if n in stepping
                        for p, v in system.components[n].variables.items()
                        if v.kind in ("output", "state") and v.type == "Real" and (n, p) in read]
        self.source, self._owner, env = _generate(system, plan, self.watched)
        self.filename = f"<twmr adaptive {system.source} {id(self):x}>"
        linecache.cache[self.filename] = (len(self.source), None,
                                          self.source.splitlines(True), self.filename)
        exec(compile(self.source, self.filename, "exec"), env)  # noqa: S102 - generated here
        self._fns = {k: env[k] for k in ("point", "record", "step", "outputs")}

    def advance(self, n0: int, n1: int, rows: list[Any]) -> int:
        """Up to `PER_CALL` accepted macro steps from n0, the last ending at n1 at most (n1 is
        the stop: `Execution` gives a variable-step algorithm the whole run)."""
        n = n0
        for _ in range(PER_CALL):
            n = self._macro(n, n1, rows)
            if n >= n1:
                break
        return n

    def finish(self, n: int, rows: list[Any]) -> None:
        t = self.start0 + n * self.h
        self._fns["point"](t)
        self._fns["record"](t, rows)

    def _macro(self, n: int, n1: int, rows: list[Any]) -> int:
        """One accepted macro step from base step n (not past n1), with as many retries as it
        takes; the step reached."""
        point, record, step = self._fns["point"], self._fns["record"], self._fns["step"]
        h, t = self.h, self.start0 + n * self.h
        k = min(self.k, n1 - n, self._to_event(t))
        while True:
            saved = [c.get_state() for c in self.comps]
            pending: list[Any] = []
            point(t)
            record(t, pending)
            if k == 1:
                step(t, h)
                err = math.nan
            else:
                step(t, k * h)
                early = self._early(t, k)
                if early < k:  # an event inside the step: take the step again, to end there
                    self._restore(saved)
                    for comp, state in zip(self.comps, saved, strict=True):
                        comp.release_state(state)
                    k = early
                    continue
                big = self._values()
                self._restore(saved)
                half = k // 2
                point(t)
                step(t, half * h)
                point(t + half * h)
                step(t + half * h, (k - half) * h)
                err = self._error(big, self._values())
            accepted = not err > 1.0 or k <= self.k_min
            self.history.append(Attempt(n, k, err, accepted))
            log.debug("t = %g s, H = %g s, err = %.3g: %s", t, k * h, err,
                      "accepted" if accepted else "rejected")
            if accepted:
                for comp, state in zip(self.comps, saved, strict=True):
                    comp.release_state(state)
                rows.extend(pending)
                capped = k < self.k and k == self._to_event(t)
                self.k = max(self.k, k) if capped else self._next(k, err)
                self.held = False
                return n + k
            self._restore(saved)
            for comp, state in zip(self.comps, saved, strict=True):
                comp.release_state(state)
            k = max(self.k_min, min(k - 1, int(k * self._factor(err))))
            self.held = True
            if k == 1:  # the tolerance needs one base step: stay there a while before trying 2
                self.wait, self.backoff = self.backoff, min(MAX_WAIT, 2 * self.backoff)

    def _early(self, t: float, k: int) -> int:
        """Base steps from t to the first grid point at or after an event a component met
        inside its last step (`Component.early_event`); k when none."""
        events = [e for c in self.comps if (e := c.early_event()) is not None and e > t]
        if not events:
            return k
        return max(1, min(k, math.ceil((min(events) - t) / self.h - 1e-9)))

    def _to_event(self, t: float) -> int:
        """Base steps from t to the first grid point at or after the next time event."""
        events = [e for c in self.comps if (e := c.next_event(t)) is not None and e > t]
        if not events:
            return self.k_max
        return max(1, math.ceil((min(events) - t) / self.h - 1e-9))

    def _factor(self, err: float) -> float:
        """The step factor for a scaled error `err` (0: the most growth)."""
        if not err > 0.0:
            return GROW
        return min(GROW, max(SHRINK, SAFETY * err ** -0.5))

    def _next(self, k: int, err: float) -> int:
        """The next step [base steps] after an accepted one of k; an unchecked step doubles."""
        if math.isnan(err) and self.wait > 0:
            self.wait -= 1
            return k
        if not math.isnan(err):
            self.backoff = 1
        fac = GROW if math.isnan(err) else self._factor(err)
        if self.held:
            fac = min(fac, 1.0)
        return min(self.k_max, max(self.k_min, int(k * fac)))

    def _values(self) -> np.ndarray:
        return np.hstack(self._fns["outputs"]()).astype(float) if self.watched \
            else np.zeros(0)

    def _error(self, big: np.ndarray, small: np.ndarray) -> float:
        if not big.size:
            return 0.0
        scale = self.atol + self.rtol * np.maximum(np.abs(big), np.abs(small))
        return float(np.max(np.abs(big - small) / scale))

    def _restore(self, saved: list[Any]) -> None:
        for comp, state in zip(self.comps, saved, strict=True):
            comp.set_state(state)

    def report(self) -> dict[str, object]:
        done = [a for a in self.history if a.accepted]
        sizes = [a.k * self.h for a in done]
        return {"steps_accepted": len(done),
                "steps_rejected": len(self.history) - len(done),
                "steps_unchecked": sum(a.k == 1 for a in done),
                "steps_forced": sum(a.err > 1.0 for a in done),
                "step_min_s": min(sizes, default=math.nan),
                "step_max_s": max(sizes, default=math.nan)}

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        return locate_in(exc, self.filename, self._owner)


def _generate(system: System, plan: Plan, watched: list[tuple[str, str]]
              ) -> tuple[str, dict[int, tuple[str, str]], dict[str, Any]]:
    """(source, line owners, globals) of `point(t)` (inputs written, feedthrough evaluated,
    NaN/Inf check), `record(t, rows)`, `step(t, H)` (every acting component steps by H) and
    `outputs()` (the `watched` port values)."""
    ids = {name: i for i, name in enumerate(plan.order)}
    env: dict[str, Any] = {"nonfinite": _nonfinite}
    for name, comp in system.components.items():
        i = ids[name]
        env.update({f"d{i}": comp.__dict__, f"ev{i}": comp.evaluate, f"st{i}": comp.do_step})

    def ref(name: str, port: str) -> str:
        return f"d{ids[name]}[{port!r}]"

    w = _Writer()
    w.add(0, "def point(t):")
    w.add(1, "pass")
    _point(w, 1, plan, ids, ref, final=True)
    _finite_check(w, 1, plan, ref)
    w.add(0, "def record(t, rows):")
    w.add(1, "pass")
    _record(w, 1, plan, ref, final=True)
    w.add(0, "def step(t, H):")
    w.add(1, "pass")
    for s in plan.steps:
        w.add(1, f"st{ids[s.name]}(t, H)", (s.name, "do_step"))
    w.add(0, "def outputs():")
    w.add(1, "return (" + "".join(f"{ref(n, p)}, " for n, p in watched) + ")")
    return "\n".join(w.lines) + "\n", w.owner, env


def adaptive(compiled: str = "auto") -> Algorithm:
    """The adaptive master (registered as 'adaptive' in `twmr.algorithms`); it runs the Python
    schedule, so `compiled` 'on' is refused."""
    if compiled == "on":
        raise CosimError("the adaptive master runs the Python schedule only (its steps change "
                         "size and are retried). Fix: run without --compiled on (or "
                         "TWMR_COMPILED=on), or use gauss_seidel.")
    return Adaptive()
