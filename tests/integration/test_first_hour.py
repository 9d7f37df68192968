"""Frictions a new user met in the first hour, each at its cause: swapping a block for its
exported FMU with a parameter the export fixed in the code."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
TWMR = [sys.executable, "-m", "twmr.cli"]


def test_a_parameter_the_export_fixed_says_how_to_export_again(tmp_path: Path) -> None:
    fmu = tmp_path / "asmc.fmu"
    subprocess.run([*TWMR, "export", "asmc", "--fmi", "3", "--out", str(fmu), "-q"],
                   check=True, timeout=240)
    text = (ROOT / "scenarios" / "bench_odrive_trajectory1.yaml").read_text().replace(
        "kind: asmc\n    parameters: {drive: backward",
        f"kind: fmu\n    parameters: {{path: {fmu}, drive: backward")
    (tmp_path / "swap.yaml").write_text(text)
    done = subprocess.run([*TWMR, "check", str(tmp_path / "swap.yaml")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "'drive' is not a parameter of this FMU: twmr export fixed it to auto" in done.stderr
    assert f"twmr export asmc --fmi 3 --set drive=<value> --out {fmu}" in done.stderr
