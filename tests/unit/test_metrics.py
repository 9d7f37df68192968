"""Table III metrics on signals whose figures are known in closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from twmr.components.metrics import peak_error, settling_time, tracking_metrics


def test_settling_time_of_an_exponential() -> None:
    t = np.linspace(0.0, 10.0, 100001)
    e = np.exp(-t)
    # |e| <= 0.05 from t = ln 20 on
    assert settling_time(t, e, 0.05) == pytest.approx(math.log(20.0), abs=1e-4)


def test_peak_error_excludes_the_initial_approach() -> None:
    t = np.linspace(0.0, 10.0, 100001)
    e = np.exp(-0.5 * t) * np.cos(2.0 * t)
    first_in = np.argmax(np.abs(e) <= 0.15)
    assert peak_error(e, 0.15) == pytest.approx(np.max(np.abs(e[first_in:])))
    assert peak_error(e, 0.15) < 0.5  # the initial 1.0 is not counted
    assert peak_error(2.0 + np.sin(t), 0.15) == pytest.approx(3.0, abs=1e-6)  # never enters


def test_mse_and_column_lookup() -> None:
    n = 5
    data = np.zeros(n, dtype=[("time", "f8"), ("ref.position[1]", "f8"), ("ref.position[2]", "f8"),
                              ("plant.pose[1]", "f8"), ("plant.pose[2]", "f8"),
                              ("plant.pose[3]", "f8")])
    data["time"] = np.arange(n)
    data["ref.position[1]"] = 1.0
    data["plant.pose[2]"] = [0, 1, 2, 3, 4]
    m = tracking_metrics(data)
    assert m["mse_x"] == pytest.approx(1.0)
    assert m["mse_y"] == pytest.approx((0 + 1 + 4 + 9 + 16) / 5)


def test_signals_figures_of_a_sine() -> None:
    from twmr.metricset import signals
    from twmr.result import Result

    t = np.linspace(0.0, 2.0, 2001)
    y = 3.0 * np.sin(2 * np.pi * t)  # whole periods: mean square A^2 / 2
    figures = signals(Result(["time", "plant.pose[1]"], ["s", "m"], np.column_stack([t, y])))
    assert figures["ms_plant_pose_1"] == pytest.approx(4.5, rel=1e-3)
    assert figures["peak_plant_pose_1"] == pytest.approx(3.0, rel=1e-6)
    assert figures["final_plant_pose_1"] == pytest.approx(0.0, abs=1e-12)
    assert set(figures) == {"ms_plant_pose_1", "peak_plant_pose_1", "final_plant_pose_1"}
