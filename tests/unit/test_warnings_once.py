"""Warnings told once: within a run each kind of warning (texts that differ only in numbers) is
shown once with a count of the rest; in a sweep each kind is told once, naming the first run,
with the number of runs that gave it, and every run's warnings are in runs.parquet."""
from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pandas as pd

import twmr
from twmr.core.warned import kind_of

BLOCK = '''
import logging

from twmr.core import Component, Input, Output


class Chatty(Component):
    """y = u; warns at every step while u > 1, and once about its name."""

    kind = "chatty"
    u = Input(0.0)
    y = Output(0.0)

    def do_step(self, t: float, h: float) -> None:
        self.y = self.u
        if self.u > 1.0:
            logging.getLogger("twmr.run").warning(
                "component '%s': u = %g at t = %g s is above 1", self.name, self.u, t)
'''

SCENARIO = """
components:
  c1: {kind: "chatty.py:Chatty"}
  c2: {kind: "chatty.py:Chatty"}
  src: {kind: constant, parameters: {value: 2.0}}
connections:
  - src.y -> c1.u
  - src.y -> c2.u
experiment: {start: 0.0, stop: 0.01, step: 0.001}
"""


def scenario(tmp_path: Path) -> Path:
    (tmp_path / "chatty.py").write_text(BLOCK)
    path = tmp_path / "chatty.yaml"
    path.write_text(SCENARIO)
    return path


def test_a_kind_is_the_text_without_its_numbers_but_names_keep_their_digits() -> None:
    assert kind_of("component 'motor2': u = -3.5e-4 at t = 0.25 s, 12 times") == \
        kind_of("component 'motor2': u = 7 at t = 1 s, 3 times")
    assert kind_of("component 'motor1': u = 7") != kind_of("component 'motor2': u = 7")


def test_in_a_run_each_kind_is_shown_once_per_component_with_the_rest_counted(
        tmp_path, caplog) -> None:
    caplog.set_level(logging.WARNING, logger="twmr")
    twmr.simulate(scenario(tmp_path))
    texts = [r.getMessage() for r in caplog.records if r.name.startswith("twmr")]
    assert [t for t in texts if "above 1" in t] == [
        "component 'c1': u = 2 at t = 0 s is above 1",
        "component 'c2': u = 2 at t = 0 s is above 1"]
    assert texts[-1] == "(18 more warning(s) like those above were not shown)"  # 2 x 10 - 2


def test_a_sweep_tells_each_kind_once_and_keeps_every_runs_warnings(tmp_path) -> None:
    out = tmp_path / "sweep"
    done = subprocess.run(
        [sys.executable, "-m", "twmr.cli", "sweep", str(scenario(tmp_path)), "-q",
         "--vary", "src.value=values:2,3,4", "--method", "grid", "--workers", "1",
         "--out", str(out)], capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    told = [line for line in lines if "above 1" in line]
    assert len(told) == 2, done.stderr  # c1 and c2, each once for the whole sweep
    assert all(line.startswith("run ") for line in told)
    assert sum("came in 3 runs in all" in line for line in lines) == 2, done.stderr
    table = pd.read_parquet(out / "runs.parquet")
    for value, warnings in zip(table["src.value"], table["warnings"], strict=True):
        assert sorted(w.split(":")[0] for w in warnings) == ["component 'c1'", "component 'c2'"]
        assert all(f"u = {value:g} at t = 0 s" in w for w in warnings)
