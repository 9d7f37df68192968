"""`twmr.testing.Harness`: time as start + n h, port checks, life-cycle order, terminate once,
feedthrough evaluation, and the same trajectory as the master running a scenario."""
from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from tests.helpers import system
from twmr.blocks import Integrator, Sine
from twmr.components.plant import TwmrPlant
from twmr.core import Component, Input, Output
from twmr.master import simulate
from twmr.testing import Harness


class Recorder(Component):
    """y = 2 u (feedthrough); every life-cycle call is appended to `calls`."""

    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def __init__(self, name: str = "", **parameters: Any):
        super().__init__(name, **parameters)
        self.calls: list[tuple[Any, ...]] = []

    def prepare(self, run: Any) -> None:
        self.calls.append(("prepare", run.step))

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self.calls.append(("setup", start, stop))

    def initialize(self) -> None:
        self.calls.append(("initialize",))

    def evaluate(self, t: float) -> None:
        self.y = 2.0 * self.u
        self.calls.append(("evaluate", t, self.u))

    def do_step(self, t: float, h: float) -> None:
        self.calls.append(("do_step", t, h, self.u))

    def terminate(self) -> None:
        self.calls.append(("terminate",))

    def count(self, call: str) -> int:
        return sum(1 for c in self.calls if c[0] == call)


# -- (a) a registered kind, stepped -----------------------------------------------------------
def test_integrator_by_kind_name_integrates_a_held_input() -> None:
    with Harness("integrator", step=0.01) as h:
        assert isinstance(h.component, Integrator)
        h.initialize()
        h.step(100, u=2.0)
        assert h["y"] == pytest.approx(2.0, abs=1e-12)
        assert h.t == pytest.approx(1.0)
        assert h.outputs == {"y": h["y"]}


def test_time_is_start_plus_n_h_not_a_running_sum() -> None:
    h = Harness("integrator", start=2.0, step=0.1).initialize()
    total = 2.0
    for n in range(1, 31):
        h.step()
        total += 0.1
        assert h.t == 2.0 + n * 0.1
    assert total != h.t  # a running sum drifts; the harness does not


# -- (b) port checks --------------------------------------------------------------------------
def test_set_of_an_unknown_input_names_the_known_ones() -> None:
    h = Harness("asmc")
    with pytest.raises(KeyError, match=r"no input 'poze'.*known: pose, wheel_speed, ref_position, "
                                       "ref_velocity, ref_acceleration"):
        h.set(poze=(0.0, 0.0, 0.0))
    with pytest.raises(KeyError) as info:
        Harness("gain").set(x=1.0)
    assert info.value.args[0].endswith("has no input 'x'; known: u")


def test_set_of_an_output_or_a_parameter_is_refused() -> None:
    h = Harness("asmc")
    with pytest.raises(KeyError, match="no input 'torque'"):
        h.set(torque=(0.0, 0.0))
    with pytest.raises(KeyError, match="no input 'eta'"):
        h.set(eta=1.0)


def test_set_of_a_wrong_size_vector_raises_value_error() -> None:
    h = Harness("asmc")
    with pytest.raises(ValueError, match="expected 3 values, got 2"):
        h.set(pose=(0.0, 0.0))
    with pytest.raises(ValueError, match="expected 3 values, got 4"):
        h.set(pose=(0.0, 0.0, 0.0, 0.0))
    assert h["pose"] == (0.0, 0.0, 0.0)  # the refused value was not written


def test_set_coerces_to_the_port_representation() -> None:
    h = Harness("asmc").set(pose=[1, 2, 3], wheel_speed=(0.5, -0.5))
    assert h["pose"] == (1.0, 2.0, 3.0) and all(type(v) is float for v in h["pose"])
    assert h["wheel_speed"] == (0.5, -0.5)


def test_parameters_and_initial_values_are_checked() -> None:
    with pytest.raises(ValueError, match="below the minimum"):
        Harness("asmc", parameters={"eta": -1.0})
    with pytest.raises(KeyError, match="no parameter 'etta'"):
        Harness("asmc", parameters={"etta": 1.0})
    with pytest.raises(KeyError, match="no input or state 'eta'"):
        Harness("asmc", initial={"eta": 1.0})  # a parameter is not a start value
    with pytest.raises(ValueError, match="expected 2 values"):
        Harness(TwmrPlant, initial={"wheel_speed": (1.0, 2.0, 3.0)})


# -- (c) life-cycle order -----------------------------------------------------------------------
def test_evaluate_or_step_before_initialize_raises() -> None:
    h = Harness(Recorder)
    with pytest.raises(RuntimeError, match="initialize"):
        h.evaluate()
    with pytest.raises(RuntimeError, match="initialize"):
        h.step()
    with pytest.raises(RuntimeError, match="initialize"):
        h.step(3, u=1.0)
    assert h.component.calls == []  # nothing reached the component
    assert h.t == 0.0


def test_initialize_twice_and_use_after_terminate_raise() -> None:
    h = Harness(Recorder).initialize()
    with pytest.raises(RuntimeError, match="already"):
        h.initialize()
    h.terminate()
    with pytest.raises(RuntimeError, match="terminated"):
        h.step()
    with pytest.raises(RuntimeError, match="terminated"):
        h.evaluate()


