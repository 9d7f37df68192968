"""Hostile leftovers and failures around a run's folder: a killed run's `<out>.partial-<pid>`
whose process id the next run gets (ids are reused, inside containers at once), and a run stopped
by an FMU error, whose `summary.json` must count the steps the kept rows show."""
from __future__ import annotations

import os
import textwrap
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.fmu_build import build_c_fmu
from tests.hostile.runner import GOOD_TEXT, write
from twmr.core.errors import CosimError


def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_partial_folder_named_after_this_pid_is_never_deleted(tmp_path: Path) -> None:
    scenario = write(tmp_path, "loop.yaml", GOOD_TEXT)
    killed = tmp_path / f"out.partial-{os.getpid()}"  # a killed run that had this pid
    twmr.simulate(twmr.load(scenario), killed)
    left = tree(killed)
    assert "result.arrows" in left
    result = twmr.simulate(twmr.load(scenario), tmp_path / "out")
    assert len(result) == 51
    assert tree(killed) == left, "a later run deleted or changed a killed run's rows"
    assert len(twmr.read_result(killed)) == 51
    assert not [p for p in tmp_path.glob("out.partial-*") if p != killed]  # its own stage left


@pytest.fixture(scope="module")
def faulty(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_c_fmu("faulty", tmp_path_factory.mktemp("fmus"))


@pytest.mark.parametrize("compiled, isolate, mode", [
    ("off", False, 4), ("on", False, 4), ("off", True, 4), ("off", True, 1),
], ids=["error", "error-compiled", "error-isolated", "segfault-isolated"])
def test_steps_done_after_an_fmu_failure_agree_with_the_rows_kept(
        tmp_path: Path, faulty: Path, monkeypatch: pytest.MonkeyPatch, compiled: str,
        isolate: bool, mode: int) -> None:
    """mode 4: doStep returns fmi2Error once `fail_after` steps are done; mode 1: it crashes
    (a segmentation fault, in the FMU's worker process). Output y counts completed doSteps."""
    monkeypatch.setenv("TWMR_COMPILED", compiled)
    scenario = write(tmp_path, "f.yaml", textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          dut:
            kind: fmu
            parameters: {{path: {faulty}, isolate: {str(isolate).lower()}, mode: {mode},
                          fail_after: 1500, timeout: 10}}
        connections: [src.y -> dut.u]
        experiment: {{stop: 20.0, step: 1.0e-3}}
    """))
    with pytest.raises(CosimError):
        twmr.simulate(twmr.load(scenario), tmp_path / "run")
    result = twmr.read_result(tmp_path / "run.incomplete")
    steps = result.summary["steps_done"]
    assert result.summary["status"] == "failed"
    # one row per step from t = 0, the last at the state the last completed step reached
    assert len(result) == steps + 1 == 1500, (len(result), steps)
    assert result["dut.y"][-1] == steps
    np.testing.assert_allclose(result.time[-1], steps * 1e-3)
