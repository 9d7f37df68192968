"""A part of the install left out (an extra not installed) is named with the extra that brings it:
`twmr run --plot` without matplotlib, `twmr sweep` without Dask, `twmr tune` without Optuna and a
`can_drive` block without python-can each end with one paragraph naming `twmr-cosim[EXTRA]`, no
traceback (the module is hidden from a fresh interpreter, as if it were not installed)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAPER = str(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml")
BENCH = str(ROOT / "scenarios" / "bench_odrive_trajectory1.yaml")


def run_without(module: str, args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    code = (f"import sys\nsys.modules[{module!r}] = None\nfrom twmr.cli import main\n"
            f"sys.exit(main({args!r}))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


@pytest.mark.parametrize(("module", "args", "extra"), [
    ("matplotlib", ["run", PAPER, "--set", "experiment.stop=0.01", "--plot", "--out", "r"],
     "plot"),
    ("dask", ["sweep", PAPER, "--vary", "plant.scale=uniform:1:1.1", "--samples", "2",
              "--set", "experiment.stop=0.01", "--out", "s"], "cluster"),
    ("optuna", ["tune", PAPER, "--param", "ctrl.eta=0.1:1", "--objective", "mse_x",
                "--trials", "1", "--set", "experiment.stop=0.01", "--out", "t"], "tune"),
    ("can", ["check", BENCH], "hw"),
], ids=["plot", "sweep", "tune", "can_drive"])
def test_a_missing_extra_is_named(module: str, args: list[str], extra: str,
                                  tmp_path: Path) -> None:
    done = run_without(module, args, tmp_path)
    assert done.returncode == 1, done.stderr
    assert f"twmr-cosim[{extra}]" in done.stderr, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
