"""`twmr tune` without --metrics takes the registered metric sets that give the figures its
objective and constraints name — the engine has no robot default: a robot-free scenario tuned on
`signals` figures needs no --metrics, and an objective no set gives is one clear error."""
from __future__ import annotations

from pathlib import Path

import pytest

import twmr
from twmr.registry import sets_giving
from twmr.tuning import TuneError

GAIN = """components:
  src: {kind: constant, parameters: {value: 1.0}}
  g: {kind: gain, parameters: {k: 1.0}}
connections: [src.y -> g.u]
experiment: {stop: 0.02, step: 0.01}
"""


def test_each_figure_is_given_by_its_set() -> None:
    assert sets_giving(["mse_x"]) == ["tracking"]
    assert sets_giving(["base_mse_y"]) == ["tracking"]
    assert sets_giving(["peak_g_y"]) == ["signals"]
    assert sets_giving(["mse_x", "final_g_y"]) == ["signals", "tracking"]
    assert sets_giving(["no_such_figure"]) == []


def test_a_robot_free_tune_needs_no_metrics(tmp_path: Path) -> None:
    path = tmp_path / "gain.yaml"
    path.write_text(GAIN)
    outcome = twmr.tune(path, ["g.k=0.5:2.0"], "(final_g_y - 1.5)**2", trials=3,
                        out=tmp_path / "tune", report=False)
    for trial in outcome.trials:  # each objective computed from the signals set's final_g_y
        assert trial["objective"] == pytest.approx((trial["g.k"] - 1.5) ** 2, rel=1e-12)


def test_an_objective_no_set_gives_is_named(tmp_path: Path) -> None:
    path = tmp_path / "gain.yaml"
    path.write_text(GAIN)
    with pytest.raises(TuneError, match="no registered metric set gives wobble"):
        twmr.tune(path, ["g.k=0.5:2.0"], "wobble", trials=1, out=tmp_path / "tune",
                  report=False)
