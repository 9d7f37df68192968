"""A bug in a user's own block (a file beside the scenario) is told as Python would tell it: the
file and line in the user's code, the line itself and Python's "did you mean", in one paragraph
of `twmr run` without a traceback."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(120)

BLOCK = '''from twmr import Component, Input, Output, Parameter


class DCMotor(Component):
    """A DC motor with a typo in its step."""

    voltage = Input(0.0, unit="V")
    speed = Output(0.0, unit="rad/s")
    gain = Parameter(2.0)

    def initialize(self) -> None:
        {init}

    def do_step(self, t: float, h: float) -> None:
        {step}
'''
SCENARIO = """components:
  m: {kind: "buggy.py:DCMotor"}
open: [m.voltage]
experiment: {stop: 1.0, step: 0.01}
"""


def run(tmp_path: Path, init: str = "pass", step: str = "pass") -> str:
    (tmp_path / "buggy.py").write_text(BLOCK.format(init=init, step=step))
    (tmp_path / "s.yaml").write_text(SCENARIO)
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(tmp_path / "s.yaml"),
                           "--out", str(tmp_path / "out"), "-q"],
                          capture_output=True, text=True, timeout=100)
    assert done.returncode == 1
    assert "Traceback" not in done.stderr + done.stdout
    return done.stderr


def test_a_misspelt_attribute_names_the_line_and_the_right_name(tmp_path: Path) -> None:
    err = run(tmp_path, step="self.speed = self.gain * self.volage")
    assert "do_step() raised AttributeError: 'DCMotor' object has no attribute 'volage'" in err
    assert "Did you mean 'voltage'?" in err
    assert f"{tmp_path / 'buggy.py'} line 15: `self.speed = self.gain * self.volage`" in err
    assert "Fix: correct the code there" in err


def test_a_misspelt_name_in_initialize(tmp_path: Path) -> None:
    err = run(tmp_path, init="self.speed = Outptu")
    assert "initialize() raised NameError: name 'Outptu' is not defined" in err
    assert "Did you mean 'Output'?" in err
    assert f"{tmp_path / 'buggy.py'} line 12: `self.speed = Outptu`" in err


def test_a_fault_in_a_library_the_block_calls_points_at_the_call_in_the_block(
        tmp_path: Path) -> None:
    err = run(tmp_path, step="import json; json.loads('{')")
    assert "do_step() raised JSONDecodeError" in err
    assert f"{tmp_path / 'buggy.py'} line 15: `import json; json.loads('{{')`" in err
