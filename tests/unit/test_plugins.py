"""Plug-in seams: a third party's result format and master algorithm, installed as a real
distribution (a module and its `*.dist-info` with `entry_points.txt`, found through PYTHONPATH,
nothing installed into the environment), used by `twmr run` / `twmr check` in a subprocess; and
the capability checks: an algorithm that needs state rollback, and one whose step falls short."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from twmr import api as twmr_api
from twmr.core.errors import CosimError
from twmr.master import Execution
from twmr.master.schedule import FixedStep
from twmr.observers.store import ResultStore
from twmr.result import read_result
from twmr.scenario import load

ROOT = Path(__file__).resolve().parents[2]
LOOP = ROOT / "tests" / "fixtures" / "scenarios" / "loop.yaml"
BENCH = ROOT / "scenarios" / "bench_odrive_trajectory1.yaml"
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
TWMR = Path(sys.executable).parent / "twmr"

MODULE = '''
"""A tab-separated result format and a master algorithm that would roll states back."""
from pathlib import Path

import numpy as np

from twmr.master.schedule import FixedStep
from twmr.observers.writers import ResultFormat


class Tsv(ResultFormat):
    suffix = ".tsv"

    def write(self, path, columns, units, values):
        with open(path, "w") as f:
            f.write("\\t".join(columns) + "\\n" + "\\t".join(units) + "\\n")
            np.savetxt(f, values, delimiter="\\t", fmt="%.17g")
        return []

    def read(self, path):
        lines = Path(path).read_text().splitlines()
        values = np.loadtxt(lines[2:], delimiter="\\t", ndmin=2)
        return lines[0].split("\\t"), lines[1].split("\\t"), values


class Rollback(FixedStep):
    needs_state_rollback = True

    def __init__(self, compiled="auto"):
        super().__init__("gauss_seidel")
'''


@pytest.fixture(scope="module")
def third_party(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    """The environment of a process that sees the distribution `thirdparty` 0.1."""
    site = tmp_path_factory.mktemp("site")
    (site / "thirdparty_plugins.py").write_text(MODULE)
    info = site / "thirdparty-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: thirdparty\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[twmr.formats]\ntsv = thirdparty_plugins:Tsv\n\n"
        "[twmr.algorithms]\nrollback_test = thirdparty_plugins:Rollback\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    env["TWMR_COMPILED"] = "off"
    return env


def twmr(env: dict[str, str], *args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([str(TWMR), *map(str, args)], env=env, capture_output=True,
                          text=True, timeout=120)


def test_third_party_format_is_written_by_twmr_run(third_party, tmp_path) -> None:
    out = tmp_path / "run"
    done = twmr(third_party, "run", LOOP, "--out", out, "--format", "tsv,csv", "--quiet")
    assert done.returncode == 0, done.stderr
    lines = (out / "result.tsv").read_text().splitlines()
    stored = read_result(out)  # the crash-consistent store the export is made from
    assert lines[0].split("\t") == stored.columns
    assert lines[1].split("\t") == [stored.units[c] for c in stored.columns]
    tsv = np.loadtxt(lines[2:], delimiter="\t", ndmin=2)
    assert tsv.shape == stored.values.shape == (51, len(stored.columns))
    assert np.array_equal(tsv, stored.values)
    assert (out / "result.csv").is_file() and not list(out.glob(".partial-*"))
    # and read back through the format's own `read`, in a process that sees it
    back = subprocess.run([sys.executable, "-c", "import json, sys, twmr; r = twmr.read_result("
                           "sys.argv[1]); print(json.dumps([r.columns, r.units, "
                           "r.values.tolist()]))", str(out / "result.tsv")],
                          env=third_party, capture_output=True, text=True, timeout=60)
    assert back.returncode == 0, back.stderr
    assert json.loads(back.stdout) == [stored.columns, stored.units, stored.values.tolist()]


def test_unknown_format_is_one_paragraph_with_a_suggestion(third_party, tmp_path) -> None:
    done = twmr(third_party, "run", LOOP, "--out", tmp_path / "x", "--format", "csv,tvs")
    assert done.returncode == 1
    err = done.stderr.strip()
    assert err.startswith("error: --format csv,tvs: unknown result format 'tvs'"), err
    assert "did you mean 'tsv'?" in err and "csv, mat, mcap, parquet, rosbag, tsv" in err
    assert "\n" not in err and "Traceback" not in err
    assert not (tmp_path / "x").exists()  # refused before running


def test_rollback_algorithm_refuses_a_can_drive_at_check(third_party) -> None:
    done = twmr(third_party, "check", BENCH, "--set", "experiment.algorithm=rollback_test")
    assert done.returncode == 1
    err = done.stderr.strip()
    assert "'rollback_test'" in err and "'motor' (CanMotorDrive)" in err, err
    assert "cannot save and restore its state" in err and "Fix:" in err
    assert str(BENCH) in err and "\n" not in err and "Traceback" not in err
    # the same scenario with a fixed-step algorithm, and the algorithm with simulated blocks only
    assert twmr(third_party, "check", BENCH).returncode == 0
    ok = twmr(third_party, "check", PAPER, "--set", "experiment.algorithm=rollback_test")
    assert ok.returncode == 0, ok.stderr


def test_rollback_algorithm_refuses_a_can_drive_at_run(third_party, tmp_path) -> None:
    done = twmr(third_party, "run", BENCH, "--set", "experiment.algorithm=rollback_test",
                "--out", tmp_path / "bench")
    assert done.returncode == 1
    assert "'motor' (CanMotorDrive)" in done.stderr and "'rollback_test'" in done.stderr
    assert not (tmp_path / "bench").exists()


def test_a_registered_algorithm_runs(third_party, tmp_path) -> None:
    """The third party's algorithm (the Python Gauss-Seidel schedule under another name) runs
    from the scenario's `algorithm:` and gives the built-in's rows."""
    rows = {}
    for name in ("rollback_test", "gauss_seidel"):
        done = twmr(third_party, "run", LOOP, "--set", f"experiment.algorithm={name}",
                    "--out", tmp_path / name, "--format", "none", "--quiet")
        assert done.returncode == 0, done.stderr
        rows[name] = read_result(tmp_path / name)
        assert rows[name].summary["algorithm"] == name
    assert np.array_equal(rows["rollback_test"].values, rows["gauss_seidel"].values)


def test_unknown_algorithm_is_one_paragraph_with_a_suggestion(third_party) -> None:
    done = twmr(third_party, "check", LOOP, "--set", "experiment.algorithm=jacobbi")
    assert done.returncode == 1
    err = done.stderr.strip()
    assert "--set (experiment.algorithm=jacobbi): unknown master algorithm 'jacobbi' (did you " \
           "mean 'jacobi'?). Fix: use one of: adaptive, gauss_seidel, jacobi, " \
           "rollback_test" in err, err
    assert "\n" not in err


class HalfStep(FixedStep):
    """The Python Gauss-Seidel loop, advancing only half of what it is asked each time."""

    def advance(self, n0: int, n1: int, rows: list) -> int:
        n = n0 + max(1, (n1 - n0) // 2)
        super().advance(n0, n, rows)
        return n


class VariableHalfStep(HalfStep):
    variable_step = True


def test_a_short_step_needs_the_variable_step_capability() -> None:
    with pytest.raises(CosimError, match=r"HalfStep was asked to advance from base step 0 to 64 "
                                         r"and reached step 32\. Fix: .*variable_step = True"):
        Execution(load(LOOP), [ResultStore()], algorithm=HalfStep()).run()
    rows = {}
    for algo in (VariableHalfStep(), FixedStep()):
        store = ResultStore()
        Execution(load(LOOP), [store], algorithm=algo).run()
        rows[type(algo).__name__] = store.data()
    assert rows["FixedStep"].shape == (51, 4)
    assert np.array_equal(rows["VariableHalfStep"], rows["FixedStep"])


def test_a_block_needs_one_import_from_twmr() -> None:
    """What a block of one's own uses comes from `twmr` itself, the same objects as inside."""
    import twmr
    from twmr import Component, CosimError, Input, Kernel, Output, Parameter, State
    from twmr.core import component, errors, kernel, port

    assert (Component, Input, Output, Parameter, State) == (
        component.Component, port.Input, port.Output, port.Parameter, port.State)
    assert Kernel is kernel.Kernel and CosimError is errors.CosimError
    assert {"Component", "Kernel", "simulate", "load"} <= set(dir(twmr))
    with pytest.raises(AttributeError):
        twmr.Nothing  # noqa: B018


def test_simulate_takes_the_compiled_loop_as_an_argument(monkeypatch) -> None:
    """`twmr.simulate(..., compiled=)` chooses the loop without an environment variable (which
    stays the default when the argument is left out); the rows are the same either way."""
    monkeypatch.setenv("TWMR_COMPILED", "off")
    text = ("components:\n  c: {kind: constant}\n  i: {kind: integrator}\n"
            "connections: [c.y -> i.u]\nexperiment: {stop: 1.0, step: 0.001}\n")
    on = twmr_api.simulate(twmr_api.load(text), compiled="on")
    off = twmr_api.simulate(twmr_api.load(text))
    assert on.summary["pacing"]["algorithm.compiled"] is True
    assert off.summary["pacing"].get("algorithm.compiled") is not True
    np.testing.assert_array_equal(on.values, off.values)
    with pytest.raises(CosimError, match="not a mode"):
        twmr_api.simulate(twmr_api.load(text), compiled="fast")
