"""Algebraic loops solved at each communication point (`experiment.loops: solve`).

The scenario builder finds the loops (`twmr.scenario.graph.find_loops`: the strongly connected
parts of the port graph) and tears each at some of its Real inputs: with those inputs held, one
pass through the loop — input writes and evaluations in topological order — is a function
x -> g(x), x the values of the torn inputs, g(x) what their sources give after the pass. The
loop is solved when x = g(x). The plan (`twmr.master.plan.Solve`) puts each loop where
everything it reads is final; the Python schedule and the adaptive master render one pass as a
generated function `body<k>(t)` (`render`) and call a `LoopSolver` in its place (`bind`):

- **fixed_point**: x <- x + w (g(x) - x), w the relaxation;
- **newton**: the Jacobian J of g by forward differences (one pass per torn value, step
  sqrt(eps) max(1, |x_j|)), then x <- x + w (I - J)^-1 (g(x) - x).

The start value is what the torn inputs hold (the solution at the previous point). The loop has
converged when every |g_i(x) - x_i| <= tol max(1, |x_i|); the inputs are then left at x, so every
output of the loop is the one computed from the inputs held. Not converging within `max_iter`
iterations (or a residual that is not finite, or a singular Jacobian) stops the run with a
`LoopError` naming the loop, its torn inputs, the residual and the time.
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.master.plan import Plan, Ref, Solve, Write
from twmr.scenario.system import LoopSolver as Options
from twmr.scenario.system import System

#: forward-difference step of the Newton Jacobian, relative to max(1, |x|)
DIFF_STEP = math.sqrt(sys.float_info.epsilon)


def _newton_step(columns: list[list[float]], r: list[float]) -> list[float] | None:
    """dx solving J dx = -r for the Jacobian J given by its `columns` (None: J is singular)."""
    if len(r) == 1:
        slope = columns[0][0]
        return [-r[0] / slope] if slope != 0.0 and math.isfinite(slope) else None
    try:
        return [float(v) for v in np.linalg.solve(np.array(columns).T, -np.array(r))]
    except np.linalg.LinAlgError:
        return None


class LoopError(CosimError):
    """An algebraic loop did not converge at time `time` [s]; the message says which and why."""

    def __init__(self, message: str, time: float = math.nan):
        super().__init__(message)
        self.message = message
        self.time = time

    def __reduce__(self) -> tuple:
        return (type(self), (self.message, self.time))


def body_name(loop: Solve) -> str:
    """The generated function of one pass through `loop`."""
    return f"body{loop.index}"


def call(loop: Solve) -> str:
    """The statement that solves `loop` at time t in a generated point."""
    return f"lp{loop.index}(t)"


def render(w: Any, plan: Plan, ids: dict[str, int], ref: Ref) -> None:
    """`def body<k>(t):` for each loop of `plan`: its writes and evaluations with the torn inputs
    held, then the torn inputs written from their sources (`w` a schedule `_Writer`; component i
    is `d<i>` and `ev<i>` as in the generated loop)."""
    for loop in plan.loops:
        w.add(0, f"def {body_name(loop)}(t):")
        for action in (*loop.body, *loop.tears):
            if isinstance(action, Write):
                w.add(1, plan.assignment(action, ref), (action.name, "input"))
            else:
                w.add(1, f"ev{ids[action.name]}(t)", (action.name, "evaluate"))


def bind(env: dict[str, Any], system: System, plan: Plan, timing: bool = False
         ) -> list[LoopSolver]:
    """A `LoopSolver` per loop of `plan` over the generated `body<k>` in `env`, set as `lp<k>`
    there (what `call` writes); `timing` also measures the wall time spent solving."""
    solvers = []
    for loop in plan.loops:
        solver = LoopSolver(loop, system, env[body_name(loop)], timing)
        env[f"lp{loop.index}"] = solver
        solvers.append(solver)
    return solvers


class LoopSolver:
    """Solves one loop at each call (see the module docstring) and counts what it took: the
    points solved, the iterations (total and most at one point), the passes through the loop
    (`evaluations`) and, with `timing`, the wall time [s]."""

    def __init__(self, loop: Solve, system: System, body: Callable[[float], None],
                 timing: bool = False):
        self.loop = loop
        self.options: Options = system.experiment.loop_solver
        self.body = body
        comps = system.components
        self.slots = [(comps[t.name].__dict__, t.port, comps[t.name].variables[t.port].size)
                      for t in loop.tears]
        self.labels = [f"{t.name}.{t.port}" if size is None else f"{t.name}.{t.port}[{i + 1}]"
                       for t, (_, _, size) in zip(loop.tears, self.slots, strict=True)
                       for i in range(1 if size is None else size)]
        self.points = self.iterations = self.most = self.evaluations = 0
        self.seconds = 0.0
        self.timing = timing
        self._solve = self._newton if self.options.method == "newton" else self._fixed_point

    def __call__(self, t: float) -> None:
        t0 = time.perf_counter() if self.timing else 0.0
        iterations = self._solve(t)
        self.points += 1
        self.iterations += iterations
        self.most = max(self.most, iterations)
        if self.timing:
            self.seconds += time.perf_counter() - t0

    def statistics(self) -> dict[str, Any]:
        """The counts (and time) so far, for `summary.json`."""
        out: dict[str, Any] = {"components": list(self.loop.components),
                               "tears": list(self.labels), "method": self.options.method,
                               "points": self.points, "iterations": self.iterations,
                               "max_iterations": self.most, "evaluations": self.evaluations}
        if self.timing:
            out["time_s"] = self.seconds
        return out

    # -- the torn inputs ---------------------------------------------------------------------
    def _get(self) -> list[float]:
        values: list[float] = []
        for d, port, size in self.slots:
            if size is None:
                values.append(float(d[port]))
            else:
                values.extend(float(v) for v in d[port])
        return values

    def _set(self, x: list[float]) -> None:
        k = 0
        for d, port, size in self.slots:
            if size is None:
                d[port] = x[k]
                k += 1
            else:
                d[port] = tuple(x[k:k + size])
                k += size

    def _pass(self, t: float, x: list[float]) -> list[float]:
        """g(x) - x: one pass with the torn inputs at x."""
        self._set(x)
        self.body(t)
        self.evaluations += 1
        return [g - xi for g, xi in zip(self._get(), x, strict=True)]

    def _converged(self, r: list[float], x: list[float]) -> bool:
        tol = self.options.tol
        return all(abs(ri) <= tol * max(1.0, abs(xi)) for ri, xi in zip(r, x, strict=True))

    # -- the methods -------------------------------------------------------------------------
    def _fixed_point(self, t: float) -> int:
        opts = self.options
        x = self._get()
        for k in range(opts.max_iter + 1):
            r = self._pass(t, x)
            if self._converged(r, x):
                self._set(x)
                return k
            if k == opts.max_iter or not all(map(math.isfinite, r)):
                break
            x = [xi + opts.relaxation * ri for xi, ri in zip(x, r, strict=True)]
        raise self._failure(t, r, k, "")

    def _newton(self, t: float) -> int:
        opts = self.options
        x = self._get()
        n = len(x)
        for k in range(opts.max_iter + 1):
            r = self._pass(t, x)
            if self._converged(r, x):
                self._set(x)
                return k
            if k == opts.max_iter or not all(map(math.isfinite, r)):
                break
            columns = []  # of the Jacobian of F(x) = g(x) - x
            for j in range(n):
                step = DIFF_STEP * max(1.0, abs(x[j]))
                xj = list(x)
                xj[j] += step
                columns.append([(a - b) / step for a, b in zip(self._pass(t, xj), r,
                                                               strict=True)])
            dx = _newton_step(columns, r)
            if dx is None:
                raise self._failure(t, r, k, "the finite-difference Jacobian is singular; ")
            x = [xi + opts.relaxation * float(d) for xi, d in zip(x, dx, strict=True)]
        raise self._failure(t, r, k, "")

    def _failure(self, t: float, r: list[float], k: int, why: str) -> LoopError:
        worst = max(range(len(r)), key=lambda i: abs(r[i]) if math.isfinite(r[i]) else math.inf)
        opts = self.options
        method = "Newton" if opts.method == "newton" else "fixed-point"
        fixes = "a relaxation below 1, or method: newton" if opts.method == "fixed_point" \
            else "a relaxation below 1 (damped Newton), or a start value closer to the solution"
        return LoopError(
            f"the algebraic loop {self.loop.index + 1} through "
            f"{', '.join(self.loop.components)} (torn at {', '.join(self.labels)}) did not "
            f"converge at t = {t:.9g} s: {why}after {k} {method} iteration(s) the largest "
            f"residual |g(x) - x| is {abs(r[worst]):.3g} (at {self.labels[worst]}), over the "
            f"tolerance {opts.tol:g} x max(1, |x|). Fix: under 'experiment: loop_solver:' try "
            f"{fixes}, more iterations (max_iter, now {opts.max_iter}) or a larger tol; or "
            f"break the loop with a `delay` on one of its wires.", t)
