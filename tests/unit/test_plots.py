"""Report-ready figures, checked through matplotlib's own objects: the paper scenario's XY figure
holds the path and the reference, each axis has a unit, a vector of mixed units gets an axis per
unit with element names from the port's description, a staircase is drawn as steps, lines differ
in colour or dashes, legends sit outside the data."""
from __future__ import annotations

from pathlib import Path

import numpy as np

import twmr
from twmr.plots import duration_text, is_stepwise, line_style, pyplot, result_figures

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


def _labels(ax: object) -> list[str]:
    return [ln.get_label() for ln in ax.get_lines()  # type: ignore[attr-defined]
            if not ln.get_label().startswith("_")]


def test_limits_dashed_reference_over_time_and_events_marked(tmp_path: Path) -> None:
    text = (ROOT / "scenarios" / "paper_trajectory1_asmc.yaml").read_text()
    text += ("events:\n  - {at: 1.0, set: plant.scale, value: 1.5}\n"
             "  - {when: 'plant.pose[1] < 0.0', set: ctrl.k, value: 50.0}\n")
    result = twmr.simulate(twmr.load(text, ["experiment.stop=2"]), tmp_path / "run")
    from twmr.plots import event_marks

    marks = event_marks(result.summary)
    fired, = result.summary["fired"]
    assert marks == sorted([(1.0, "plant.scale set"),
                            (fired["at"], "ctrl.k set (plant.pose[1] < 0.0)")])
    figures = result_figures(result.data, result.units, "paper", result.summary.get("ports"),
                             marks)
    torque = figures["ctrl_torque"].axes[0]
    dashed = sorted(ln.get_ydata()[0] for ln in torque.get_lines() if ln.get_linestyle() == "--")
    assert dashed == [-48.0, 48.0]  # the controller's torque_limit
    vertical = [ln.get_xdata()[0] for ln in torque.get_lines()
                if len(ln.get_xdata()) == 2 and ln.get_xdata()[0] == ln.get_xdata()[1]]
    assert sorted(vertical) == sorted([1.0, fired["at"]])  # the events
    x_axis, y_axis = figures["xy_time"].axes
    assert [lb.split(":")[0] for lb in _labels(x_axis)] == ["ref.position", "plant.pose"]
    assert x_axis.get_ylabel() == "x [m]" and y_axis.get_ylabel() == "y [m]"
    pyplot().close("all")


def test_results_overlaid_on_chosen_signals(tmp_path: Path) -> None:
    first = _paper(tmp_path)
    other = twmr.simulate(twmr.load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                                    ["experiment.stop=2", "ctrl.k=20"]), tmp_path / "k20")
    fig = first.plot("ref.position[1]+plant.pose[1],ctrl.torque", others={"k20": other},
                     label="nominal")
    panels = fig.axes
    assert len(panels) == 3  # x together, then each torque element
    assert _labels(panels[0]) == ["nominal: ref.position[1]", "nominal: plant.pose[1]",
                                  "k20: ref.position[1]", "k20: plant.pose[1]"]
    assert _labels(panels[2]) == ["nominal: ctrl.torque[2]", "k20: ctrl.torque[2]"]
    assert panels[1].get_ylabel() == "ctrl.torque[1] [N.m]"
    assert not np.array_equal(panels[1].get_lines()[0].get_ydata(),
                              panels[1].get_lines()[1].get_ydata())
    pyplot().close("all")


def test_twmr_plot_overlays_results_and_names_an_unknown_signal(tmp_path: Path, capsys
                                                                ) -> None:
    from twmr.cli import main

    _paper(tmp_path)
    run = str(tmp_path / "run")
    assert main(["plot", run, run, "--signals", "plant.pose", "--out", str(tmp_path / "p")]) == 0
    assert (tmp_path / "p" / "overlay.png").is_file()
    assert main(["plot", run, "--signals", "ctrl.torqe"]) == 1
    assert "did you mean 'ctrl.torque'" in capsys.readouterr().err


def test_values_over_decades_go_on_a_log_axis() -> None:
    from twmr.plots import spans_decades

    assert spans_decades([0.1, 0.12, 0.2, 40.0])  # one bad trial among good ones
    assert not spans_decades([0.1, 0.12, 0.2, 5.0])  # within two decades
    assert not spans_decades([-1.0, 0.1, 40.0])  # not all positive
    assert spans_decades([np.nan, 1e-3, 1.0])  # what is not finite is left out


def test_twmr_plot_of_an_empty_or_header_only_csv_says_so(tmp_path: Path, capsys) -> None:
    from twmr.cli import main

    (tmp_path / "empty.csv").write_text("")
    (tmp_path / "header.csv").write_text("time,a\n")
    (tmp_path / "gap.csv").write_text("time,a\n\n0,1\n1,3\n")
    assert main(["plot", str(tmp_path / "empty.csv")]) == 1
    assert "the file is empty (no header row" in capsys.readouterr().err
    assert main(["plot", str(tmp_path / "header.csv"), "--out", str(tmp_path / "h")]) == 0
    err = capsys.readouterr().err
    assert "holds no samples" in err and "UserWarning" not in err
    assert main(["plot", str(tmp_path / "gap.csv"), "--out", str(tmp_path / "p")]) == 0
    assert twmr.read_result(tmp_path / "gap.csv").values.tolist() == [[0.0, 1.0], [1.0, 3.0]]
