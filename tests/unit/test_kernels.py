"""A block's kernel is its definition: the Python methods run it (`Component.kernel_evaluate`,
`kernel_do_step`), the compiled loop calls it, so a block that offers a kernel writes nothing else
and both loops give identical rows; its private state is held by the component and handed over
when `auto` switches to the compiled loop; the engine's blocks run without numba in Python."""
from __future__ import annotations

import copy
import math
import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from tests.helpers import system
from twmr.blocks import Sine
from twmr.core import Component, Input, Output, Parameter
from twmr.core.component import runs_kernel
from twmr.core.kernel import Kernel, kernel_function
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.master.compiled import CompiledStep
from twmr.observers.store import ResultStore
from twmr.scenario import load
from twmr.testing import Harness

ROOT = Path(__file__).resolve().parents[2]


class ClipParams(NamedTuple):
    low: float
    high: float


class MeanParams(NamedTuple):
    start: float  #: [s]


class MeanState(NamedTuple):
    total: float  #: integral of u since `start`
    count: float  #: steps taken


@kernel_function
def clip_evaluate(t: float, x: tuple, y: tuple, u: tuple, p: ClipParams) -> tuple[tuple, tuple]:
    return x, (min(p.high, max(p.low, u[0])),)


@kernel_function
def mean_step(t: float, h: float, x: MeanState, y: tuple, u: tuple, p: MeanParams
              ) -> tuple[MeanState, tuple]:
    total = x.total + u[0] * h
    return MeanState(total, x.count + 1.0), (total / (t + h - p.start), x.count + 1.0)


class Clip(Component):
    """y = u limited to [low, high]: a kernel and nothing else."""

    low = Parameter(-0.5)
    high = Parameter(0.5)
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def initialize(self) -> None:
        self.evaluate(self.start_time)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=ClipParams(float(self.low), float(self.high)),
                      evaluate=clip_evaluate)


class RunningMean(Component):
    """The mean of u since the start (private state: the integral), and the number of steps."""

    u = Input(0.0)
    mean = Output(0.0)
    steps = Output(0.0)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=MeanParams(float(self.start_time)), state=MeanState(0.0, 0.0),
                      step=mean_step)


class LowPassParams(NamedTuple):
    a: float  #: exp(-h / tau) for the step h


@kernel_function
def lowpass_step(t, h, x, y, u, p):
    """y(t + h) = a y + (1 - a) u."""
    return x, (p.a * y[0] + (1.0 - p.a) * u[0],)


class LowPass(Component):
    """docs/components.md's example, as printed there."""

    kind = "lowpass"
    tau = Parameter(0.1, unit="s", min=1e-9, description="time constant")
    u = Input(0.0)
    y = Output(0.0)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=LowPassParams(math.exp(-h / self.tau)), step=lowpass_step)


def test_the_documented_example_is_exact_for_a_held_input_and_compiles_bit_identical() -> None:
    from twmr.blocks import Constant

    def lowpass() -> object:
        return system([Constant("one", value=1.0), LowPass("f", tau=0.05)], ["one.y -> f.u"],
                      0.5, 1e-3, record=["f.y"], multiples={"f": 2})

    python, _ = run(lowpass(), "off")
    compiled, was = run(lowpass(), "on")
    assert was and np.array_equal(python, compiled)
    t, y = compiled[:, 0], compiled[:, 1]
    done = np.floor(t / 2e-3 + 1e-9) * 2e-3  # the filter's outputs change every 2 ms
    np.testing.assert_allclose(y, 1.0 - np.exp(-done / 0.05), rtol=1e-12, atol=1e-15)


def build(stop: float):
    return system([Sine("s", frequency=1.3, offset=0.2), Clip("c", low=-0.3, high=0.6),
                   RunningMean("m")], ["s.y -> c.u", "c.y -> m.u"], stop, 1e-3,
                  record=["c.y", "m.mean", "m.steps"])


def run(sysm, mode: str) -> tuple[np.ndarray, bool]:
    """The rows of a run, and whether it ran compiled ('off': the Python schedule)."""
    store = ResultStore()
    algo = make_algorithm("gauss_seidel", mode)
    Execution(sysm, [store], algorithm=algo).run()
    return store.data(), isinstance(algo, CompiledStep) and algo.compiled


