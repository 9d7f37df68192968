"""Statistics of a run per block and per algebraic loop (`summary.json` under `statistics`,
printed by `twmr run -v`).

Per block: `steps` (its `do_step` calls), `evaluations` (its `evaluate` calls, the passes
through a loop included) and, under the adaptive master, `rejected` (steps rolled back); per
loop: the points solved, the iterations (total and the most at one point) and the passes
through it (`twmr.master.loops`). The fixed-step schedule counts nothing while it runs: its
calls follow from the steps done and the plan; the adaptive master counts the calls of its
generated `point` and `step` (every block steps in each), not each block's. The wall
time spent in each block (`time_s`) is measured only when the run asks for it (`Options.timing`,
`twmr run -v`): each call is then wrapped in a timer.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from typing import Any

from twmr.master.loops import LoopSolver
from twmr.master.plan import Evaluate, Plan, Solve


class Probe:
    """Counts (and with `timing` times) every `evaluate` and `do_step` call of each block by
    wrapping the callables `ev<i>` and `st<i>` a generated loop calls."""

    def __init__(self, timing: bool):
        self.timing = timing
        #: block -> [evaluate calls, do_step calls, seconds]
        self.slots: dict[str, list[float]] = {}

    def wrap(self, env: dict[str, Any], order: Sequence[str]) -> None:
        """Wrap `ev<i>` / `st<i>` of the blocks `order` (block i is `order[i]`) in `env`."""
        for i, name in enumerate(order):
            slot = self.slots.setdefault(name, [0, 0, 0.0])
            env[f"ev{i}"] = self._wrapped(env[f"ev{i}"], slot, 0)
            env[f"st{i}"] = self._wrapped(env[f"st{i}"], slot, 1)

    def _wrapped(self, fn: Callable[..., None], slot: list[float], k: int
                 ) -> Callable[..., None]:
        if not self.timing:
            def counted(*args: Any) -> None:
                slot[k] += 1
                fn(*args)
            return counted
        clock = time.perf_counter

        def timed(*args: Any) -> None:
            t0 = clock()
            try:
                fn(*args)
            finally:
                slot[k] += 1
                slot[2] += clock() - t0
        return timed

    def blocks(self) -> dict[str, dict[str, Any]]:
        """Per block: steps, evaluations (and time_s when timed), for blocks called at all."""
        out: dict[str, dict[str, Any]] = {}
        for name, (evaluations, steps, seconds) in self.slots.items():
            if evaluations or steps:
                out[name] = {"steps": int(steps), "evaluations": int(evaluations)}
                if self.timing:
                    out[name]["time_s"] = seconds
        return out


def planned(plan: Plan, steps: Callable[[int], int], points: Callable[[int], int],
            loops: Sequence[LoopSolver]) -> dict[str, dict[str, Any]]:
    """Per block of `plan`, its `do_step` and `evaluate` calls when a block of step multiple m
    stepped `steps(m)` times and evaluated at `points(m)` points, the passes of `loops`
    included."""
    out: dict[str, dict[str, Any]] = {}

    def block(name: str) -> dict[str, Any]:
        return out.setdefault(name, {"steps": 0, "evaluations": 0})

    for s in plan.steps:
        block(s.name)["steps"] = steps(s.multiple)
    passes = {solver.loop.index: solver.evaluations for solver in loops}
    for action in plan.point:
        if isinstance(action, Evaluate):
            block(action.name)["evaluations"] += points(action.multiple)
        elif isinstance(action, Solve):
            for inner in action.body:
                if isinstance(inner, Evaluate):
                    block(inner.name)["evaluations"] += passes.get(action.index, 0)
    return {name: out[name] for name in plan.order if name in out}


def fixed_step(plan: Plan, steps_done: int, finished: bool, loops: Sequence[LoopSolver]
               ) -> dict[str, dict[str, Any]]:
    """`planned` for the fixed-step `plan` after `steps_done` base steps (a block of multiple m
    steps every m and evaluates at every m-th point), the final point included when
    `finished`."""
    return planned(plan, lambda m: steps_done // m,
                   lambda m: math.ceil(steps_done / m) + finished, loops)


def document(blocks: dict[str, dict[str, Any]], loops: Sequence[LoopSolver]
             ) -> dict[str, Any]:
    """The `statistics` of `summary.json`: {'blocks': {...}, 'loops': {'loop1': {...}, ...}}."""
    return {"blocks": blocks,
            "loops": {f"loop{s.loop.index + 1}": s.statistics() for s in loops}}


def lines(statistics: dict[str, Any]) -> list[str]:
    """The statistics as text lines, one per block and one per loop (for `twmr run -v`)."""
    out = []
    for name, b in statistics.get("blocks", {}).items():
        parts = [f"{b.get('steps', 0)} steps"]
        if "rejected" in b:
            parts.append(f"{b['rejected']} rejected")
        parts.append(f"{b.get('evaluations', 0)} evaluations")
        if "time_s" in b:
            parts.append(f"{b['time_s'] * 1e3:.3f} ms")
        out.append(f"  {name}: {', '.join(parts)}")
    for name, lp in statistics.get("loops", {}).items():
        time_text = f", {lp['time_s'] * 1e3:.3f} ms" if "time_s" in lp else ""
        out.append(f"  {name} ({', '.join(lp['components'])}; torn at "
                   f"{', '.join(lp['tears'])}; {lp['method']}): {lp['points']} points, "
                   f"{lp['iterations']} iterations (at most {lp['max_iterations']} at one "
                   f"point), {lp['evaluations']} passes{time_text}")
    return out
