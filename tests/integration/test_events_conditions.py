"""Condition events (`events: - when: "comp.port > c"`): the located crossing time against the
analytic one, the action applied from the next communication point in the Python schedule and
the compiled loop alike (the same rows), hysteresis, a fault opened for a duration, and the
events that cannot be refused at check."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(300)


def _scenario(tmp_path: Path, events: str, step: float = 1e-3, stop: float = 2.5,
              sine: str = "{frequency: 1.0, amplitude: 1.0}", algorithm: str = "gauss_seidel"
              ) -> Path:
    path = tmp_path / "conditions.yaml"
    path.write_text(f"""
components:
  s: {{kind: sine, parameters: {sine}}}
  g: {{kind: gain, parameters: {{k: 1.0}}}}
connections: [s.y -> g.u]
events:
{events}
experiment: {{stop: {stop}, step: {step}, algorithm: {algorithm}}}
""", encoding="utf-8")
    return path


def _run(path: Path, compiled: str) -> twmr.Result:
    return twmr.simulate(twmr.load(path), compiled=compiled)


@pytest.mark.parametrize("step", [1e-3, 1e-4])
def test_the_located_time_is_the_analytic_crossing(tmp_path: Path, step: float) -> None:
    """sin(2 pi t) crosses 0.5 upwards at asin(0.5) / (2 pi) + k and downwards at 1/2 -
    asin(0.5) / (2 pi) + k. Linear interpolation between the communication points is off by
    about h^2 / 8 |y''| / |y'| (4.5e-7 at h = 1 ms); the action applies at the first point after
    the one where the condition is seen true."""
    path = _scenario(tmp_path, '  - {when: "s.y > 0.5", set: g.k, value: 3.0}\n'
                               '  - {when: "s.y <= 0.5", set: g.k, value: 1.0}', step=step)
    fired = _run(path, "off").summary["fired"]
    up, down = math.asin(0.5) / (2 * math.pi), 0.5 - math.asin(0.5) / (2 * math.pi)
    wanted = sorted([(up + k, "s.y > 0.5") for k in range(3)]
                    + [(down + k, "s.y <= 0.5") for k in range(3)])
    assert [f["when"] for f in fired] == [w for _, w in wanted]
    bound = step ** 2 / 8 * (2 * math.pi) ** 2 / (2 * math.pi * math.cos(math.asin(0.5)))
    for f, (t, _) in zip(fired, wanted, strict=True):
        assert abs(f["located"] - t) <= 1.01 * bound, (f, t, bound)
        seen = math.floor(t / step + 1e-9) + 1  # the first point past the crossing
        assert f["at"] == pytest.approx((seen + 1) * step, abs=1e-12)


def test_a_set_by_condition_changes_the_rows_from_its_point_alike_compiled(
        tmp_path: Path) -> None:
    path = _scenario(tmp_path, '  - {when: "s.y > 0.5", set: g.k, value: 3.0}')
    python, compiled = _run(path, "off"), _run(path, "on")
    assert compiled.summary["pacing"].get("algorithm.compiled") is True
    assert np.array_equal(python.values, compiled.values)
    t, u, y = (np.asarray(python[c]) for c in ("time", "s.y", "g.y"))
    at = python.summary["fired"][0]["at"]
    before, after = t < at - 1e-9, t >= at - 1e-9
    assert np.array_equal(y[before], u[before])
    assert np.array_equal(y[after], 3.0 * u[after])


def test_hysteresis_keeps_a_signal_that_hovers_from_firing_again(tmp_path: Path) -> None:
    """0.5 + 0.1 sin(2 pi t) crosses 0.5 upwards once a second: without hysteresis each time;
    with 0.2 it never goes back below 0.3, so it fires once."""
    hover = "{frequency: 1.0, amplitude: 0.1, offset: 0.5, phase: -0.1}"
    counts = []
    for hysteresis in (0.0, 0.2):
        path = _scenario(tmp_path, f'  - {{when: "s.y > 0.5", hysteresis: {hysteresis}, '
                                   f'set: g.k, value: 2.0}}', sine=hover, stop=3.5)
        counts.append(len(_run(path, "off").summary["fired"]))
    assert counts == [4, 1]


def test_a_fault_opened_by_a_condition_lasts_its_duration(tmp_path: Path) -> None:
    """The gain reads s.y frozen for 0.05 s from the point after s.y reached 0.9, then live
    again; s.y itself is recorded as it is, and the watch reads it unfaulted."""
    path = _scenario(tmp_path, '  - {when: "s.y >= 0.9", port: s.y, fault: freeze, '
                               'duration: 0.05}', stop=1.5)
    python, compiled = _run(path, "off"), _run(path, "on")
    assert np.array_equal(python.values, compiled.values)
    t, u, y = (np.asarray(python[c]) for c in ("time", "s.y", "g.y"))
    fired = python.summary["fired"]
    assert [f["action"] for f in fired] == ["freeze", "freeze"]
    for f in fired:
        inside = (t >= f["at"] - 1e-9) & (t < f["until"] - 1e-9)
        assert inside.sum() == 50
        first = np.flatnonzero(inside)[0]
        assert np.all(y[inside] == u[first - 1])  # the value before the fault, held
        assert y[np.flatnonzero(inside)[-1] + 1] == u[np.flatnonzero(inside)[-1] + 1]


@pytest.mark.parametrize(("event", "said"), [
    ('{when: "s.yy > 0.5", set: g.k, value: 3.0}', "'yy' is no output of 's'"),
    ('{when: "s.y >> 0.5", set: g.k, value: 3.0}', "is not a condition of the form"),
    ('{when: "g.u > 0.5", set: g.k, value: 3.0}', "'u' is an input"),
    ('{when: "s.y > 0.5", at: 1.0, set: g.k, value: 3.0}', "at with when"),
    ('{when: "s.y > 0.5", port: s.y, fault: freeze, until: 2}', "until with when"),
    ('{at: 1.0, hysteresis: 0.1, set: g.k, value: 3.0}', "hysteresis goes with when"),
    ('{when: "s.y > 0.5", set: g.kk, value: 3.0}', "'g' has no parameter 'kk'"),
    ('{when: "s.y > inf", set: g.k, value: 3.0}', "is not a finite number"),
    ('{set: g.k, value: 3.0}', "needs at (a time [s]) or when"),
])
def test_an_event_that_cannot_be_is_refused_at_check(tmp_path: Path, event: str,
                                                     said: str) -> None:
    with pytest.raises(ScenarioError) as caught:
        twmr.load(_scenario(tmp_path, f"  - {event}"))
    text = str(caught.value)
    assert said in text and "conditions.yaml:" in text and "Fix:" in text


def test_condition_events_are_refused_on_the_adaptive_master(tmp_path: Path) -> None:
    path = _scenario(tmp_path, '  - {when: "s.y > 0.5", set: g.k, value: 3.0}',
                     algorithm="adaptive")
    with pytest.raises(ScenarioError, match=r"condition events .* fixed-step masters"):
        twmr.load(path)


def test_an_events_keys_are_overrides_and_sweep_names(tmp_path: Path) -> None:
    """`events.<name or number>.<key>=value` moves an event (a fault campaign's sweep varies
    it): the rows change at the new time; a name, key or value that cannot be is refused with
    the event names and the fix, at check and by a sweep's --vary."""
    from twmr.sweeps.engine import SweepError, check_names
    from twmr.sweeps.spec import parse_vary

    path = _scenario(tmp_path, "  - {name: boost, at: 0.5, set: g.k, value: 3.0}\n"
                               '  - {when: "s.y > 0.5", set: g.k, value: 2.0}')
    moved = twmr.simulate(twmr.load(path, ["events.boost.at=0.25", "events.2.value=5.0"]))
    t, u, y = (np.asarray(moved[c]) for c in ("time", "s.y", "g.y"))
    assert np.array_equal(y[t < 0.085 - 1e-9], u[t < 0.085 - 1e-9])     # k = 1
    assert np.array_equal(y[(t > 0.085 - 1e-9) & (t < 0.25 - 1e-9)],  # the condition: k = 5
                          5.0 * u[(t > 0.085 - 1e-9) & (t < 0.25 - 1e-9)])
    moved_on = (t >= 0.25 - 1e-9) & (t < 1.085 - 1e-9)  # until the condition fires again
    assert np.array_equal(y[moved_on], 3.0 * u[moved_on])  # the event moved
    for override, said in (("events.bost.at=1", "no event 'bost' (did you mean 'boost'?) "
                                                "(its events: boost, 2)"),
                           ("events.boost.att=1", "has no 'att' to set (did you mean 'at'?)"),
                           ("events.boost.at=-5", "outside the run"),
                           ("events.2.hysteresis=-1", "less than the minimum of 0")):
        with pytest.raises(ScenarioError, match="Fix:") as caught:
            twmr.load(path, [override])
        assert said in str(caught.value), str(caught.value)
    scenario = twmr.load(path)
    check_names(scenario, [parse_vary("events.boost.at=uniform:0.2:0.8")])
    with pytest.raises(SweepError, match=r"--vary events.bost.at: .*no event 'bost'.*Fix:"):
        check_names(scenario, [parse_vary("events.bost.at=uniform:0.2:0.8")])
