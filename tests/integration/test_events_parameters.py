"""`events:` that set a parameter during a run: the rows change exactly from the event's time,
bit for bit alike in the Python schedule and the compiled loop (its kernels re-read), for a
block without state (a gain), one with state (a first-order lag's time constant) and the
paper's plant (its scale, a payload); changes that cannot be made mid-run are refused at their
line."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(300)

BASE = """components:
  src: {kind: constant, parameters: {value: 1.0}}
  g: {kind: gain, parameters: {k: 2.0}}
  lag: {kind: first_order, parameters: {K: 1.0, T: 0.1}}
  i: {kind: integrator}
connections: [src.y -> g.u, g.y -> i.u, g.y -> lag.u]
experiment: {stop: 0.2, step: 0.01%s}
events:
%s
"""
SETS = """  - {at: 0.05, set: g.k, value: 5.0}
  - {at: 0.1, set: lag.T, value: 0.02}"""


def test_a_set_changes_the_rows_from_its_time_in_every_loop(tmp_path: Path) -> None:
    scenario = twmr.load(BASE % ("", SETS))
    python = twmr.simulate(scenario, tmp_path / "py", compiled="off")
    compiled = twmr.simulate(scenario, tmp_path / "c", compiled="on")
    assert np.array_equal(python.values, compiled.values)
    t, g = python["time"], python["g.y"]
    after = t >= 0.05 - 1e-12
    np.testing.assert_array_equal(g[~after], 2.0)
    np.testing.assert_array_equal(g[after], 5.0)
    # the integrator's Euler sum of g, the new gain from the step that starts at 0.05
    np.testing.assert_allclose(python["i.y"][1:], np.cumsum(g[:-1]) * 0.01, atol=1e-12)
    # the lag, by hand: y+ = a y + K (1 - a) u, a = exp(-h / T), T from 0.1 s to 0.02 s at 0.1
    y, expected = 0.0, [0.0]
    for k in range(20):
        a = np.exp(-0.01 / (0.1 if k < 10 else 0.02))
        y = a * y + (1 - a) * g[k]
        expected.append(y)
    np.testing.assert_allclose(python["lag.y"], expected, rtol=1e-14, atol=0)
    summary = json.loads((tmp_path / "py" / "summary.json").read_text())
    assert [(e["at"], e["port"], e["fault"], e["value"]) for e in summary["events"]] == \
        [(0.05, "g.k", "set", 5.0), (0.1, "lag.T", "set", 0.02)]


def test_a_payload_on_the_paper_plant_changes_its_path_from_then_on(tmp_path: Path) -> None:
    paper = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
    text = paper.read_text().replace("stop: 30.0", "stop: 2.0")
    (tmp_path / "plain.yaml").write_text(text)
    (tmp_path / "payload.yaml").write_text(
        text + "events:\n  - {at: 1.0, set: plant.scale, value: 1.6}\n")
    plain = twmr.simulate(tmp_path / "plain.yaml", tmp_path / "a", compiled="off")
    python = twmr.simulate(tmp_path / "payload.yaml", tmp_path / "b", compiled="off")
    compiled = twmr.simulate(tmp_path / "payload.yaml", tmp_path / "c", compiled="on")
    assert np.array_equal(python.values, compiled.values)
    t = python["time"]
    before = t <= 1.0 + 1e-12
    x, x0 = python["plant.pose[1]"], plain["plant.pose[1]"]
    np.testing.assert_array_equal(x[before], x0[before])
    assert np.abs(x[~before] - x0[~before]).max() > 1e-6


@pytest.mark.parametrize("event, said", [
    ("{at: 0.05, set: g.kk, value: 1.0}", "has no parameter 'kk'"),
    ("{at: 0.05, set: g.n_in, value: 2}", "changes the block's ports"),
    ("{at: 0.05, set: g.k, value: banana}", "cannot take"),
    ("{at: 0.05, set: g.k}", "needs a value"),
    ("{at: 0.5, set: g.k, value: 1.0}", "outside the run"),
    ("{at: 0.05, set: g.k, value: 1.0, fault: bias}", "either"),
    ("{at: 0.05, set: i.u, value: 1.0}", "not a parameter"),
])
def test_bad_sets_are_refused_at_their_line(tmp_path: Path, event: str, said: str) -> None:
    path = tmp_path / "sets.yaml"
    path.write_text(BASE % ("", f"  - {event}"))
    with pytest.raises(CosimError, match=said) as err:
        twmr.load(path)
    assert "sets.yaml:9" in str(err.value)


def test_the_adaptive_master_refuses_a_set(tmp_path: Path) -> None:
    path = tmp_path / "sets.yaml"
    path.write_text(BASE % (", algorithm: adaptive", "  - {at: 0.05, set: g.k, value: 1.0}"))
    with pytest.raises(CosimError, match="adaptive"):
        twmr.load(path)


def test_a_set_with_until_ramps_the_parameter_step_by_step(tmp_path: Path) -> None:
    """g.k from 2 to 7 between 0.1 and 0.15 s: 2 + 5 (t - 0.1) / 0.05 at each point, 7 after."""
    scenario = twmr.load(BASE % ("", "  - {at: 0.1, until: 0.15, set: g.k, value: 7.0}"))
    python = twmr.simulate(scenario, tmp_path / "py", compiled="off")
    compiled = twmr.simulate(scenario, tmp_path / "c", compiled="on")
    assert np.array_equal(python.values, compiled.values)
    t, g = python["time"], python["g.y"]
    expected = np.clip(2.0 + 5.0 * (t - 0.1) / 0.05, 2.0, 7.0)
    np.testing.assert_allclose(g, expected, rtol=0, atol=1e-12)
    assert g[-1] == 7.0
