"""`twmr sweep` killed for real (SIGKILL to its whole process group, Dask workers included) at
moments hypothesis picks, once or twice, then run again to the end: the folder is never refused
and keeps every finished row; the last invocation's table holds every run once, each ok. The
journal's torn last line (a kill in the middle of a write) is cut before appending
(`sweeps.folder.open_journal`; byte-level kills in tests/unit/test_journal_kills.py)."""
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

RUNS = 24
SCENARIO = ("components:\n  c: {kind: constant}\n  g: {kind: gain}\nconnections: [c.y -> g.u]\n"
            "experiment: {start: 0.0, stop: 0.2, step: 0.001}\n")


def sweep(folder: Path) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "twmr.cli", "sweep", "s.yaml", "--vary",
         f"g.k=values:{','.join(str(k) for k in range(1, RUNS + 1))}", "--method", "grid",
         "--workers", "1",
         "--out", "out", "-q"], cwd=folder, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
        text=True, start_new_session=True)


def rows_so_far(folder: Path) -> int:
    journal = folder / "out" / "runs.jsonl"
    return journal.read_text(errors="replace").count("\n") if journal.exists() else 0


@pytest.mark.timeout(600)
@settings(max_examples=3, deadline=None, derandomize=True, phases=[Phase.generate],
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(st.floats(0.0, 1.5), min_size=1, max_size=2))
def test_a_sweep_killed_at_any_moment_resumes_with_every_row(tmp_path_factory, pauses) -> None:
    folder = tmp_path_factory.mktemp("killed")
    (folder / "s.yaml").write_text(SCENARIO)
    for pause in pauses:
        proc = sweep(folder)
        deadline = time.monotonic() + 120
        while rows_so_far(folder) == 0 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)  # the runs are under way (or the sweep ended)
        time.sleep(pause)
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
        assert process_group_left(proc.pid) == ""
    done = sweep(folder)
    _, err = done.communicate(timeout=300)
    assert done.returncode == 0, err
    table = pd.read_parquet(folder / "out" / "runs.parquet")
    assert len(table) == RUNS and table["run_id"].is_unique, table
    assert (table["status"] == "ok").all(), table[["status", "error"]]
    assert sorted(table["g.k"]) == list(range(1, RUNS + 1))
