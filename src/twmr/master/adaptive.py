"""`Adaptive`: a Gauss-Seidel master whose communication step H grows and shrinks from a
step-doubling error estimate, rolling every component back on a rejected step (as OMSimulator's
adaptive master).

H is a whole number k of base steps h (k between `min_step / h` and `max_step / h`), and a
step ends on the grid of base steps, except one that ends at a state event (below). From the
communication point t with every component's state saved:

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

Events located in time: every component is asked to hold a state event found at the very end of
a step (`Component.hold_events`). When an attempt meets one inside the step
(`Component.state_event()`, e.g. a model-exchange FMU's located zero crossing at t_e), every
state is restored and the step retried to end at t_e exactly, off the grid; the attempts that
will be retried so let a component stop at the event (`Component.stop_at_events`), and a
component whose step does not repeat from the saved state (`Component.repeats_steps`: a
model-exchange FMU whose solver went on with its history) has the step taken again first, so
that the retry finds the crossing where the retaken step found it. After it is
accepted, a row is recorded just before the event, the event is handled (`Component.event`) and
the next step records the row just after it at the same time, then ends on the grid again. A
non-Real output that the run reads and that changes inside a step (a co-simulation FMU's event
counter) makes the master halve the step until the one holding the change is `min_step` long.
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
from twmr.master import loops, stats
from twmr.master.algorithm import Algorithm, OptionError, WithOptions
from twmr.master.plan import Plan, build
from twmr.master.render import Writer, finite_check, nonfinite, point, record
from twmr.master.schedule import locate_in
from twmr.master.ticks import Tick
from twmr.scenario.system import System

log = logging.getLogger("twmr.adaptive")

#: the step factor's safety margin and bounds per step (grow at most x2, shrink at most x5)
SAFETY, GROW, SHRINK = 0.9, 2.0, 0.2
#: accepted macro steps per `advance` call (the rows reach the observers after each call)
PER_CALL = 64
#: most unchecked one-base-step steps in a row after a step of two was rejected (the wait
#: doubles with each such rejection, from 1)
MAX_WAIT = 64
#: a state event closer than this many base steps to a step's start is taken as at its start
EVENT_TOL = 1e-9
#: most retries of one macro step to a newly located state event
MAX_RELOCATE = 8


@dataclass(frozen=True)
class Attempt:
    """One macro step tried from base step `n` over `k` base steps; `err` its scaled error
    estimate (NaN: unchecked, k = 1). `t` [s] and `size` [s] are where it started and how long
    it was: a step that starts or ends at a state event is off the grid (`n` is then the grid
    point before its start and `k` the grid points to its end, rounded up)."""

    n: int
    k: int
    err: float
    accepted: bool
    t: float = math.nan
    size: float = math.nan


class Adaptive(Algorithm):
    """Step-size control by step doubling with rollback of every component (see the module
    docstring); registered as 'adaptive' in `twmr.algorithms`."""

    needs_state_rollback = True
    variable_step = True

    def __init__(self) -> None:
        self.source = ""
        self.filename = ""
        self.history: list[Attempt] = []
        self.loops: list[loops.LoopSolver] = []
        self.probe: stats.Probe | None = None
        self.calls: dict[str, int] = {}
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

    def notes(self, system: System) -> list[str]:
        exp = system.experiment
        longest = exp.options.get("max_step", exp.stop - exp.start)
        return [f"component '{name}': {why}, so the adaptive master cannot locate them: an "
                f"event is placed only within the step that holds it (up to max_step = "
                f"{longest:g} s). Fix: run it as model exchange (interface: model_exchange; "
                f"events located to the tolerance), or bound the step with max_step."
                for name, comp in system.components.items()
                if (why := comp.events_unseen()) is not None]

    def prepare(self, system: System, record: list[tuple[str, str]], decimation: int,
                check_finite: bool = True) -> None:
        exp = system.experiment
        self.h, self.start0 = exp.step, exp.start
        options = {**DEFAULTS, **exp.options}
        self.k_min = max(1, round(options.get("min_step", exp.step) / exp.step))
        self.k_max = max(self.k_min, round(options.get("max_step", exp.stop - exp.start)
                                           / exp.step))
        self.rtol, self.atol = options["rtol"], options["atol"]
        self.k, self.held = self.k_min, False
        self.wait, self.backoff = 0, 1
        self.m, self.t_off = 0, math.nan  # the grid point at or before now; now if off it
        self.bracket: int | None = None  # a discrete output changes before this grid point
        self.comps = [system.components[n] for n in system.order]
        for comp in self.comps:
            comp.hold_events = True
        plan = build(system, "gauss_seidel", record, 1, check_finite)
        read = {(c.src, c.src_port) for c in system.connections} | set(record)
        stepping = {s.name for s in plan.steps}
        outputs = [(n, p, v) for n in plan.order if n in stepping
                   for p, v in system.components[n].variables.items()
                   if v.kind in ("output", "state") and (n, p) in read]
        fed = {(c.src, c.src_port) for c in system.connections}
        self.watched = [(n, p) for n, p, v in outputs if v.type == "Real" and
                        ((n, p) in fed or not system.components[n].controls_its_error())]
        self.discrete = [(n, p) for n, p, v in outputs if v.type != "Real"]
        self.source, self._owner, env = _generate(system, plan, self.watched, self.discrete)
        self.filename = f"<twmr adaptive {system.source} {id(self):x}>"
        linecache.cache[self.filename] = (len(self.source), None,
                                          self.source.splitlines(True), self.filename)
        exec(compile(self.source, self.filename, "exec"), env)  # noqa: S102 - generated here
        timing = self.timing
        self.probe = stats.Probe(timing) if timing else None
        if self.probe is not None:
            self.probe.wrap(env, plan.order)
        self.loops = loops.bind(env, system, plan, timing)
        self.plan = plan
        self._fns = {k: env[k] for k in ("point", "record", "step", "outputs", "discrete")}
        self.calls = {"point": 0, "step": 0}
        for key in self.calls:
            self._fns[key] = _counted(self._fns[key], self.calls, key)

    def advance(self, n0: int, n1: int, rows: list[Any]) -> int:
        """Up to `PER_CALL` accepted macro steps from n0 (more while they stay before grid point
        n0 + 1, at state events), the last ending at n1 at most (n1 is the stop: `Execution`
        gives a variable-step algorithm the whole run); the grid point at or before the time
        reached."""
        if self.m != n0:  # a fresh start, or a caller that moved the time: on the grid
            self.m, self.t_off = n0, math.nan
        for i in range(1_000_000):
            self._macro(n1, rows)
            if self.m >= n1 or (i + 1 >= PER_CALL and self.m > n0):
                break
        return self.m

    def finish(self, n: int, rows: list[Any]) -> None:
        t = self.start0 + n * self.h
        self._fns["point"](t)
        self._fns["record"](t, rows)

    def _grid(self, m: int) -> float:
        return self.start0 + m * self.h

    def _macro(self, n1: int, rows: list[Any]) -> None:
        """One accepted macro step from now (not past grid point n1), with as many retries as
        it takes; a step that ends at a state event records the row just before it and
        has the event handled (the next step records the row after it)."""
        point, record, step = self._fns["point"], self._fns["record"], self._fns["step"]
        h, m = self.h, self.m
        on_grid = math.isnan(self.t_off)
        t = self._grid(m) if on_grid else self.t_off
        to_event = self._to_event(m)
        k = min(self.k, n1 - m, self.k_max if to_event is None else to_event)
        if self.bracket is not None:  # halve the interval a discrete output changed in
            k = min(k, max(self.k_min, (self.bracket - m) // 2))
        at_event: float | None = None  # the step ends at this state event instead
        relocated = 0
        retaken = False
        while True:
            t_end = at_event if at_event is not None else self._grid(m + k)
            whole = k * h if on_grid and at_event is None else t_end - t
            saved = [c.get_state() for c in self.comps]
            stop = relocated < MAX_RELOCATE  # an event inside: the step is taken again
            for comp in self.comps:
                comp.stop_at_events = EVENT_TOL * h if stop else None
            pending: list[Any] = []
            point(t)
            record(t, pending)
            before = self._fns["discrete"]()
            step(t, whole)
            early = self._early(m, k) if at_event is None else k
            if early < k:  # an event inside the step it could not announce: retaken to end there
                self._undo(saved, None)
                k = early
                continue
            found = self._state_event(t, t_end)
            if found is not None and not retaken and \
                    not all(c.repeats_steps() for c in self.comps):
                self._undo(saved, Attempt(m, k, math.nan, False, t, whole))
                retaken = True  # from the saved states alone, as the steps to the event will be
                continue
            changed = self._fns["discrete"]() != before
            err = math.nan
            # a change in a step that ends at a time event is that event's, at the end
            hunt = changed and k > self.k_min and at_event is None and k != to_event
            checked = bool(self.watched) and (whole >= 2 * h if at_event is not None else k > 1)
            if found is None and not hunt and checked:
                big = self._values()
                self._restore(saved)
                if at_event is not None:
                    mid, first = t + whole / 2, whole / 2
                elif on_grid:
                    mid, first = t + (k // 2) * h, (k // 2) * h
                else:
                    mid = self._grid(m + k // 2)
                    first = mid - t
                point(t)
                step(t, first)
                found = self._state_event(t, mid)
                if found is None or not stop:
                    point(mid)
                    step(mid, t_end - mid)
                    found = found if found is not None else self._state_event(mid, t_end)
                    err = self._error(big, self._values())
            if found is not None and relocated < MAX_RELOCATE:
                relocated += 1
                self._undo(saved, Attempt(m, k, math.nan, False, t, whole))
                at_event = found  # retried to end at the event, first of all
                k = max(1, math.ceil((found - self._grid(m)) / h - 1e-9))
                continue
            if hunt:
                self._undo(saved, Attempt(m, k, math.nan, False, t, whole))
                self.bracket = m + k
                k = max(self.k_min, k // 2)
                continue
            accepted = not err > 1.0 or k <= self.k_min
            self.history.append(Attempt(m, k, err, accepted, t, whole))
            log.debug("t = %g s, H = %g s, err = %.3g: %s", t, whole, err,
                      "accepted" if accepted else "rejected")
            if accepted:
                for comp, state in zip(self.comps, saved, strict=True):
                    comp.release_state(state)
                rows.extend(pending)
                break
            self._undo(saved, None)
            k_new = max(self.k_min, min(k - 1, int(k * self._factor(err))))
            if at_event is not None and self._grid(m + k_new) < at_event:
                at_event = None
            k = k_new
            self.held = True
            if k == 1:  # the tolerance needs one base step: stay there a while before trying 2
                self.wait, self.backoff = self.backoff, min(MAX_WAIT, 2 * self.backoff)
        if changed:
            self.bracket = None
        elif self.bracket is not None and m + k >= self.bracket:
            self.bracket = None  # the change seen before did not come again
        held = at_event if at_event is not None else self._held_at(t_end)
        if held is not None:
            point(held)
            record(held, rows)  # just before the event
            for comp in self.comps:
                comp.event(held)
        if at_event is not None:
            self.m = m + k - 1 if self._grid(m + k) > at_event else m + k
            self.t_off = at_event if self._grid(self.m) != at_event else math.nan
            return
        self.m, self.t_off = m + k, math.nan
        capped = k < self.k and k == to_event
        self.k = max(self.k, k) if capped else self._next(k, err)
        self.held = False

    def _undo(self, saved: list[Any], attempt: Attempt | None) -> None:
        """Every component back to `saved`, which is released; `attempt` logged as rejected."""
        if attempt is not None:
            self.history.append(attempt)
        self._restore(saved)
        for comp, state in zip(self.comps, saved, strict=True):
            comp.release_state(state)

    def _state_event(self, t: float, t_end: float) -> float | None:
        """The earliest state event the components met in the steps from t to t_end [s] that lies
        inside them (more than `EVENT_TOL` base steps from either end); None: none."""
        tol = EVENT_TOL * self.h
        inside = [e for c in self.comps if (e := c.state_event()) is not None and
                  t + tol < e < t_end - tol]
        return min(inside, default=None)

    def _held_at(self, t_end: float) -> float | None:
        """t_end [s] when a component met a state event at the very end of the last step (it
        holds it); None otherwise."""
        tol = EVENT_TOL * self.h
        held = any(e is not None and abs(e - t_end) <= tol
                   for e in (c.state_event() for c in self.comps))
        return t_end if held else None

    def _early(self, m: int, k: int) -> int:
        """Base steps from grid point m to the first grid point at or after an event a
        component met inside its last step (`Component.early_event`); k when none."""
        t = self._grid(m)
        events = [e for c in self.comps if (e := c.early_event()) is not None and e > t]
        if not events:
            return k
        return max(1, min(k, math.ceil((min(events) - t) / self.h - 1e-9)))

    def _to_event(self, m: int) -> int | None:
        """Base steps from grid point m to the first grid point at or after the next time
        event (after now); None: no time event ahead."""
        t = self._grid(m) if math.isnan(self.t_off) else self.t_off
        events = [e for c in self.comps if (e := c.next_event(t)) is not None and e > t]
        if not events:
            return None
        return max(1, math.ceil((min(events) - self._grid(m)) / self.h - 1e-9))

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
        sizes = [a.size for a in done]
        return {"steps_accepted": len(done),
                "steps_rejected": len(self.history) - len(done),
                "steps_unchecked": sum(a.k == 1 for a in done),
                "steps_forced": sum(a.err > 1.0 for a in done),
                "step_min_s": min(sizes, default=math.nan),
                "step_max_s": max(sizes, default=math.nan)}

    def statistics(self, steps_done: int, finished: bool) -> dict[str, object]:
        rejected = sum(not a.accepted for a in self.history)
        blocks = self.probe.blocks() if self.probe is not None else \
            stats.planned(self.plan, lambda m: self.calls["step"],
                          lambda m: self.calls["point"], self.loops)
        for figures in blocks.values():
            if figures["steps"]:
                figures["rejected"] = rejected
        return stats.document(blocks, self.loops)

    def locate(self, exc: BaseException) -> tuple[str, str, float]:
        return locate_in(exc, self.filename, self._owner)


def _generate(system: System, plan: Plan, watched: list[tuple[str, str]],
              discrete: list[tuple[str, str]]
              ) -> tuple[str, dict[int, tuple[str, str]], dict[str, Any]]:
    """(source, line owners, globals) of `point(t)` (inputs written, feedthrough evaluated,
    NaN/Inf check), `record(t, rows)`, `step(t, H)` (every acting component steps by H),
    `outputs()` (the `watched` port values) and `discrete()` (the `discrete` ones)."""
    ids = {name: i for i, name in enumerate(plan.order)}
    env: dict[str, Any] = {"nonfinite": nonfinite, "Tick": Tick}
    for name, comp in system.components.items():
        i = ids[name]
        env.update({f"d{i}": comp.__dict__, f"ev{i}": comp.evaluate, f"st{i}": comp.do_step})

    def ref(name: str, port: str) -> str:
        return f"d{ids[name]}[{port!r}]"

    w = Writer()
    w.add(0, "def point(t):")
    w.add(1, "pass")
    point(w, 1, plan, ids, ref, final=True)
    finite_check(w, 1, plan, ref)
    w.add(0, "def record(t, rows):")
    w.add(1, "pass")
    record(w, 1, plan, ref, final=True)
    w.add(0, "def step(t, H):")
    w.add(1, "pass")
    for s in plan.steps:
        w.add(1, f"st{ids[s.name]}(t, H)", (s.name, "do_step"))
    w.add(0, "def outputs():")
    w.add(1, "return (" + "".join(f"{ref(n, p)}, " for n, p in watched) + ")")
    w.add(0, "def discrete():")
    w.add(1, "return (" + "".join(f"{ref(n, p)}, " for n, p in discrete) + ")")
    loops.render(w, plan, ids, ref)
    return "\n".join(w.lines) + "\n", w.owner, env


def _counted(fn: Callable[..., Any], calls: dict[str, int], key: str) -> Callable[..., Any]:
    """`fn` counting its calls in `calls[key]`."""
    def counted(*args: Any) -> Any:
        calls[key] += 1
        return fn(*args)
    return counted


#: the experiment keys of the adaptive master, with their JSON schemas (`options_schema`)
OPTIONS: dict[str, Any] = {
    "rtol": {"type": "number", "exclusiveMinimum": 0, "description": "relative tolerance of "
             "the step-doubling error estimate (default 1e-4)."},
    "atol": {"type": "number", "exclusiveMinimum": 0, "description": "absolute tolerance of "
             "the step-doubling error estimate (default 1e-6)."},
    "min_step": {"type": "number", "exclusiveMinimum": 0, "description": "smallest "
                 "communication step [s], a whole multiple of step (default: step)."},
    "max_step": {"type": "number", "exclusiveMinimum": 0, "description": "largest "
                 "communication step [s], a whole multiple of step (default: stop - start)."},
}
DEFAULTS = {"rtol": 1e-4, "atol": 1e-6}


def read_options(given: dict[str, Any], step: float, duration: float) -> dict[str, Any]:
    """rtol, atol [1], min_step and max_step [s] as the master runs them: given or default, the
    step bounds whole multiples of the base `step` within the run, min <= max. `OptionError`
    otherwise."""
    options = {**DEFAULTS, "min_step": step, "max_step": duration,
               **{k: float(v) for k, v in given.items()}}
    for key in ("min_step", "max_step"):
        n = options[key] / step
        if not (round(n) >= 1 and math.isclose(n, round(n), rel_tol=1e-9, abs_tol=1e-9)):
            raise OptionError(key, f"{key} = {options[key]:g} s is not a whole multiple of the "
                              f"base step {step:g} s.", f"give {key} as n * step, n >= 1 (the "
                              f"adaptive master steps on the base grid).")
        options[key] = min(round(n) * step, duration)
    if options["min_step"] > options["max_step"]:
        key = "min_step" if "min_step" in given else "max_step"
        raise OptionError(key, f"min_step ({options['min_step']:g} s) is larger than max_step "
                          f"({options['max_step']:g} s).", "make min_step <= max_step.")
    return options


def _adaptive(compiled: str = "auto") -> Algorithm:
    """The adaptive master; it runs the Python schedule, so `compiled` 'on' is refused."""
    if compiled == "on":
        raise CosimError("the adaptive master runs the Python schedule only (its steps change "
                         "size and are retried). Fix: run without --compiled on (or "
                         "TWMR_COMPILED=on), or use gauss_seidel.")
    return Adaptive()


#: registered as 'adaptive' in `twmr.algorithms`, with its options
adaptive = WithOptions(_adaptive, OPTIONS, read_options)
