"""Events under the adaptive master (`experiment.algorithm: adaptive`): a model-exchange FMU's
state event ends the communication step at the time the FMU's integrator located it (off the
grid), with a row just before and one just after it as fmpy's simulate_fmu records them; a
co-simulation FMU's bounce, seen only at step ends, brackets itself by shrinking steps; a Van der
Pol oscillator (one RK4 step per doStep) meets its tolerance against fmpy's CVODE at 1e-10. Each
against a fixed step whose accuracy is no better, step counts read from summary.json.

Ball: h(0) = 1 m, g = 9.81 m/s2, e = 0.7: first bounce at sqrt(2 h / g) = 0.4515236 s
(tests/fmus/README.md)."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import simulate_fmu

from tests.fmu_build import build_c_fmu
from tests.integration.test_fmu_events import H0, E, G, ball_height
from twmr.core.component import Component
from twmr.core.port import Output, Parameter
from twmr.master import Execution
from twmr.observers.store import FILENAME, ResultStore, read_store
from twmr.observers.summary import SignalSummary
from twmr.scenario import loads

T1 = math.sqrt(2 * H0 / G)
T2 = T1 + 2 * E * math.sqrt(2 * G * H0) / G
BALLS = ["bounce2s", "bounce3"]  # FMI 2.0 and 3.0, both with their state


@pytest.fixture(autouse=True)
def _allow_this_module(monkeypatch: pytest.MonkeyPatch) -> None:
    """The scenarios name blocks of this test module: allowed as a user allows a package."""
    monkeypatch.setenv("TWMR_ALLOW_CODE", "tests")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("event_fmus")
    return {"bounce2s": build_c_fmu("bounce2s", out), "vdp2": build_c_fmu("vdp2", out),
            "bounce3": build_c_fmu("bounce3", out, fmi3=True)}


def run(folder: Path, component: str, experiment: str, signals: str
        ) -> tuple[dict[str, np.ndarray], dict[str, Any], Any]:
    """(columns, summary.json, the algorithm) of one run written to `folder`."""
    text = f"""
components:
  {component}
