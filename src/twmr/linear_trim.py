"""Trim points solved for (`twmr linearize --trim`, `twmr.linear_trim.trim`): the start values of
named states (or parameters that set them) for which the scenario's step map stands still — an
equilibrium, stable or not, with the inputs and sources as they are at the start time.

The unknowns p are the values of the named `COMP.NAME` (every element of a vector, or
`COMP.NAME[i]` alone). One step of the scenario from its start with them set gives the change of
the checked outputs, r(p) = y(start + h) - y(start) (by default every real output of the
scenario). Newton's method drives r to 0: the Jacobian by central
differences, each unknown's step 1e-6 max(1, |p_j|) (the cube root of the double precision
rounding: truncation and rounding errors balanced), the Newton step by least squares (more
outputs than unknowns; directions nothing moves are left alone), halved until |r| falls. The
point is reached when every output changes by at most `tol` (relative to max(1, |y|)) per step.
There the unknowns' one-step map is differenced too (`TrimPoint.step_matrix`: a linear model
by finite differences through the start values, beside the impulse-response one
`twmr.linearize` takes from the ports).

A simulation run finds the steady state of a stable system (`--at steady`, Simulink's
"simulation snapshot"); this finds the equilibria it cannot reach: the upright inverted pendulum,
the unstable focus of the Van der Pol oscillator (Simulink's `findop` with the states free).
"""
from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError

log = logging.getLogger(__name__)

#: largest relative change per step of every checked output at a trim point
TRIM_TOL = 1e-12
#: Newton iterations before giving up
MAX_ITER = 40
#: relative step of the central differences (about the cube root of the double's epsilon)
DIFF_STEP = 1e-6


@dataclass
class TrimPoint:
    """The values of the unknowns at the trim point, as `--set` texts that put a run there."""

    values: dict[str, float | tuple[float, ...]]
    overrides: list[str]
    outputs: list[str]
    change: float  # the largest relative change per step of an output there
    iterations: int
    runs: int  # one-step runs taken
    #: the unknowns' one-step map there (discrete A, the unknowns as the state, in their order
    #: element by element), by finite differences; None when the outputs do not show them all
    step_matrix: np.ndarray | None
    step_matrix_error: float  # its estimated relative error

    def poles(self) -> np.ndarray:
        """The discrete poles z of `step_matrix` (none without one)."""
        return np.linalg.eigvals(self.step_matrix) if self.step_matrix is not None \
            else np.zeros(0)

    def plain(self) -> dict[str, Any]:
        matrix = self.step_matrix
        return {"values": {k: list(v) if isinstance(v, tuple) else v
                           for k, v in self.values.items()},
                "set": self.overrides, "outputs": self.outputs, "change": self.change,
                "iterations": self.iterations, "runs": self.runs,
                "step_matrix": matrix.tolist() if matrix is not None else None,
                "step_matrix_error": self.step_matrix_error,
                "poles": [[float(z.real), float(z.imag)] for z in np.sort_complex(self.poles())]}


@dataclass
class _Unknown:
    name: str  # 'comp.name' or 'comp.name[i]'
    size: int  # elements it contributes (1 for an element)
    vector: bool  # a whole vector value (set as a list)