def test_life_cycle_calls_come_in_the_masters_order() -> None:
    with Harness(Recorder, start=1.0, stop=2.0, step=0.5) as h:
        h.set(u=3.0).initialize()
        h.step(2, u=4.0)
    assert h.component.calls == [
        ("prepare", 0.5), ("setup", 1.0, 2.0), ("initialize",),
        ("evaluate", 1.0, 4.0), ("do_step", 1.0, 0.5, 4.0),  # inputs written, then evaluate
        ("evaluate", 1.5, 4.0), ("do_step", 1.5, 0.5, 4.0),
        ("terminate",)]


def test_evaluate_is_at_the_current_time_and_does_not_step() -> None:
    h = Harness(Recorder, start=1.0, step=0.25).initialize()
    h.evaluate()
    h.step(3)
    h.set(u=5.0).evaluate()
    assert h.t == 1.75
    assert h.component.calls[-1] == ("evaluate", 1.75, 5.0)
    assert h["y"] == 10.0
    assert h.component.count("do_step") == 3


def test_step_without_feedthrough_does_not_evaluate() -> None:
    h = Harness("integrator").initialize()
    assert not h.component.has_feedthrough
    calls = []
    h.component.evaluate = lambda t: calls.append(t)  # spy on the instance
    h.step(3, u=1.0)
    assert calls == []


# -- (d) terminate exactly once -----------------------------------------------------------------
def test_terminate_runs_once_when_the_with_block_raises() -> None:
    with pytest.raises(ZeroDivisionError), Harness(Recorder) as h:
        h.initialize()
        h.step()
        raise ZeroDivisionError
    assert h.component.count("terminate") == 1
    h.terminate()  # later calls do nothing
    assert h.component.count("terminate") == 1


def test_terminate_runs_once_on_an_explicit_call_inside_with() -> None:
    with Harness(Recorder) as h:
        h.initialize()
        h.terminate()
    assert h.component.count("terminate") == 1


# -- (e) feedthrough ----------------------------------------------------------------------------
def test_feedthrough_gain_reads_k_times_u_after_evaluate() -> None:
    with Harness("gain", parameters={"k": 3.0}) as h:
        h.initialize()
        assert h["y"] == 0.0  # initialize computed y from the start value u = 0
        h.set(u=2.0)
        assert h["y"] == 0.0  # set() writes the input only
        h.evaluate()
        assert h["y"] == 6.0
        assert h["k"] == 3.0


def test_inputs_set_before_initialize_are_its_start_values() -> None:
    h = Harness("gain", parameters={"k": 3.0}).set(u=2.0).initialize()
    assert h["y"] == 6.0


# -- (f) the same trajectory as the master --------------------------------------------------------
def test_sine_alone_matches_a_one_component_scenario() -> None:
    params = {"frequency": 1.3, "amplitude": 0.7, "phase": 0.2}
    r = simulate(system([Sine("s", **params)], [], 1.0, 0.01, record=["s.y"]))
    h = Harness("sine", name="s", parameters=params, stop=1.0, step=0.01).initialize()
    times, ys = [h.t], [h["y"]]
    for _ in range(len(r) - 1):
        h.step()
        times.append(h.t)
        ys.append(h["y"])
    np.testing.assert_array_equal(times, r["time"])
    np.testing.assert_array_equal(ys, r["s.y"])


def test_integrator_matches_the_scenario_fed_with_its_recorded_input() -> None:
    r = simulate(system([Sine("s", frequency=0.5), Integrator("i", k=1.5, x0=0.25)],
                        ["s.y -> i.u"], 1.0, 0.01, record=["s.y", "i.y"]))
    h = Harness("integrator", name="i", parameters={"k": 1.5, "x0": 0.25}, stop=1.0,
                step=0.01).initialize()
    ys = [h["y"]]
    for u in r["s.y"][:-1]:  # the input the master wrote at each communication point
        h.step(u=float(u))
        ys.append(h["y"])
    np.testing.assert_array_equal(ys, r["i.y"])
    assert h.t == r["time"][-1]


def test_plant_with_initial_inputs_matches_a_one_component_scenario() -> None:
    """Start values of inputs and states through `initial=`, as a scenario's `initial:`."""
    initial = {"pose": (0.5, 0.0, -0.3), "wheel_speed": (1.0, 0.5), "torque": (2.0, -1.0),
               "slip_rate": (0.1, 0.0, 0.05)}
    plant = TwmrPlant("p")
    for k, v in initial.items():
        plant.set_parameter(k, v)
    r = simulate(system([plant], [], 0.5, 0.01, record=["p.pose", "p.wheel_speed"]))
    h = Harness(TwmrPlant, name="p", initial=initial, stop=0.5, step=0.01).initialize()
    rows = [h["pose"] + h["wheel_speed"]]
    for _ in range(len(r) - 1):
        h.step()
        rows.append(h["pose"] + h["wheel_speed"])
    columns = [f"p.pose[{i}]" for i in (1, 2, 3)] + [f"p.wheel_speed[{i}]" for i in (1, 2)]
    np.testing.assert_array_equal(np.array(rows), np.column_stack([r[c] for c in columns]))
