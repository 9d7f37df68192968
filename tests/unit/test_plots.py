"""Report-ready figures, checked through matplotlib's own objects: the paper scenario's XY figure
holds the path and the reference, each axis has a unit, a vector of mixed units gets an axis per
unit with element names from the port's description, a staircase is drawn as steps, lines differ
in colour or dashes, legends sit outside the data."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import twmr
from twmr.plots import duration_text, is_stepwise, line_style, result_figures

ROOT = Path(__file__).resolve().parents[2]


def _paper(tmp_path: Path) -> twmr.Result:
    scenario = twmr.load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                         ["experiment.stop=2"])
    return twmr.simulate(scenario, tmp_path / "run", formats=())


def test_paper_figures_have_the_reference_units_and_outside_legends(tmp_path: Path) -> None:
    result = _paper(tmp_path)
    figures = result_figures(result.data, result.units, "paper",
                             result.summary.get("ports"))
    xy = figures["xy"].axes[0]
    labels = [line.get_label() for line in xy.get_lines() if not line.get_label().startswith("_")]
    assert len(labels) == 2 and any(lb.startswith("plant.pose") for lb in labels)
    assert any(lb.startswith("ref.position") for lb in labels), labels
    assert xy.get_xlabel() == "x [m]" and xy.get_ylabel() == "y [m]"
    for name, fig in figures.items():
        for ax in fig.axes:
            assert ax.get_ylabel(), (name, "an axis without a label")
            if name != "xy" and ax.get_ylabel().endswith("]") is False:
                unit = result.units.get(ax.get_ylabel().split(" [")[0], "")
                assert unit == "", (name, ax.get_ylabel())
            legend = ax.get_legend()
            if legend is not None:
                box = legend.get_window_extent(fig.canvas.get_renderer())
                assert box.x0 >= ax.get_window_extent().x1 - 1, (name, "legend over the data")
    pose = figures["plant_pose"].axes
    assert [ax.get_ylabel() for ax in pose] == ["plant.pose [m]", "plant.pose [rad]"]
    assert [line.get_label() for line in pose[0].get_lines()] == ["x_M", "y_M"]
    assert [line.get_label() for line in pose[1].get_lines()] == ["theta"]


def test_staircases_are_steps_and_ten_lines_are_told_apart() -> None:
    t = np.linspace(0, 10, 1001)
    stair = np.floor(t / 2.0)
    assert is_stepwise(stair) and not is_stepwise(np.sin(t)) and is_stepwise(t, "Integer")
    data = np.zeros(t.size, dtype=[("time", "<f8"), ("fmu.counter", "<f8"), ("s.y", "<f8")])
    data["time"], data["fmu.counter"], data["s.y"] = t, stair, np.sin(t)
    figures = result_figures(data, {"fmu.counter": "", "s.y": "m"})
    assert figures["fmu_counter"].axes[0].get_lines()[0].get_drawstyle() == "steps-post"
    assert figures["s_y"].axes[0].get_lines()[0].get_drawstyle() == "default"
    assert figures["fmu_counter"].axes[0].get_ylabel() == "fmu.counter"  # no empty brackets
    styles = {(line_style(i)["color"], line_style(i)["linestyle"]) for i in range(10)}
    assert len(styles) == 10


def test_durations_read_in_their_unit() -> None:
    assert duration_text(187937.4) == "188 ms" and duration_text(12.34) == "12.3 us"
    assert duration_text(2.5e6) == "2.5 s"