experiment: {{start: 0.0, {experiment}}}
record: {{signals: [{signals}]}}
"""
    folder.mkdir(parents=True)
    summary = SignalSummary({})
    ex = Execution(loads(text, source="events.yaml"), [ResultStore(), summary], folder)
    ex.run()
    data = read_store(folder / FILENAME)[2]
    columns = ["time", *[s.strip() for s in signals.split(",")]]
    document = json.loads((folder / "summary.json").read_text())
    return ({c: data[:, i] for i, c in enumerate(columns)}, document, ex.algorithm)


def ball(path: Path, interface: str, solver: str = "") -> str:
    return f"ball: {{kind: fmu, parameters: {{path: {path}, interface: {interface}{solver}}}}}"


def first_bounce(r: dict[str, np.ndarray]) -> tuple[float, float]:
    """(time of the last row before the first bounce, time of the first row after it) [s]."""
    i = int(np.argmax(r["ball.bounces"] >= 1))
    return float(r["time"][i - 1]), float(r["time"][i])


@pytest.mark.parametrize("name", BALLS)
def test_a_state_event_ends_the_step_at_the_fmus_own_event_time(fmus, tmp_path, name) -> None:
    me = ball(fmus[name], "model_exchange", ", rtol: 1.0e-8")
    adaptive = "stop: 1.2, step: 1.0e-3, algorithm: adaptive, rtol: 1.0e-6, atol: 1.0e-8, " \
               "max_step: 0.1"
    r, summary, algorithm = run(tmp_path / "adaptive", me, adaptive,
                                "ball.h, ball.v, ball.bounces")
    before, after = first_bounce(r)
    # two rows at the event, as fmpy records one: just before it, then just after it
    assert before == after
    i = int(np.argmax(r["ball.bounces"] >= 1))
    assert r["ball.bounces"][i - 1] == 0 and r["ball.v"][i - 1] < -4.0
    assert abs(r["ball.h"][i - 1]) < 1e-9 and r["ball.v"][i] > 3.0
    assert abs(after - T1) < 1e-6
    assert abs(after / 1e-3 - round(after / 1e-3)) > 1e-3  # off the 1 ms grid
    # the FMU's own event time, as fmpy's CVODE finds it at the same tolerance
    ref = simulate_fmu(str(fmus[name]), fmi_type="ModelExchange", stop_time=0.6,
                       relative_tolerance=1e-8, output=["bounces"])
    t_fmpy = float(ref["time"][np.argmax(ref["bounces"] >= 1)])
    assert abs(after - t_fmpy) < 1e-6
    # the step to the event was a retry of a longer one that stepped over it
    over = [a for a in algorithm.history if not a.accepted and a.t < T1 < a.t + a.size]
    assert over and any(a.accepted and math.isclose(a.t + a.size, after, abs_tol=1e-15)
                        for a in algorithm.history)
    # a fixed step shows the bounce at the next grid point: 0.1 ms is not accurate enough yet
    fixed, fixed_summary, _ = run(tmp_path / "fixed", me, "stop: 1.2, step: 1.0e-4",
                                  "ball.h, ball.v, ball.bounces")
    assert first_bounce(fixed)[1] - T1 > 1e-6
    steps = summary["pacing"]["algorithm.steps_accepted"]
    assert steps < fixed_summary["steps"] / 100
    assert r["ball.bounces"][-1] == fixed["ball.bounces"][-1] == 2


@pytest.mark.parametrize("name", BALLS)
def test_later_steps_go_back_to_the_grid_after_an_off_grid_event(fmus, tmp_path, name) -> None:
    me = ball(fmus[name], "model_exchange", ", rtol: 1.0e-8")
    r, summary, _ = run(tmp_path / "run", me, "stop: 1.5, step: 1.0e-3, algorithm: adaptive, "
                        "rtol: 1.0e-6, atol: 1.0e-8, max_step: 0.1", "ball.h, ball.bounces")
    t = r["time"]
    events = t[1:][np.diff(t) == 0.0]
    assert len(events) == 2 and abs(events[0] - T1) < 1e-6 and abs(events[1] - T2) < 1e-6
    off = np.abs(t / 1e-3 - np.round(t / 1e-3)) > 1e-6
    assert set(t[off]) == set(events)  # every other row on the grid
    assert t[-1] == 1.5 and np.all(np.diff(t) >= 0.0)
    keep = np.diff(t, append=np.inf) > 0.0  # the row after each event (its last one)
    np.testing.assert_allclose(r["ball.h"][keep], ball_height(t[keep]), atol=1e-6)
    assert summary["pacing"]["algorithm.steps_accepted"] < 40


@pytest.mark.parametrize("name", BALLS)
def test_a_co_simulation_bounce_is_bracketed_by_shrinking_steps(fmus, tmp_path, name) -> None:
    """Co-simulation reports only at step ends: the bounce counter changing inside a step
    halves it until the step that holds the bounce is one base step (1 us here)."""
    cs = ball(fmus[name], "co_simulation")
    r, summary, algorithm = run(tmp_path / "adaptive", cs, "stop: 1.2, step: 1.0e-6, "
                                "algorithm: adaptive, rtol: 1.0e-6, atol: 1.0e-8, "
                                "max_step: 0.1", "ball.h, ball.bounces")
    before, after = first_bounce(r)
    assert before < T1 <= after and after - before <= 1e-6 + 1e-12
    sizes = [(a.t, a.size) for a in algorithm.history if a.accepted]
    near = [s for t, s in sizes if T1 - 0.1 < t < T1]
    assert max(near) >= 0.01 and min(near) <= 1e-6 + 1e-12  # shrinking to the bounce
    assert max(s for t, s in sizes if t > T1 + 0.2) >= 0.05  # and growing again after it
    fixed, fixed_summary, _ = run(tmp_path / "fixed", cs, "stop: 1.2, step: 1.0e-4",
                                  "ball.h, ball.bounces")
    assert np.diff(first_bounce(fixed))[0] > 1e-6  # a fixed 0.1 ms step brackets it worse
    assert summary["pacing"]["algorithm.steps_accepted"] < fixed_summary["steps"] / 50


def test_van_der_pol_meets_its_tolerance_with_fewer_steps_than_fixed(fmus, tmp_path) -> None:
    """vdp2 in co-simulation (one RK4 step per doStep) against fmpy's CVODE at rtol 1e-10
    (model exchange of the same FMU), 10 s."""
    osc = f"osc: {{kind: fmu, parameters: {{path: {fmus['vdp2']}}}}}"
    rtol = atol = 1e-6
    ref = simulate_fmu(str(fmus["vdp2"]), fmi_type="ModelExchange", stop_time=10.0,
                       relative_tolerance=1e-10, output_interval=1e-4, output=["x0", "x1"])

    def error(r: dict[str, np.ndarray]) -> float:
        return max(float(np.max(np.abs(r[f"osc.{x}"] - np.interp(r["time"], ref["time"],
                                                                  ref[x])))) for x in ("x0", "x1"))

    r, summary, _ = run(tmp_path / "adaptive", osc, "stop: 10.0, step: 1.0e-4, "
                        "algorithm: adaptive, rtol: 1.0e-6, atol: 1.0e-6", "osc.x0, osc.x1")
    err = error(r)
    scale = max(float(np.max(np.abs(ref["x0"]))), float(np.max(np.abs(ref["x1"]))))
    assert err < 5 * (rtol * scale + atol)  # a local tolerance, after 10 s of accumulation
    as_good = []
    for h in (0.01, 0.02, 0.025, 0.04, 0.05):
        fixed, fixed_summary, _ = run(tmp_path / f"fixed{h}", osc, f"stop: 10.0, step: {h}",
                                      "osc.x0, osc.x1")
        if error(fixed) <= err:
            as_good.append(fixed_summary["steps"])
    assert as_good, "no fixed step tried is as accurate"
    assert summary["pacing"]["algorithm.steps_accepted"] < min(as_good) / 2


def test_a_block_fed_by_the_fmu_shows_the_event_in_both_rows(fmus, tmp_path) -> None:
    """ball.v -> gain: the row before the event has the gain of the speed before the bounce,
    the row after it the gain of the rebound speed."""
    component = ball(fmus["bounce3"], "model_exchange", ", rtol: 1.0e-8") + \
        "\n  gain: {kind: gain, parameters: {k: 2.0}}\nconnections: [ball.v -> gain.u]"
    r, _, _ = run(tmp_path / "run", component, "stop: 0.6, step: 1.0e-3, algorithm: adaptive, "
                  "rtol: 1.0e-6, atol: 1.0e-8, max_step: 0.1", "ball.v, ball.bounces, gain.y")
    i = int(np.argmax(r["ball.bounces"] >= 1))
    v1 = math.sqrt(2 * G * H0)
    assert r["time"][i - 1] == r["time"][i]
    np.testing.assert_allclose([r["gain.y"][i - 1], r["gain.y"][i]], [-2 * v1, 2 * E * v1],
                               rtol=1e-4)  # the FMU's CVODE at rtol 1e-8


def test_a_model_exchange_fmu_alone_is_not_checked_by_step_doubling(fmus, tmp_path) -> None:
    """Its CVODE keeps its error to its own rtol: alone (recorded only), its steps go unchecked
    (one doStep each, no halves) and grow to max_step; wired to a gain, its output is coupling
    and is checked again."""
    me = ball(fmus["bounce3"], "model_exchange", ", rtol: 1.0e-8")
    experiment = "stop: 0.6, step: 1.0e-3, algorithm: adaptive, rtol: 1.0e-6, atol: 1.0e-8, " \
                 "max_step: 0.1"
    r, _, alone = run(tmp_path / "alone", me, experiment, "ball.h, ball.bounces")
    assert alone.watched == [] and all(math.isnan(a.err) for a in alone.history)
    assert max(a.size for a in alone.history if a.accepted) == pytest.approx(0.1)
    assert abs(r["time"][int(np.argmax(r["ball.bounces"] >= 1))] - T1) < 1e-6
    wired = me + "\n  gain: {kind: gain, parameters: {k: 2.0}}\nconnections: [ball.v -> gain.u]"
    _, _, coupled = run(tmp_path / "wired", wired, experiment, "ball.h, gain.y")
    assert ("ball", "v") in coupled.watched and ("ball", "h") not in coupled.watched
    assert any(not math.isnan(a.err) for a in coupled.history)


def test_the_solver_goes_on_across_saves_and_restarts_only_around_bounces(
        fmus, tmp_path, monkeypatch: pytest.MonkeyPatch) -> None:
    """CVODE keeps its history across the master's saves: on 3 s of the ball alone (eleven
    bounces) it restarts at most three times per bounce (at a restore
    before the retaken step and the step to the event, and at the event), never at a plain
    step; the first bounce is still within 2e-7 s of its analytic time, the second 1e-6 s."""
    import fmpy.sundials

    restarts = []
    reset = fmpy.sundials.CVodeSolver.reset

    def counted(self: Any, t: float) -> None:
        restarts.append(t)
        reset(self, t)

    monkeypatch.setattr(fmpy.sundials.CVodeSolver, "reset", counted)
    me = ball(fmus["bounce3"], "model_exchange", ", rtol: 1.0e-7")
    r, _, algorithm = run(tmp_path / "ball", me, "stop: 3.0, step: 1.0e-2, algorithm: adaptive",
                          "ball.h, ball.bounces")
    bounces = int(r["ball.bounces"][-1])
    assert bounces >= 8
    assert len(restarts) <= 3 * bounces
    before, after = first_bounce(r)
    assert before == after and abs(after - T1) < 2e-7
    i = int(np.argmax(r["ball.bounces"] >= 2))
    assert r["time"][i - 1] == r["time"][i] and abs(r["time"][i] - T2) < 1e-6
    assert sum(a.accepted for a in algorithm.history) < 3 * bounces + 10


class Crossing(Component):
    """x = t [s]; a state event when x reaches `at`, counted by the Integer output `n`. With
    `hold_events`, an event at the very end of a step waits for `event` (as a model-exchange
    FMU's does)."""

    kind = "crossing"
    at = Parameter(0.25, unit="s")
    x = Output(0.0, unit="s")
    n = Output(0, type="Integer")
    state_attributes = ("_held",)

    def initialize(self) -> None:
        self.x, self._held, self._met = self.start_time, False, None

    def do_step(self, t: float, h: float) -> None:
        end, self._met = t + h, None
        if t < self.at <= end:
            self._met = float(self.at)
            if self.hold_events and end == self.at:
                self._held = True
            else:
                self.n += 1
        self.x = end

    def state_event(self) -> float | None:
        return self._met

    def event(self, t: float) -> None:
        if self._held:
            self._held = False
            self.n += 1


@pytest.mark.parametrize("at", [255 / 1024, 0.3])
def test_an_event_at_a_step_end_or_inside_gives_the_two_rows(tmp_path, at) -> None:
    """Base step 1/1024 s: the steps double from one base step, so the step from 127 to 255
    base steps ends exactly at 255/1024 s (an event at its end, held); 0.3 s lies off the grid
    (the step is retried to end there)."""
    component = f"c: {{kind: 'tests.integration.test_adaptive_events:Crossing', " \
                f"parameters: {{at: {at!r}}}}}"
    r, _, algorithm = run(tmp_path / "run", component, f"stop: 0.5, step: {1 / 1024!r}, "
                          "algorithm: adaptive", "c.x, c.n")
    i = int(np.argmax(r["c.n"] >= 1))
    assert r["time"][i - 1] == r["time"][i] == at
    assert (r["c.n"][i - 1], r["c.n"][i]) == (0, 1) and r["c.n"][-1] == 1
    retried = [a for a in algorithm.history if not a.accepted]
    assert bool(retried) == (at == 0.3)


class Ticker(Crossing):
    """`n` counts a time event at `at` (announced by `next_event`), handled inside the step."""

    kind = "ticker"

    def do_step(self, t: float, h: float) -> None:
        if t < self.at <= t + h:
            self.n += 1
        self.x = t + h

    def state_event(self) -> float | None:
        return None

    def next_event(self, t: float) -> float | None:
        return float(self.at) if t < self.at else None


@pytest.mark.parametrize("at", [255 / 1024, 0.3])
def test_a_discrete_change_at_a_time_event_does_not_halve_the_step(tmp_path, at) -> None:
    """The step ends at the grid point at or after the time event, so the counter's change in
    it needs no search: no step is rejected, and the row there has the new count."""
    component = f"c: {{kind: 'tests.integration.test_adaptive_events:Ticker', " \
                f"parameters: {{at: {at!r}}}}}"
    r, summary, _ = run(tmp_path / "run", component, f"stop: 0.5, step: {1 / 1024!r}, "
                        "algorithm: adaptive, max_step: 0.0625", "c.x, c.n")
    after = float(r["time"][int(np.argmax(r["c.n"] >= 1))])
    assert r["c.n"][-1] == 1 and at <= after < at + 1 / 1024
    assert summary["pacing"]["algorithm.steps_rejected"] == 0
