"""Model-exchange FMUs with events, FMI 2.0 and 3.0, through the master: state events (bouncing
ball), time events (staircase), discrete inputs set only in event mode; checked against the
analytic answers and against fmpy's own simulate_fmu (CVode, tight tolerance)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import simulate_fmu

from tests.fmu_build import build_c_fmu
from twmr.master import simulate
from twmr.scenario import loads

G, E, H0 = 9.81, 0.7, 1.0


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, str]:
    out = tmp_path_factory.mktemp("event_fmus")
    built = {name: str(build_c_fmu(name, out)) for name in ("bounce2", "stair2", "discin2")}
    built["bounce3"] = str(build_c_fmu("bounce3", out, fmi3=True))
    return built


def ball_height(t: np.ndarray, bounces: int = 6) -> np.ndarray:
    """Analytic height [m]: free fall from H0, rebounds at e^k v1 after bounce k."""
    v1 = math.sqrt(2 * G * H0)
    times = [math.sqrt(2 * H0 / G)]
    for k in range(1, bounces):
        times.append(times[-1] + 2 * E**k * v1 / G)
    h = H0 - G / 2 * t**2
    for k, tk in enumerate(times[:-1], start=1):
        s = t - tk
        inside = (t >= tk) & (t < times[k])
        h = np.where(inside, E**k * v1 * s - G / 2 * s**2, h)
    return h


def ball(path: str, solver: str = "rtol: 1.0e-10", stop: float = 2.0) -> str:
    return f"""
components:
  ball: {{kind: fmu, parameters: {{path: {path}, interface: model_exchange, {solver}}}}}
experiment: {{start: 0.0, stop: {stop}, step: 0.01}}
"""


@pytest.mark.parametrize("name", ["bounce2", "bounce3"])
@pytest.mark.parametrize("solver, tol", [("rtol: 1.0e-10", 1e-6),
                                         ("solver: rk4, solver_step: 1.0e-3", 1e-9)])
def test_bouncing_ball_follows_the_analytic_bounces(fmus, name, solver, tol) -> None:
    r = simulate(loads(ball(fmus[name], solver), source="ball.yaml"))
    t = np.asarray(r["time"])
    keep = t < 1.9  # three bounces, before the rebounds get short
    np.testing.assert_allclose(r["ball.h"][keep], ball_height(t)[keep], atol=tol)
    assert np.min(r["ball.h"]) >= -1e-9  # never through the floor
    assert r["ball.bounces"][-1] >= 3


def test_bouncing_ball_matches_fmpy_cvode(fmus) -> None:
    r = simulate(loads(ball(fmus["bounce2"]), source="ball.yaml"))
    ref = simulate_fmu(fmus["bounce2"], fmi_type="ModelExchange", stop_time=2.0,
                       output_interval=0.01, relative_tolerance=1e-10, output=["h", "v"])
    t = np.asarray(r["time"])
    ref_h = np.interp(t, ref["time"], ref["h"])
    assert np.max(np.abs(r["ball.h"] - ref_h)) < 1e-5


def test_staircase_steps_at_its_time_events(fmus) -> None:
    text = f"""
components:
  st: {{kind: fmu, parameters: {{path: {fmus['stair2']}, interface: model_exchange}}}}
experiment: {{start: 0.0, stop: 4.5, step: 0.1}}
"""
    r = simulate(loads(text, source="stair.yaml"))
    t = np.asarray(r["time"])
    np.testing.assert_array_equal(r["st.counter"], np.floor(t + 1e-9) + 1)
    ref = simulate_fmu(fmus["stair2"], fmi_type="ModelExchange", stop_time=4.5,
                       output_interval=0.1, output=["counter"])
    after_events = np.searchsorted(ref["time"], t + 1e-9, side="right") - 1  # fmpy records both
    np.testing.assert_array_equal(r["st.counter"], ref["counter"][after_events])


def test_staircase_with_a_step_that_does_not_hit_the_events(fmus) -> None:
    """Communication points at 0.3 s: each time event is handled inside a step."""
    text = f"""
components:
  st: {{kind: fmu, parameters: {{path: {fmus['stair2']}, interface: model_exchange}}}}
experiment: {{start: 0.0, stop: 3.0, step: 0.3}}
"""
    r = simulate(loads(text, source="stair.yaml"))
    np.testing.assert_array_equal(r["st.counter"], np.floor(np.asarray(r["time"]) + 1e-9) + 1)


def test_discrete_inputs_are_set_in_event_mode_only(fmus) -> None:
    """Open discrete inputs k, on (set once, at initialization) and a wired discrete input r_d
    that jumps at 0.5 s: the FMU refuses a discrete input set in continuous-time mode, so this
    runs only if every set happens in initialization or event mode. x' = k + r_d + u."""
    text = f"""
components:
  sw: {{kind: step, parameters: {{time: 0.5, height: 3.0}}}}
  ramp: {{kind: constant, parameters: {{value: 0.5}}}}
  f:
    kind: fmu
    parameters: {{path: {fmus['discin2']}, interface: model_exchange, rtol: 1.0e-10}}
    initial: {{k: 2, 'on': true}}
connections:
  - sw.y -> f.r_d
  - ramp.y -> f.u
open: [f.k, f.on]
experiment: {{start: 0.0, stop: 1.0, step: 0.1}}
"""
    r = simulate(loads(text, source="discin.yaml"))
    t = np.asarray(r["time"])
    expected = np.where(t <= 0.5, 2.5 * t, 1.25 + 5.5 * (t - 0.5))
    np.testing.assert_allclose(r["f.x"], expected, atol=1e-8)
    assert set(r["f.y"]) == {4}
