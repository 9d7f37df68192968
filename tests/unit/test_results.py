"""Result files: CSV and .mat carry every column and its unit and read back exactly."""
from __future__ import annotations

import numpy as np
import scipy.io

from tests.helpers import system
from twmr.analysis.plots import plot_result
from twmr.analysis.results import load_result, save_csv, save_mat
from twmr.blocks import Integrator, Sine
from twmr.master import Execution


def _run(tmp_path):
    ex = Execution(system([Sine("s"), Integrator("i")], ["s.y -> i.u"], 0.5, 0.01,
                          record=["s.y", "i.y"]), tmp_path / "result.npy")
    return ex.run(), ex.recorder.units


def test_csv_round_trip_keeps_values_and_units(tmp_path) -> None:
    data, units = _run(tmp_path)
    back, back_units = load_result(save_csv(data, units, tmp_path / "r.csv"))
    assert back.dtype.names == data.dtype.names
    for n in data.dtype.names:
        assert np.array_equal(back[n], data[n])
    assert back_units["time"] == "s"


def test_mat_file_is_readable_by_scipy_with_units(tmp_path) -> None:
    data, units = _run(tmp_path)
    save_mat(data, units, tmp_path / "r.mat")
    m = scipy.io.loadmat(tmp_path / "r.mat")
    np.testing.assert_array_equal(np.ravel(m["i_y"]), data["i.y"])
    assert [str(np.ravel(u)[0]) if np.size(u) else "" for u in np.ravel(m["units"])][0] == "s"
    back, _ = load_result(tmp_path / "r.mat")
    np.testing.assert_array_equal(back["s.y"], data["s.y"])


def test_recorder_file_is_a_plain_npy(tmp_path) -> None:
    data, _ = _run(tmp_path)
    again = np.load(tmp_path / "result.npy")
    assert len(again) == 51 and again.dtype.names == ("time", "s.y", "i.y")
    np.testing.assert_array_equal(again["i.y"], data["i.y"])


def test_plots_are_written(tmp_path) -> None:
    data, units = _run(tmp_path)
    paths = plot_result(data, units, tmp_path / "plots")
    assert {p.name for p in paths} == {"s_y.png", "i_y.png"}
    assert all(p.stat().st_size > 1000 for p in paths)