def test_a_block_that_offers_a_kernel_needs_no_python_methods() -> None:
    with Harness(RunningMean, step=0.5) as m:
        m.initialize()
        for u in (1.0, 3.0, 2.0):
            m.step(u=u)
        assert m["mean"] == pytest.approx((1.0 + 3.0 + 2.0) * 0.5 / 1.5)
        assert m["steps"] == 3.0
    with Harness(Clip) as c:
        c.initialize()
        assert c.set(u=0.9).evaluate()["y"] == 0.5 and c.set(u=-2.0).evaluate()["y"] == -0.5


def test_python_and_compiled_rows_of_a_user_block_are_identical() -> None:
    python, _ = run(build(2.0), "off")
    compiled, was = run(build(2.0), "on")
    assert was
    assert np.array_equal(python, compiled)
    assert compiled[-1, 3] == 2000.0 and 0.1 < compiled[-1, 2] < 0.4


def test_auto_hands_the_private_state_over_to_the_compiled_loop() -> None:
    """12 s: the first chunk runs in Python, the rest compiled; the running mean over the whole
    run (held in the kernel's private state) equals the Python run's to the bit."""
    python, _ = run(build(12.0), "off")
    auto, was = run(build(12.0), "auto")
    assert was
    assert np.array_equal(python, auto)
    assert auto[-1, 3] == 12000.0


def test_a_kernel_that_covers_no_parameters_and_no_python_method_is_named() -> None:
    class Nothing(RunningMean):
        def kernel(self, h: float) -> Kernel | None:
            return None

    with Harness(Nothing, name="odd") as c, pytest.raises(TypeError, match=r"'odd'.*Fix:"):
        c.initialize().step()


def test_a_saved_state_holds_the_kernel_state() -> None:
    """get_state after 50 steps, 50 more, set_state, the same 50 again: the same outputs."""
    with Harness("motor_driver", parameters={"mode": "dc"}) as m:
        m.initialize()
        m.step(50, torque_command=(5.0, -2.0))
        saved = m.component.get_state()
        m.step(50, torque_command=(9.0, 1.0))
        after = m["torque"]
        m.component.set_state(saved)
        m.step(50, torque_command=(9.0, 1.0))
        assert m["torque"] == after and after != (0.0, 0.0)


def test_the_engines_blocks_run_in_python_without_numba(tmp_path: Path) -> None:
    scenario = tmp_path / "tiny.yaml"
    scenario.write_text("""
components:
  src: {kind: sine, parameters: {frequency: 1.0}}
  step: {kind: step, parameters: {time: 0.05}}
  add: {kind: sum}
  g: {kind: gain, parameters: {k: 2.0}}
  i: {kind: integrator}
  d: {kind: delay}
  ss: {kind: state_space, parameters: {A: [-1.0], B: [1.0], C: [1.0]}}
connections:
  - src.y -> add.u1
  - step.y -> add.u2
  - add.y -> g.u
  - g.y -> i.u
  - i.y -> d.u
  - d.y -> ss.u
experiment: {start: 0.0, stop: 0.1, step: 0.001}
record: {signals: [ss.y]}
""")
    code = ("import sys; from twmr.master import simulate; from twmr.scenario import load; "
            f"r = simulate(load({str(scenario)!r})); "
            "print('numba' in sys.modules, r['ss.y'][-1])")
    # an empty cache folder: with a compiled driver of these kinds cached, `auto` would run it
    env = {**os.environ, "TWMR_CACHE_DIR": str(tmp_path / "cache")}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=tmp_path, env=env).stdout.split()
    assert out[0] == "False" and math.isfinite(float(out[1])) and float(out[1]) > 0.0


class RootParams(NamedTuple):
    scale: float


@kernel_function
def root_step(t: float, h: float, x: tuple, y: tuple, u: tuple, p: RootParams
              ) -> tuple[tuple, tuple]:
    return (x[0] + 1.0,), (p.scale * math.sqrt(u[0]),)  # ValueError below 0 (in Python)


class Root(Component):
    """y(t + h) = scale sqrt(u); its private state counts the steps."""

    scale = Parameter(2.0)
    u = Input(0.0)
    y = Output(0.0)

    def kernel(self, h: float) -> Kernel:
        return Kernel(params=RootParams(float(self.scale)), state=(0.0,), step=root_step)