def trim(scenario: str | Path | Any, unknowns: Sequence[str], *,
         outputs: Sequence[str] = (), overrides: Sequence[str] = (), tol: float = TRIM_TOL,
         max_iter: int = MAX_ITER) -> TrimPoint:
    """The trim point of `scenario` at its start: values of the `unknowns` (`COMP.NAME`,
    parameters or start values of states, their present values the first guess) with which
    one step changes none of `outputs` (default: every real output of the scenario) by more
    than `tol` relative. CosimError when an unknown moves none of them or Newton's
    method does not get there."""
    from twmr.api import load
    from twmr.linear_analysis import outputs_run, replayable

    if not unknowns:
        raise CosimError("trim needs at least one unknown. Fix: name the start values it "
                         "solves for: --trim COMP.STATE (repeatable).")
    if not (math.isfinite(tol) and tol > 0):
        raise CosimError(f"tol {tol} is not above 0. Fix: give a small positive number.")
    base = load(scenario, list(overrides))
    system = base.system
    replayable(system, "trim")
    h, start = float(system.experiment.step), float(system.experiment.start)
    parsed = [_unknown(u, system) for u in unknowns]
    p = np.concatenate([np.atleast_1d(np.asarray(_value(u.name, system), float))
                        for u in parsed])
    checked = [_output(o, system) for o in outputs] or _outputs_of(system)
    runs = 0

    def outputs_at(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        """(the outputs at the start, after one step, their names) with the unknowns `x`;
        CosimError naming the values when that run fails."""
        nonlocal runs
        runs += 1
        try:
            y, columns = outputs_run(_with_values(base.spec, parsed, x), None, start, h,
                                     start + h, checked)
        except CosimError as err:
            values = ", ".join(_texts(_grouped(parsed, x)))
            raise CosimError(f"trim: the one-step run with {values} failed: "
                             f"{str(err).partition(' Fix: ')[0]} Fix: start where the "
                             f"scenario runs (--set the unknowns), or bound what the values "
                             f"may reach.") from None
        return y[0], y[1], columns

    def residual(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[str]]:
        y0, y1, columns = outputs_at(x)
        return y1 - y0, np.maximum(1.0, np.abs(y0)), columns

    r, scale, columns = residual(p)
    iterations = 0
    while not _settled(r, scale, tol):
        if iterations == max_iter:
            raise _not_reached(r, scale, columns, parsed, p, tol, iterations)
        iterations += 1
        jac = _jacobian(lambda x: residual(x)[0], p)
        still = [u.name for u, col in zip(_elements(parsed), jac.T, strict=True)
                 if not np.any(col)]
        if still:
            raise CosimError(f"trim: {', '.join(still)} move{'s' if len(still) == 1 else ''} "
                             f"none of the outputs checked ({', '.join(columns)}) over a step: "
                             f"nothing says where {'it' if len(still) == 1 else 'they'} should "
                             f"be. Fix: solve for the start values of states these outputs "
                             f"show, or check outputs that show them (--trim-output).")
        newton = np.linalg.lstsq(jac, -r, rcond=None)[0]
        norm, alpha = float(np.max(np.abs(r) / scale)), 1.0
        while True:
            trial = p + alpha * newton
            try:
                r_new, scale_new, _ = residual(trial)
            except CosimError:
                if alpha < 1e-6:
                    raise
                alpha /= 2  # a step the scenario cannot run at: a shorter one
                continue
            # measured in the present point's scale: a merit that moves with the point
            # can call a better point worse
            if np.max(np.abs(r_new) / scale) < norm or alpha < 1e-6:
                break
            alpha /= 2
        p, r, scale = trial, r_new, scale_new
        log.info("trim: iteration %d, largest change per step %.3g (relative), %d one-step "
                 "runs", iterations, float(np.max(np.abs(r) / scale)), runs)
    values = _grouped(parsed, p)
    matrix, error = _step_matrix(lambda x: np.concatenate(outputs_at(x)[:2]), p, len(columns))
    return TrimPoint(values, _texts(values), columns, float(np.max(np.abs(r) / scale)),
                     iterations, runs, matrix, error)


def _step_matrix(outputs: Callable[[np.ndarray], np.ndarray], p: np.ndarray, m: int
                 ) -> tuple[np.ndarray | None, float]:
    """The unknowns' one-step map's Jacobian A (x[k+1] = A x[k] near the point, the unknowns
    taken as the state) from the outputs y0 = C x at the start and y1 = C A x after a step,
    both differenced (A = C^+ dy1/dx), and its error estimate (the largest change of A between
    the difference steps d and 2d, relative to max(1, |A|)); (None, nan) when the outputs do
    not show every unknown (C loses rank)."""
    fine = _jacobian(outputs, p)
    c0 = fine[:m]
    if np.linalg.matrix_rank(c0) < len(p):
        return None, math.nan
    coarse = _jacobian(outputs, p, 2.0)
    a = np.linalg.lstsq(c0, fine[m:], rcond=None)[0]
    a2 = np.linalg.lstsq(coarse[:m], coarse[m:], rcond=None)[0]
    return a, float(np.max(np.abs(a - a2)) / max(1.0, float(np.max(np.abs(a)))))


def _unknown(name: str, system: Any) -> _Unknown:
    """`name` checked: a parameter, state or input of a component, or one element of one."""
    from twmr.registry import suggest
    from twmr.scenario.graph import element_of

    try:
        comp, var, element = element_of(name, system.components)
    except ValueError as err:
        raise CosimError(f"trim: {err}. Fix: give COMP.NAME or COMP.NAME[i].") from None
    c = system.components.get(comp)
    if c is None or var not in c.variables:
        where = list(system.components) if c is None else list(c.variables)
        raise CosimError(f"trim: '{name}' names no value of the scenario"
                         f"{suggest(comp if c is None else var, where)}. Fix: give "
                         f"COMP.NAME of a state's start value or a parameter.")
    v = c.variables[var]
    if v.kind not in ("state", "parameter", "input") or v.type != "Real":
        raise CosimError(f"trim: '{name}' is a {v.type} {v.kind}, not a real value a run "
                         f"starts from. Fix: name a real state or parameter.")
    value = c.get(var)
    width = len(value) if isinstance(value, tuple) else 1
    if element > width:
        raise CosimError(f"trim: '{name}': '{comp}.{var}' has {width} element(s). Fix: give "
                         f"an index from 1 to {width}.")
    if element or width == 1:
        return _Unknown(name, 1, False)
    return _Unknown(name, width, True)


def _value(name: str, system: Any) -> float | tuple[float, ...]:
    from twmr.scenario.graph import element_of

    comp, var, element = element_of(name, system.components)
    value = system.components[comp].get(var)
    if element:
        return float(value[element - 1])
    return tuple(map(float, value)) if isinstance(value, tuple) else float(value)


def _elements(parsed: list[_Unknown]) -> list[_Unknown]:
    """One entry per unknown element (a vector's as NAME[i])."""
    return [dataclasses.replace(u, name=f"{u.name}[{i + 1}]") if u.vector else u
            for u in parsed for i in range(u.size)]


def _grouped(parsed: list[_Unknown], p: np.ndarray) -> dict[str, float | tuple[float, ...]]:
    values: dict[str, float | tuple[float, ...]] = {}
    k = 0
    for u in parsed:
        part = p[k:k + u.size]
        values[u.name] = tuple(map(float, part)) if u.vector else float(part[0])
        k += u.size
    return values


def _texts(values: dict[str, float | tuple[float, ...]]) -> list[str]:
    """`--set` texts of the values (each double in the form that reads back to it)."""
    return [f"{name}=[{', '.join(map(repr, v))}]" if isinstance(v, tuple) else
            f"{name}={v!r}" for name, v in values.items()]


def _with_values(spec: Any, parsed: list[_Unknown], p: np.ndarray) -> Any:
    from twmr.scenario.overrides import apply_overrides

    return apply_overrides(spec, _texts(_grouped(parsed, p)))


def _output(name: str, system: Any) -> str:
    """`name` checked: a real output or state of a component (or one element of one)."""
    from twmr.registry import suggest
    from twmr.scenario.graph import element_of

    try:
        comp, port, _ = element_of(name, system.components)
    except ValueError as err:
        raise CosimError(f"trim: {err}. Fix: give COMP.PORT or COMP.PORT[i].") from None
    c = system.components.get(comp)
    v = c.variables.get(port) if c is not None else None
    if v is None or v.kind not in ("output", "state") or v.type != "Real":
        where = list(system.components) if c is None else \
            [n for n, x in c.variables.items() if x.kind in ("output", "state")]
        raise CosimError(f"trim: '{name}' names no real output of the scenario"
                         f"{suggest(comp if c is None else port, where)}. Fix: give COMP.PORT "
                         f"of an output (--trim-output).")
    return name


def _outputs_of(system: Any) -> list[str]:
    """Every real output and state of the scenario."""
    found = [f"{c}.{n}" for c, comp in system.components.items()
             for n, v in comp.variables.items() if v.kind in ("output", "state") and
             v.type == "Real"]
    if not found:
        raise CosimError("trim: the scenario has no real output to hold still. Fix: give "
                         "the outputs that show its states (--trim-output COMP.PORT).")
    return found


def _jacobian(f: Callable[[np.ndarray], np.ndarray], p: np.ndarray, factor: float = 1.0
              ) -> np.ndarray:
    """df/dp by central differences, the step of each element factor DIFF_STEP max(1,
    |p_j|)."""
    columns = []
    for j in range(len(p)):
        d = factor * DIFF_STEP * max(1.0, abs(float(p[j])))
        up, down = p.copy(), p.copy()
        up[j] += d
        down[j] -= d
        columns.append((f(up) - f(down)) / (2 * d))
    return np.column_stack(columns)


def _settled(r: np.ndarray, scale: np.ndarray, tol: float) -> bool:
    return bool(np.all(np.abs(r) <= tol * scale))


def _not_reached(r: np.ndarray, scale: np.ndarray, columns: list[str],
                 parsed: list[_Unknown], p: np.ndarray, tol: float,
                 iterations: int) -> CosimError:
    j = int(np.argmax(np.abs(r) / scale))
    last = ", ".join(f"{k}={v}" for k, v in zip([u.name for u in _elements(parsed)],
                                                 (f"{x:.6g}" for x in p), strict=True))
    return CosimError(f"trim: no steady point reached in {iterations} Newton iterations: "
                      f"{columns[j]} still changes by {abs(r[j]) / scale[j]:.3g} (relative) per "
                      f"step, above {tol:g} (last values {last}). Fix: start nearer (--set the "
                      f"unknowns), hold the inputs where a steady point exists, or solve for "
                      f"other values.")
