"""The `twmr` command: results on disk, clear errors without tracebacks, exit codes."""
from __future__ import annotations

import json
from pathlib import Path

from twmr.cli import main
from twmr.result import read_result

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"


def test_run_writes_results_summary_and_plots(tmp_path, capsys) -> None:
    assert main(["run", str(FIXTURE), "--out", str(tmp_path), "--plot", "--quiet",
                 "--format", "csv,mat"]) == 0
    for name in ("result.arrows", "result.csv", "result.mat", "summary.json"):
        assert (tmp_path / name).exists(), name
    assert main(["run", str(FIXTURE), "--out", str(tmp_path / "plain"), "--quiet"]) == 0
    assert sorted(p.name for p in (tmp_path / "plain").iterdir()) == ["result.arrows",
                                                                       "summary.json"]
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
    assert main(["run", str(scen), "--out", str(tmp_path / "out"), "--quiet",
                 "--format", "csv"]) == 1
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


def test_version_and_common_options_after_the_subcommand(capsys) -> None:
    import pytest

    import twmr

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and twmr.__version__ in capsys.readouterr().out
    assert main(["check", str(FIXTURE), "-q"]) == 0
    assert main(["check", str(FIXTURE), "-v", "--debug"]) == 0
    assert main(["-q", "components", "gain"]) == 0


def test_check_schedule_prints_the_generated_loop(capsys) -> None:
    assert main(["check", str(FIXTURE), "--schedule"]) == 0
    out = capsys.readouterr().out
    assert "def run(n0, n1, rows):" in out and "for n in range(n0, n1):" in out
    assert "# 2: err (Sum): kernel" in out
    assert out.index("ev2(t,") < out.index("ev3(t,") < out.index("rows.append(")


def test_metrics_only_when_asked_and_registered_subcommands_listed(tmp_path, capsys) -> None:
    paper = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
    args = ["run", str(paper), "--quiet", "--format", "none", "--set", "experiment.stop=1.0"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 0
    assert "metrics" not in json.loads((tmp_path / "a" / "summary.json").read_text())
    capsys.readouterr()
    assert main([*args, "--out", str(tmp_path / "b"), "--metrics", "tracking"]) == 0
    printed = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    saved = json.loads((tmp_path / "b" / "summary.json").read_text())["metrics"]
    assert printed == saved and set(saved) >= {"mse_x", "settling_time_y"}
    assert main(["run", str(paper), "--metrics", "trakcing"]) == 1
    assert "did you mean 'tracking'" in capsys.readouterr().err


def test_generated_loop_shows_in_tracebacks(tmp_path) -> None:
    import traceback

    import pytest

    from tests.helpers import system
    from twmr.blocks import Constant
    from twmr.core import Component, ComponentError, Input, Output
    from twmr.master import simulate

    class Fails(Component):
        u = Input(0.0)
        y = Output(0.0)

        def do_step(self, t: float, h: float) -> None:
            raise RuntimeError("boom")

    with pytest.raises(ComponentError) as err:
        simulate(system([Constant("c"), Fails("f")], ["c.y -> f.u"], 0.1, 0.01))
    text = "".join(traceback.format_exception(err.value.__cause__))
    assert "st1(t, h1)" in text  # the generated line, shown from linecache


def test_compare_is_registered_by_the_robot_package(tmp_path, capsys) -> None:
    scen = Path(__file__).resolve().parents[2] / "scenarios"
    assert main(["compare", str(scen / "paper_trajectory1_asmc.yaml"),
                 str(scen / "paper_trajectory1_smc.yaml"), "--json", "--out", str(tmp_path),
                 "--set", "experiment.stop=2.0", "-q"]) == 0
    table = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert set(table) == {"paper_trajectory1_asmc", "paper_trajectory1_smc"}
    assert (tmp_path / "xy.png").is_file()


def test_ctrl_c_inside_generated_code_still_exits_with_status_130(tmp_path) -> None:
    """A Ctrl-C that lands while a dataclass or namedtuple is being made (code run by `exec` of
    a text, as during imports) ends `python -m ...` with status 130, not killed by SIGINT."""
    import subprocess
    import sys

    (tmp_path / "interrupted_cli.py").write_text(
        "import sys\n"
        "from twmr import cli\n"
        "def interrupted(args):\n"
        "    exec('raise KeyboardInterrupt')\n"
        "cli.cmd_components = interrupted\n"
        "sys.exit(cli.main(['components']))\n")
    done = subprocess.run([sys.executable, "-m", "interrupted_cli"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 130, done
    assert done.stderr.startswith("interrupted (Ctrl-C) after "), done.stderr


def test_the_done_line_says_how_long_the_compile_before_the_steps_took(tmp_path, capsys
                                                                       ) -> None:
    assert main(["run", str(FIXTURE), "--out", str(tmp_path), "--compiled", "on"]) == 0
    err = capsys.readouterr().err
    done = [line for line in err.splitlines() if line.startswith("done: ")]
    compile_s = json.loads((tmp_path / "summary.json").read_text())["pacing"][
        "algorithm.compile_s"]
    assert len(done) == 1 and f"after {compile_s:.2f} s to compile the step loop" in done[0]


def test_a_compile_during_the_run_is_said_to_be_part_of_its_wall_time(tmp_path) -> None:
    """With nothing cached, mode 'auto' runs a first chunk in Python and compiles meanwhile: the
    done line says the compile is part of the stepping time it prints (not 'after' it)."""
    import os
    import subprocess
    import sys

    out = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "twmr.cli", "run", str(FIXTURE), "--set", "experiment.stop=300",
         "--format", "none", "--out", str(out)], capture_output=True, text=True, timeout=280,
        env={**os.environ, "TWMR_CACHE_DIR": str(tmp_path / "cache")})
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    pacing = summary["pacing"]
    line = next(ln for ln in done.stderr.splitlines() if ln.startswith("done: "))
    assert pacing["algorithm.compiled_at_step"] > 0, pacing
    assert pacing["algorithm.compile_s"] <= summary["wall_time_s"]
    assert (f"{pacing['algorithm.compile_s']:.2f} s of it compiling the step loop (numba) after "
            f"{pacing['algorithm.compiled_at_step']} steps in Python") in line, line


def test_run_v_says_which_step_loop_ran_and_why(tmp_path, capsys) -> None:
    assert main(["run", str(FIXTURE), "--out", str(tmp_path / "on"), "-v",
                 "--compiled", "on"]) == 0
    err = capsys.readouterr().err
    assert "compiled step loop: the driver (each kind of block compiled once); compiled " \
           "because --compiled on" in err
    assert main(["run", str(FIXTURE), "--out", str(tmp_path / "auto"), "-v"]) == 0
    err = capsys.readouterr().err
    assert "Python step loop: a short run (100 < 10000 steps)" in err or (
        "compiled step loop" in err and "compiled because every kind compiled already" in err)
    summary = json.loads((tmp_path / "on" / "summary.json").read_text())
    assert summary["pacing"]["algorithm.why"] == "--compiled on"