def test_the_python_loop_hands_ports_and_state_back_and_names_a_failing_kernel() -> None:
    from twmr.core.errors import ComponentError

    sysm = system([Sine("s", frequency=0.5, offset=0.5), Root("r")], ["s.y -> r.u"], 2.0, 0.01,
                  record=["r.y"])
    store = ResultStore()
    with pytest.raises(ComponentError) as err:
        Execution(sysm, [store], algorithm=make_algorithm("gauss_seidel", "off")).run()
    text = str(err.value)
    assert "'r'" in text and "do_step()" in text and "math domain error" in text, text
    rows = store.data()
    t_bad = 1.0 / 0.5 * (7 / 12)  # 0.5 + sin(2 pi 0.5 t) < 0 from t = 7/6 s
    assert rows[-1, 0] == pytest.approx(t_bad, abs=0.011) and f"t = {rows[-1, 0]:g}" in text
    root = sysm.components["r"]
    # what the loop held when the kernel failed is back in the component
    assert root.y == rows[-1, 1] and root.u < 0.0
    assert root.__dict__["_kernel_x"] == (float(len(rows) - 1),)


@kernel_function
def indexes(t: float, x: tuple, y: tuple, u: tuple, p: ClipParams) -> tuple[tuple, tuple]:
    return x, (min(p[1], max(p.low, u[0])),)


def plain_helper(p: ClipParams) -> float:
    return p.high


@kernel_function
def hands_on(t: float, x: tuple, y: tuple, u: tuple, p: ClipParams) -> tuple[tuple, tuple]:
    return x, (min(plain_helper(p), max(p.low, u[0])),)


def test_a_parameter_table_is_read_through_slots_only_where_the_source_shows_field_reads(
        ) -> None:
    from twmr.components.asmc import AsmcParams, asmc_evaluate, asmc_step
    from twmr.components.motor import motor_evaluate, motor_step
    from twmr.core.kernel import python_params

    table = ClipParams(-0.5, 0.5)
    view = python_params(table, (clip_evaluate.py_func, None))
    assert not isinstance(view, tuple) and (view.low, view.high) == table
    assert clip_evaluate.py_func(0.0, (), (0.0,), (0.9,), view) == ((), (0.5,))
    for fn in (indexes, hands_on):  # p[1]; p given to a function that is no kernel_function
        assert python_params(table, (clip_evaluate.py_func, fn.py_func)) is table
    ctrl = load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml").components["ctrl"]
    ctrl.setup(0.0, 1.0)
    ctrl.initialize()
    params = ctrl.kernel(1e-3).params
    assert isinstance(params, AsmcParams)
    view = python_params(params, (asmc_evaluate.py_func, asmc_step.py_func))
    # the nested table too: handed to `limited_law`, which reads its fields
    assert not isinstance(view.law, tuple) and view.law.lam == params.law.lam
    # functions that read fields this table does not have get it as it is (the same error)
    assert python_params(params, (motor_evaluate.py_func, motor_step.py_func)) is params
    # a long run's calls (numba loaded, kernel functions in their `python(True)` forms) too
    import numba  # noqa: F401 - what a run that loaded it leaves

    ctrl.setup(0.0, 30.0)
    ctrl.initialize()
    ctrl.do_step(0.0, 1e-3)
    env = ctrl.__dict__["_kernel_calls"].env
    assert env["st"] is not asmc_step.py_func and not isinstance(env["p"], tuple)


def test_a_copy_and_a_pickle_of_a_block_run_their_own_calls_and_a_replacement_is_seen() -> None:
    """The kernel's calls are bound on the instance at first use: a deep copy and a pickle of a
    block that has run step their own values, and an `evaluate` a user sets on the instance
    after that is theirs (the kernel is then not called in its place)."""
    original = RunningMean("m")
    original.setup(0.0, 1.0)
    original.do_step(0.0, 0.5)
    original.u = 4.0
    for twin in (copy.deepcopy(original), pickle.loads(pickle.dumps(original))):
        twin.u = 2.0
        twin.do_step(0.5, 0.5)
        assert (twin.mean, twin.steps) == (1.0, 2.0)
        assert (original.mean, original.steps) == (0.0, 1.0)
        assert runs_kernel(twin)
        twin.do_step = original.do_step  # type: ignore[method-assign]
        assert not runs_kernel(twin)
    assert runs_kernel(original)
    original.evaluate = lambda t: None  # type: ignore[method-assign]
    assert not runs_kernel(original)
