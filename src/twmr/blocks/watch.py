"""`condition_watch`: what a scenario's condition event (`events: - when: "comp.port > c"`)
inserts on the signal it watches (`twmr.scenario.events`). At each communication point it
compares its input u with `threshold` by `op` (>, >=, <, <=); the condition becoming true fires
it once, and it fires again only after the condition has been false with u at least `hysteresis`
back from the threshold (u <= threshold - hysteresis for > and >=; u >= threshold + hysteresis
for < and <=). A condition true at the first point does not fire: it must become true.

On firing at the point t (u true there, false at the point before, t_prev) it counts, and its
outputs say when: `located`, the crossing time located by linear interpolation of u between
t_prev and t (as a state event's time is located within the step, here with the values at the
communication points; exact for a signal linear over the step), and `fired_at` = t + h, the
communication point from which the master applies the event's action (`twmr.master.execution`).
Its outputs depend on no input (they change at its step), so a watch closes no algebraic loop.
"""
from __future__ import annotations

from typing import Any, NamedTuple

from twmr.core.component import Component
from twmr.core.kernel import Kernel, kernel_function
from twmr.core.port import STRING, Input, Output, Parameter

#: the comparisons, by their text, and their codes in the kernel
OPS = {">": 0.0, ">=": 1.0, "<": 2.0, "<=": 3.0}


class WatchParams(NamedTuple):
    op: float  #: OPS
    threshold: float
    hysteresis: float


@kernel_function
def condition_true(v: float, p: WatchParams) -> bool:
    """The condition at the value v."""
    if p.op == 0.0:
        return v > p.threshold
    if p.op == 1.0:
        return v >= p.threshold
    if p.op == 2.0:
        return v < p.threshold
    return v <= p.threshold


@kernel_function
def watch_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: WatchParams
               ) -> tuple[tuple, tuple]:
    """x = (armed: -1 before the first point, 1 armed, 0 fired and not yet re-armed; count,
    located, fired_at, the point before and u there); y = (count, located, fired_at)."""
    armed, count, located, fired_at, t_prev, u_prev = x
    v = u[0]
    true = condition_true(v, p)
    if armed < 0.0:
        armed = 0.0 if true else 1.0
    elif armed > 0.0 and true:
        count += 1.0
        located = t
        if v != u_prev:
            share = (p.threshold - u_prev) / (v - u_prev)
            located = t_prev + min(1.0, max(0.0, share)) * (t - t_prev)
        fired_at = t + h
        armed = 0.0
    elif armed == 0.0 and not true:
        upward = p.op < 2.0
        if (upward and v <= p.threshold - p.hysteresis) or (
                not upward and v >= p.threshold + p.hysteresis):
            armed = 1.0
    return (armed, count, located, fired_at, t, v), (count, located, fired_at)


class ConditionWatch(Component):
    """Fires when u `op` `threshold` becomes true (again after `hysteresis`): its count, the
    located crossing time [s] and the time its action applies [s]."""

    kind = "condition_watch"
    op = Parameter(">", type=STRING, description=" | ".join(OPS))
    threshold = Parameter(0.0, description="the value u is compared with")
    hysteresis = Parameter(0.0, min=0.0, description="how far back u must go to fire again")
    u = Input(0.0, description="the signal watched")
    count = Output(0.0, description="times fired")
    located = Output(0.0, unit="s", description="the last firing's located crossing time")
    fired_at = Output(0.0, unit="s", description="the last firing's action time (t + h)")

    @classmethod
    def examples(cls, h: float) -> tuple[dict[str, Any], ...]:
        """Parameter sets for tests (tests/property/test_block_forms.py)."""
        return ({"op": ">", "threshold": 0.2}, {"op": "<=", "threshold": -0.1, "hysteresis": 0.3},
                {"op": ">=", "threshold": 0.0, "hysteresis": 0.05})

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.op not in OPS:
            return [("op", f"op '{self.op}' is unknown.", f"use one of: {', '.join(OPS)}.")]
        return []

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=WatchParams(OPS[self.op], float(self.threshold),
                                         float(self.hysteresis)),
                      state=(-1.0, 0.0, 0.0, 0.0, 0.0, 0.0), step=watch_step)
