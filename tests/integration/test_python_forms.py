"""A long run on the Python schedule calls the robot's kernel functions compiled from Python (the
work of a step inside numba, the blocks' tables and state in Python), with the rows of the
compiled loop; a short one imports no numba and runs the plain functions; what numba cannot
compile stays in Python."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np

from twmr.components import _model
from twmr.components.plant import plant_step
from twmr.core.component import _CALLS
from twmr.core.kernel import AUTO_MIN_STEPS, KernelFunction, kernel_function
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"


def run(mode: str, stop: float) -> tuple[np.ndarray, dict, dict]:
    """(rows, outcome extras, {block: its bound kernel}) of the paper scenario up to `stop`."""
    system = load(PAPER, [f"experiment.stop={stop}"])
    store = ResultStore()
    outcome = Execution(system, [store], algorithm=make_algorithm("gauss_seidel", mode)).run()
    bound = {n: c.__dict__[_CALLS].bound for n, c in system.components.items()
             if _CALLS in c.__dict__}
    return store.data(), outcome.extra, bound


def test_a_long_python_schedule_run_calls_the_model_compiled_with_the_same_rows(
        monkeypatch) -> None:
    stop = AUTO_MIN_STEPS * 1e-3
    rows, extra, bound = run("off", stop)
    assert extra.get("algorithm.compiled") is not True
    step = bound["plant"].step
    assert step is not plant_step.py_func and step.__code__ is plant_step.py_func.__code__
    assert step.__globals__["rk4"] is _model.rk4.jit  # a call's floats: the dispatcher
    law = bound["ctrl"].evaluate.__globals__["limited_law"]  # takes the parameter table
    assert law.__code__ is law.__wrapped__.__code__ and law is not law.__wrapped__
    assert law.__globals__["tracking_law"] is _model.tracking_law.jit
    compiled, extra, _ = run("on", stop)
    assert extra["algorithm.compiled"] is True
    assert rows.shape == compiled.shape == (AUTO_MIN_STEPS // 10 + 1, 21)
    assert np.array_equal(rows, compiled), np.max(np.abs(rows - compiled))
    monkeypatch.setattr(KernelFunction, "python", lambda kf, long: kf.py_func)
    plain, _, bound = run("off", stop)
    assert bound["plant"].step is plant_step.py_func
    assert np.array_equal(rows, plain), np.max(np.abs(rows - plain))


def test_a_short_python_schedule_run_binds_the_plain_functions_and_imports_no_numba() -> None:
    code = (
        "import os, sys\nos.environ['TWMR_COMPILED'] = 'off'\n"
        "from twmr.components.plant import plant_step\n"
        "from twmr.core.component import _CALLS\n"
        "from twmr.master import Execution\n"
        "from twmr.master.algorithm import make_algorithm\n"
        "from twmr.scenario import load\n"
        f"system = load({str(PAPER)!r}, ['experiment.stop=0.5'])\n"
        "Execution(system, [], algorithm=make_algorithm('gauss_seidel', 'off')).run()\n"
        "step = system.components['plant'].__dict__[_CALLS].bound.step\n"
        "print(step is plant_step.py_func, 'numba' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT)
    assert out.stdout.split() == ["True", "False"], out.stdout + out.stderr


@kernel_function
def _twice(v: float) -> float:
    return 2.0 * v


@kernel_function
def _opaque(v: float) -> float:
    return v + len(object.__name__)  # numba cannot type `object`


@kernel_function
def _outer(v: float, table: tuple) -> float:
    return _twice(v) + _opaque(v) + _twice(table[0])


def test_a_long_runs_python_form_keeps_in_python_what_numba_cannot_compile() -> None:
    form = _outer.python(True)
    assert form(1.5, (0.25,)) == _outer.py_func(1.5, (0.25,)) == 3.0 + 7.5 + 0.5
    assert form.__globals__["_twice"] is _twice.jit
    assert form.__globals__["_opaque"] is _opaque.python(True) is not _opaque.py_func
    assert _outer.python(True) is form and _twice.py_func is not _twice.jit


def test_a_run_the_compiled_loop_refuses_loads_the_compiled_functions_before_its_first_step(
        monkeypatch) -> None:
    """The `random` slip profile has no kernel: mode 'auto' keeps the Python schedule, which
    binds the plant's kernel (its RK4 compiled) in `start`, before the clock runs."""
    system = load(PAPER, [f"experiment.stop={AUTO_MIN_STEPS * 1e-3}", "slip.profile=random"])
    algo = make_algorithm("gauss_seidel", "auto")
    plant = system.components["plant"]
    seen = []
    advance = algo.python.advance

    def first(n0: int, n1: int, rows: list) -> int:
        if not seen:
            bound = plant.__dict__[_CALLS].bound if _CALLS in plant.__dict__ else None
            seen.append(bound is not None and bound.step.__globals__["rk4"] is _model.rk4.jit)
        return advance(n0, n1, rows)
    monkeypatch.setattr(algo.python, "advance", first)
    outcome = Execution(system, [ResultStore()], algorithm=algo).run()
    assert outcome.status == "completed" and outcome.extra["algorithm.compiled"] is False
    assert seen == [True]
