"""`twmr fit` / `twmr.fit`: estimates known parameters back from data made apart — a first-order
lag's gain and time constant from its step response computed by numpy with seeded noise
(inside the 95 % intervals), the paper plant's scale from a run recorded with another scale —
resumes from its journal, and refuses what cannot be fitted."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import curve_fit

import twmr
from twmr.core.errors import CosimError
from twmr.fitting import Estimate, Experiment, fit

pytestmark = pytest.mark.timeout(300)

K, T, H = 2.0, 0.3, 0.01
LAG = f"""components:
  u: {{kind: constant, parameters: {{value: 1.0}}}}
  lag: {{kind: first_order, parameters: {{K: 1.0, T: 1.0}}}}
connections: [u.y -> lag.u]
experiment: {{stop: 2.0, step: {H}}}
record: {{signals: [lag.y]}}
"""


def lag_data(tmp_path: Path, noise: float, seed: int = 7) -> Path:
    """The step response K (1 - exp(-t / T)) (the block's update is exact for a held input),
    every 20 ms, with seeded Gaussian noise, as CSV."""
    t = np.arange(101) * 0.02
    y = K * (1 - np.exp(-t / T)) + np.random.default_rng(seed).normal(0.0, noise, t.size)
    path = tmp_path / "lag.csv"
    np.savetxt(path, np.column_stack([t, y]), delimiter=",", header="time,lag.y", comments="")
    return path


def test_a_lags_gain_and_time_constant_come_back_within_their_intervals(tmp_path: Path
                                                                        ) -> None:
    (tmp_path / "lag.yaml").write_text(LAG)
    result = fit(tmp_path / "lag.yaml", lag_data(tmp_path, noise=0.02),
                 ["lag.K=0.1:10", "lag.T=0.05:5"], ["lag.y"], out=tmp_path / "fit")
    # scipy's curve_fit on the closed-form response: the same estimates and standard errors
    t = np.arange(101) * 0.02
    y = np.loadtxt(tmp_path / "lag.csv", delimiter=",", skiprows=1)[:, 1]
    ref, cov = curve_fit(lambda t, k, tau: k * (1 - np.exp(-t / tau)), t, y, p0=[1.0, 1.0])
    for i, (name, truth) in enumerate((("lag.K", K), ("lag.T", T))):
        assert result.estimates[name] == pytest.approx(ref[i], rel=1e-5)
        assert result.stderr[name] == pytest.approx(np.sqrt(cov[i, i]), rel=1e-3)
        assert abs(result.estimates[name] - truth) < 3 * result.stderr[name], result.text()
        lo, hi = result.interval[name]
        assert lo < result.estimates[name] < hi
    corr = cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1])
    assert result.correlation[0, 1] == pytest.approx(corr, abs=1e-3)
    report = json.loads((tmp_path / "fit" / "fit.json").read_text())
    assert report["estimates"] == result.estimates
    fitted = twmr.load(tmp_path / "fit" / "fitted.yaml")
    assert fitted.system.components["lag"].get("K") == pytest.approx(result.estimates["lag.K"])
    assert (tmp_path / "fit" / "residuals.png").stat().st_size > 1000

    again = fit(tmp_path / "lag.yaml", lag_data(tmp_path, noise=0.02),
                ["lag.K=0.1:10", "lag.T=0.05:5"], ["lag.y"], out=tmp_path / "fit")
    assert again.runs == 0 and again.resumed >= result.runs
    assert again.estimates == result.estimates


def test_a_fit_killed_midway_resumes_and_other_settings_are_refused(tmp_path: Path) -> None:
    (tmp_path / "lag.yaml").write_text(LAG)
    data = lag_data(tmp_path, noise=0.0)
    args = (tmp_path / "lag.yaml", data, ["lag.K=0.1:10", "lag.T=0.05:5"], ["lag.y"])
    whole = fit(*args, out=tmp_path / "fit")
    journal = tmp_path / "fit" / "runs.jsonl"
    lines = journal.read_text().splitlines()
    kept = len(lines) // 2
    journal.write_text("\n".join(lines[:kept]) + "\n" + lines[kept][:20])  # cut mid-line
    first = json.loads(lines[1])["file"]
    (tmp_path / "fit" / "runs" / first).write_bytes(b"\0" * 16)  # a file that lies
    resumed = fit(*args, out=tmp_path / "fit")
    assert resumed.estimates == whole.estimates
    assert resumed.resumed == kept - 2  # the head line and the corrupted run are not reused
    assert resumed.runs == whole.runs - resumed.resumed
    with pytest.raises(CosimError, match="holds a fit of other settings"):
        fit(tmp_path / "lag.yaml", data, ["lag.K=0.1:10"], ["lag.y"], out=tmp_path / "fit")


def test_the_paper_plants_scale_comes_back_from_a_recorded_run(tmp_path: Path) -> None:
    """The recorded torques of a closed-loop run drive the plant open loop (`data` block); a run
    with scale 1.4 is the measurement; the fit starts from the scenario's 1.25."""
    from tests.integration.test_data_block import open_loop, recorded

    folder, _ = recorded(tmp_path, 1)
    scenario = open_loop(tmp_path, f"file: {folder.name}, columns: ['ctrl.torque[1]', "
                                   f"'ctrl.torque[2]']")
    measured = tmp_path / "bench"
    twmr.simulate(twmr.load(scenario, ["plant.scale=1.4"]), measured)
    result = fit(scenario, [Experiment(measured)], [Estimate("plant.scale", 0.5, 2.0)],
                 ["plant.pose[1]", "plant.pose[2]", "plant.wheel_speed[1]"])
    assert result.estimates["plant.scale"] == pytest.approx(1.4, abs=1e-6)


def test_the_command_fits_and_bad_input_is_refused(tmp_path: Path) -> None:
    (tmp_path / "lag.yaml").write_text(LAG)
    data = lag_data(tmp_path, noise=0.0)
    done = subprocess.run([str(Path(sys.executable).parent / "twmr"), "fit",
                           str(tmp_path / "lag.yaml"), "--data", str(data), "--estimate",
                           "lag.K=0.1:10", "--estimate", "lag.T=0.05:5@0.5", "--match", "lag.y",
                           "--out", str(tmp_path / "cli")],
                          capture_output=True, text=True, timeout=200)
    assert done.returncode == 0, done.stderr
    assert "lag.K" in done.stdout and "95 % interval" in done.stdout
    with pytest.raises(CosimError, match=r"lag\.csv: no column 'lag\.x'"):
        fit(tmp_path / "lag.yaml", data, ["lag.K=0.1:10"], {"lag.y": "lag.x"})
    with pytest.raises(CosimError, match=r"outside 0\.1 \.\. 0\.5"):
        fit(tmp_path / "lag.yaml", data, ["lag.K=0.1:0.5"], ["lag.y"])
    with pytest.raises(CosimError, match="no finite range"):
        Estimate.parse("lag.K=3:1")


def test_until_fits_a_stretch_of_the_data_and_stops_the_runs_there(tmp_path: Path) -> None:
    (tmp_path / "lag.yaml").write_text(LAG)
    data = lag_data(tmp_path, noise=0.0)
    result = fit(tmp_path / "lag.yaml", [Experiment(data, until=0.5)],
                 ["lag.K=0.1:10", "lag.T=0.05:5"], ["lag.y"], out=tmp_path / "part")
    assert result.estimates["lag.K"] == pytest.approx(K, rel=1e-6)
    assert result.estimates["lag.T"] == pytest.approx(T, rel=1e-6)
    runs = sorted((tmp_path / "part" / "runs").iterdir())
    assert np.frombuffer(runs[0].read_bytes(), dtype="<f8").size == 26  # rows 0 .. 0.5 s


SINE = """components:
  s: {kind: sine, parameters: {frequency: 1.0, amplitude: 1.0}}
experiment: {stop: 2.0, step: 0.01}
record: {signals: [s.y]}
"""


@pytest.mark.parametrize("where", ["here", "dask"])
def test_a_global_start_finds_what_one_local_fit_misses(tmp_path: Path, where: str) -> None:
    """A sine's frequency from 2 s of sin(2 pi 3.3 t) (numpy): from 1 Hz the cost has minima
    at every few tenths of a hertz, and one local fit stops in another; eight starts over
    0.5 .. 5 Hz (a Latin hypercube) find 3.3 Hz. On a real Dask cluster of two workers too,
    each local fit journalled in its own file."""
    (tmp_path / "sine.yaml").write_text(SINE)
    t = np.arange(201) * 0.01
    path = tmp_path / "sine.csv"
    np.savetxt(path, np.column_stack([t, np.sin(2 * np.pi * 3.3 * t)]), delimiter=",",
               header="time,s.y", comments="")
    one = fit(tmp_path / "sine.yaml", path, ["s.frequency=0.5:5@1.0"], ["s.y"], sigma={"s.y": 1})
    assert abs(one.estimates["s.frequency"] - 3.3) > 0.1  # another minimum
    many = fit(tmp_path / "sine.yaml", path, ["s.frequency=0.5:5@1.0"], ["s.y"],
               sigma={"s.y": 1}, starts=8, seed=1, out=tmp_path / "fit",
               workers=2 if where == "dask" else None)
    assert many.estimates["s.frequency"] == pytest.approx(3.3, abs=1e-6)
    assert len(many.starts) == 8 and many.starts[0]["start"] == [1.0]
    assert min(s["cost"] for s in many.starts) == many.cost < one.cost
    report = json.loads((tmp_path / "fit" / "fit.json").read_text())
    assert len(report["starts"]) == 8
    assert all((tmp_path / "fit" / name).exists() for name in ("runs.jsonl", "runs.7.jsonl"))
    again = fit(tmp_path / "sine.yaml", path, ["s.frequency=0.5:5@1.0"], ["s.y"],
                sigma={"s.y": 1}, starts=8, seed=1, out=tmp_path / "fit")
    assert again.runs == 0 and again.estimates == many.estimates  # every run from the journals
