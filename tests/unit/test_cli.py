"""The `twmr` command: results on disk, clear errors without tracebacks, exit codes."""
from __future__ import annotations

import json
from pathlib import Path

from twmr.cli import main
from twmr.result import read_result

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"


def test_run_writes_results_summary_and_plots(tmp_path, capsys) -> None:
    assert main(["run", str(FIXTURE), "--out", str(tmp_path), "--plot", "--quiet"]) == 0
    for name in ("result.arrows", "result.csv", "result.mat", "summary.json"):
        assert (tmp_path / name).exists(), name
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["steps_done"] == 100 and "plant.y" in summary["signals"]
    assert any((tmp_path / "plots").glob("*.png"))
    assert main(["plot", str(tmp_path), "--out", str(tmp_path / "again")]) == 0


def test_bad_scenario_is_one_paragraph_without_traceback(tmp_path, capsys) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(FIXTURE.read_text().replace("kind: gain", "kind: gian"))
    assert main(["check", str(bad)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "bad.yaml:5" in err and "did you mean 'gain'" in err
    assert "Traceback" not in err


def test_failing_component_keeps_partial_results(tmp_path, capsys) -> None:
    text = FIXTURE.read_text().replace("ref: {kind: step, parameters: {height: 1.0, time: 0.1}}",
                                       "ref: {kind: step, parameters: {height: .inf, time: 0.5}}")
    scen = tmp_path / "nan.yaml"
    scen.write_text(text)
    assert main(["run", str(scen), "--out", str(tmp_path / "out"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "component 'ref'" in err and "not finite" in err and "t = 0.5 s" in err
    assert "out.incomplete" in err and not (tmp_path / "out").exists()
    saved = read_result(tmp_path / "out.incomplete")
    assert 0 < len(saved) < 51 and (tmp_path / "out.incomplete" / "result.csv").exists()


def test_set_override_and_components_listing(tmp_path, capsys) -> None:
    assert main(["check", str(FIXTURE), "--set", "ctrl.k=7"]) == 0
    assert main(["components", "twmr_plant"]) == 0
    out = capsys.readouterr().out
    assert "pose[3] [(m, m, rad)]" in out and "internal_step" in out
