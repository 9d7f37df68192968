"""Master algorithms: Gauss-Seidel vs Jacobi semantics, multi-rate ZOH, determinism, failures."""
from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import system
from twmr.blocks import Constant, Delay, Gain, Integrator, Sine
from twmr.core import Component, ComponentError, Input, Output
from twmr.master import simulate
from twmr.result import read_result


def cascade(algorithm: str):
    return system([Sine("src", frequency=1.0), Gain("g1", k=2.0), Gain("g2", k=3.0)],
                  ["src.y -> g1.u", "g1.y -> g2.u"], 1.0, 0.01, algorithm,
                  record=["src.y", "g2.y"])


def test_gauss_seidel_is_exact_for_a_static_cascade() -> None:
    r = simulate(cascade("gauss_seidel"))
    np.testing.assert_allclose(r["g2.y"], 6.0 * np.sin(2 * np.pi * r["time"]), atol=1e-12)


def test_jacobi_is_one_step_late_per_feedthrough_edge() -> None:
    r = simulate(cascade("jacobi"))
    # src.y is a state output (current at t_n); g1.y is a feedthrough output, so g2 reads the
    # value g1 computed at t_{n-1}: g2.y(t_n) = 6 src(t_{n-1})
    np.testing.assert_allclose(r["g2.y"][1:], 6.0 * r["src.y"][:-1], atol=1e-12)
    assert abs(r["g2.y"][10] - 6.0 * r["src.y"][10]) > 1e-3


def test_integrator_matches_closed_form_with_zoh_input() -> None:
    # x' = u, u = sin(2 pi t) held over each step: x(t_n) = h * sum_{k<n} u(t_k)
    h = 1e-3
    r = simulate(system([Sine("s"), Integrator("i")], ["s.y -> i.u"], 1.0, h,
                        record=["s.y", "i.y"]))
    expected = np.concatenate([[0.0], np.cumsum(r["s.y"][:-1]) * h])
    np.testing.assert_allclose(r["i.y"], expected, atol=1e-12)


def test_slow_component_holds_its_input_and_output_between_its_steps() -> None:
    r = simulate(system([Sine("s", frequency=0.5), Integrator("i")], ["s.y -> i.u"], 1.0, 0.01,
                        record=["s.y", "i.y"], multiples={"i": 5}))
    y = r["i.y"]
    for n in range(0, 100, 5):
        assert np.all(y[n:n + 5] == y[n]), "output must hold between the slow steps"
    h5 = 0.05
    expected = np.cumsum(r["s.y"][0:100:5]) * h5  # inputs sampled at the slow points only
    np.testing.assert_allclose(y[5:101:5], expected, atol=1e-12)


def test_two_runs_are_bit_identical() -> None:
    a = np.array(simulate(cascade("gauss_seidel")))
    b = np.array(simulate(cascade("gauss_seidel")))
    assert a.tobytes() == b.tobytes()


def test_time_is_an_integer_step_count() -> None:
    r = simulate(system([Constant("c")], [], 1.0, 0.1, record=["c.y"]))
    assert list(r["time"]) == [0.1 * n for n in range(11)]
    assert len(r) == 11 and r["time"][-1] == 1.0


def test_decimation_keeps_every_nth_point() -> None:
    r = simulate(system([Sine("s")], [], 1.0, 0.01, record=["s.y"], decimation=10))
    np.testing.assert_allclose(r["time"], np.linspace(0, 1, 11), atol=1e-12)


def test_feedback_through_a_delay() -> None:
    # x_{n+1} = x_n + h * (-x_delayed): a loop broken by a delay block runs
    r = simulate(system([Integrator("i", x0=1.0), Gain("g", k=-1.0), Delay("d")],
                        ["i.y -> g.u", "g.y -> d.u", "d.y -> i.u"], 1.0, 0.01, record=["i.y"]))
    assert 0.3 < r["i.y"][-1] < 0.5


class Blows(Component):
    u = Input(0.0)
    y = Output(0.0)
    at = 0.5

    def do_step(self, t: float, h: float) -> None:
        if t + h > self.at:
            raise RuntimeError("boom")
        self.y = t


class MakesNan(Blows):
    def do_step(self, t: float, h: float) -> None:
        self.y = math.nan if t + h > self.at else t


def test_exception_names_instance_call_and_time_and_keeps_results(tmp_path) -> None:
    path = tmp_path / "run"
    sysm = system([Constant("c"), Blows("bad")], ["c.y -> bad.u"], 1.0, 0.1, record=["bad.y"])
    with pytest.raises(ComponentError) as err:
        simulate(sysm, path)
    text = str(err.value)
    assert "'bad'" in text and "do_step()" in text and "boom" in text and "t = 0.5" in text
    saved = read_result(path)
    assert len(saved) == 6 and saved["time"][-1] == pytest.approx(0.5)


def test_nan_output_names_instance_port_and_time(tmp_path) -> None:
    sysm = system([MakesNan("nanny")], [], 1.0, 0.1, record=["nanny.y"])
    with pytest.raises(ComponentError) as err:
        simulate(sysm, tmp_path / "run")
    text = str(err.value)
    assert "'nanny'" in text and "'y'" in text and "nan" in text and "t = 0.6" in text
    assert len(read_result(tmp_path / "run")) == 6  # points 0 .. 0.5 were finite


def test_every_component_is_terminated_after_an_error(tmp_path) -> None:
    seen = []

    class Tracks(Constant):
        def terminate(self) -> None:
            seen.append(self.name)

    sysm = system([Tracks("c"), Blows("bad")], ["c.y -> bad.u"], 1.0, 0.1)
    with pytest.raises(ComponentError):
        simulate(sysm, tmp_path / "run")
    assert seen == ["c"]


class Degrees(Component):
    angle = Output(30.0, unit="deg")


class Radians(Component):
    angle = Input(0.0, unit="rad")
    seen = Output(0.0, unit="rad", depends_on="angle")

    def evaluate(self, t: float) -> None:
        self.seen = self.angle


def test_unit_scale_is_folded_into_the_wire_and_applied() -> None:
    from twmr.core.errors import Location, Problem
    from twmr.scenario.graph import parse_end, wire

    comps = {"a": Degrees("a"), "b": Radians("b")}
    problems: list[Problem] = []
    conns = wire(comps, parse_end("a.angle"), parse_end("b.angle"), Location(), problems)
    assert not problems and conns[0].gain == pytest.approx(math.pi / 180)
    sysm = system(list(comps.values()), [], 0.1, 0.1, record=["b.seen"])
    sysm.connections = conns
    r = simulate(sysm)
    assert r["b.seen"][0] == pytest.approx(math.pi / 6)


def test_pacer_lateness_counts_from_each_steps_own_deadline() -> None:
    import time as _time

    from twmr.master.execution import Pacer

    pacer = Pacer(0.01)
    pacer.start()
    _time.sleep(0.008)  # the first step is released ~0.8 periods late
    pacer(0)
    pacer(1)
    late = pacer.lateness_us()
    assert late[0] >= 7000  # measured from t0, not from a deadline rounded to the release
