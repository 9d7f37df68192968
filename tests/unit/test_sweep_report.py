"""The sweep report: summary.md states the spread of every metric over the ok runs (checked against
numpy) and every failed run; the plots are real PNGs; all-failed tables, text parameters, empty
metrics and a folder with no sweep are handled."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from twmr.sweeps.report import sweep_report
from twmr.sweeps.spec import SweepError

METRICS = ("mse_x", "settling_time_x", "peak_error_x")
FAILED = {3: "SolverError: the step size fell below 1e-12 at t = 0.41 s\ntraceback ...",
          17: "the worker running it failed: KilledWorker('run-x')"}


def _runs(n: int = 30, failed: dict[int, str] = FAILED) -> pd.DataFrame:
    rng = np.random.default_rng(1)
    scale = rng.uniform(0.9, 1.1, n)
    gain = rng.uniform(0.0, 2.0, n)
    rows = []
    for i in range(n):
        bad = i in failed
        rows.append({"run_id": f"{i:012x}", "sample": i, "plant.scale": scale[i],
                     "slip.slip_gain": gain[i], "status": "failed" if bad else "ok",
                     "error": failed.get(i, ""), "wall_time_s": math.nan if bad else 0.5 + i,
                     "step_time_s": 0.4, "worker": "host:1",
                     "mse_x": math.nan if bad else 1e-4 * scale[i] * (1 + gain[i]),
                     "settling_time_x": math.nan if bad else 2.0 + gain[i],
                     "peak_error_x": math.nan if bad else 0.01 * i})
    return pd.DataFrame(rows)


def _folder(tmp_path: Path, frame: pd.DataFrame, spec: dict | None = None) -> Path:
    folder = tmp_path / "sweep"
    folder.mkdir()
    frame.to_parquet(folder / "runs.parquet", index=False)
    if spec is not None:
        (folder / "sweep.json").write_text(json.dumps(spec))
    return folder


SPEC = {"scenario": "scenarios/paper_asmc.yaml", "method": "lhs", "samples": 30, "seed": 7,
        "vary": {"plant.scale": "uniform:0.9:1.1", "slip.slip_gain": "uniform:0:2"},
        "metrics": ["tracking"]}


def _is_png(path: Path) -> bool:
    data = path.read_bytes()
    return data.startswith(b"\x89PNG\r\n\x1a\n") and len(data) > 5000


def test_summary_states_the_spread_of_every_metric_and_every_failure(tmp_path) -> None:
    frame = _runs()
    folder = _folder(tmp_path, frame, SPEC)
    written = sweep_report(folder)
    report = folder / "report"
    assert written[0] == report / "summary.md"
    text = written[0].read_text(encoding="utf-8")
    assert "scenarios/paper_asmc.yaml" in text and "lhs" in text and "`7`" in text
    assert "uniform:0.9:1.1" in text and "uniform:0:2" in text
    assert "30 runs: 28 ok, 2 failed." in text
    ok = frame[frame["status"] == "ok"]
    for m in METRICS:
        q = ok[m].quantile([0.5, 0.05, 0.95])
        expected = [q[0.5], q[0.05], q[0.95], ok[m].min(), ok[m].max()]
        row = next(line for line in text.splitlines() if line.startswith(f"| `{m}` |"))
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert [float(c) for c in cells[1:6]] == pytest.approx(expected, rel=1e-5)
        assert cells[6] == "28"
    failures = text.split("## Failures", 1)[1]
    for i, error in FAILED.items():
        assert f"`{i:012x}`" in failures
        assert error.splitlines()[0] in failures
    assert "traceback" not in failures  # only the first line of an error
    assert f"plant.scale={frame['plant.scale'][3]:.6g}" in failures

    names = {p.name for p in written[1:]}
    assert names == {"metrics_boxplot.png", *(f"hist_{m}.png" for m in METRICS),
                     *(f"scatter_{m}.png" for m in METRICS)}
    assert all(p.parent == report and _is_png(p) for p in written[1:])


def test_all_failed_gives_the_failures_and_no_plot(tmp_path) -> None:
    errors = {i: f"ScenarioError: run {i} broke" for i in range(4)}
    folder = _folder(tmp_path, _runs(4, errors), SPEC)
    written = sweep_report(folder, tmp_path / "out")
    assert written == [tmp_path / "out" / "summary.md"]
    text = written[0].read_text(encoding="utf-8")
    assert "4 runs: 0 ok, 4 failed." in text
    assert all(f"`{i:012x}`" in text and f"run {i} broke" in text for i in errors)
    assert text.count("no finite value") == len(METRICS)


def test_text_parameters_without_sweep_json_and_an_empty_metric(tmp_path) -> None:
    frame = _runs(12, {5: "x" * 500})
    frame["ctrl.mode"] = ["fast", "slow", "safe"] * 4
    frame["energy"] = math.nan
    folder = _folder(tmp_path, frame)
    written = sweep_report(folder)
    text = written[0].read_text(encoding="utf-8")
    assert "no sweep.json" in text
    assert "| `ctrl.mode` | ? | fast, safe, slow |" in text
    assert "| `energy` | no finite value |" in text
    assert "x" * 199 + "…" in text and "x" * 200 not in text  # the error is cut
    assert "ctrl.mode=safe" in text  # run 5 failed
    assert not any("energy" in p.name for p in written)
    scatter = folder / "report" / "scatter_mse_x.png"
    assert scatter in written and _is_png(scatter)


def test_file_names_are_sanitised(tmp_path) -> None:
    frame = _runs(6, {})
    frame = frame.rename(columns={"peak_error_x": "peak error [m]/x"})
    written = sweep_report(_folder(tmp_path, frame, SPEC))
    assert tmp_path / "sweep" / "report" / "hist_peak_error__m__x.png" in written


def test_a_folder_without_a_sweep_is_refused(tmp_path) -> None:
    with pytest.raises(SweepError, match="twmr sweep") as info:
        sweep_report(tmp_path / "nowhere")
    assert "nowhere" in str(info.value)
