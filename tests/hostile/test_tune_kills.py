"""`twmr tune` killed for real (SIGKILL to its process group) at moments hypothesis picks, once
or twice, then run again to the end: the folder is never refused and keeps every finished trial;
the last invocation's table holds every trial once (numbers 0..N-1), each ok. Its journal's
torn last line is cut before appending (`sweeps.folder.open_journal`; byte-level kills in
tests/unit/test_journal_kills.py)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from tests.helpers import process_group_left

ROOT = Path(__file__).resolve().parents[2]
LOOP = ROOT / "tests" / "fixtures" / "scenarios" / "loop_tune.yaml"
TRIALS = 12


def tune(folder: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "twmr.cli", "tune", str(LOOP), "--param", "ctrl.k=log:0.3:30",
         "--objective", "ms_err_y + 0.1*ms_ctrl_y", "--metrics", "signals", "--trials",
         str(TRIALS), "--batch", "1", "--out", "out", "-q"], cwd=folder,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)


def trials_so_far(folder: Path) -> int:
    journal = folder / "out" / "trials.jsonl"
    return journal.read_text(errors="replace").count("\n") if journal.exists() else 0


@pytest.mark.timeout(600)
@settings(max_examples=3, deadline=None, derandomize=True, phases=[Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=2))
def test_a_tune_killed_at_any_moment_resumes_with_every_trial(tmp_path_factory, pauses) -> None:
    folder = tmp_path_factory.mktemp("killed_tune")
    for pause in pauses:
        proc = tune(folder)
        deadline = time.monotonic() + 120
        while trials_so_far(folder) < 2 and proc.poll() is None and \
                time.monotonic() < deadline:
            time.sleep(0.02)  # trials are under way (or the tune ended)
        time.sleep(pause)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
        assert process_group_left(proc.pid) == ""
    done = tune(folder)
    _, err = done.communicate(timeout=300)
    assert done.returncode == 0, err
    table = pd.read_parquet(folder / "out" / "trials.parquet")
    assert sorted(table["trial"]) == list(range(TRIALS)), table
    assert (table["status"] == "ok").all(), table
