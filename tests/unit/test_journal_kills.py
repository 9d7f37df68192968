"""A kill while a journal line is written leaves a fragment; the next resume cuts it off before
appending, so a resume after any number of kills reads every finished row (sweeps and tunes
share the journal writer)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twmr.sweeps.folder import JOURNAL, SweepFolder, append_row, open_journal
from twmr.tuning.study import JOURNAL as TUNE_JOURNAL
from twmr.tuning.study import _read_journal

pytestmark = pytest.mark.timeout(120)


def _trial(k: int) -> dict[str, object]:
    return {"trial": {"number": k, "value": 0.5 * k, "params": {"lam": 1.0 + k}},
            "runs": [{"run_id": f"t{k}-r0", "status": "completed", "cost": float(k)}]}


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 4), st.floats(0.0, 0.999)), min_size=1, max_size=5))
def test_tune_resumes_after_kills_at_any_byte(tmp_path_factory: pytest.TempPathFactory,
                                             kills: list[tuple[int, float]]) -> None:
    folder = tmp_path_factory.mktemp("tune")
    path = folder / TUNE_JOURNAL
    finished = 0
    for written, cut in kills:
        with open_journal(path) as journal:  # a resume
            for _ in range(written):
                append_row(journal, _trial(finished))
                finished += 1
        line = (json.dumps(_trial(finished)) + "\n").encode()
        with open(path, "ab") as f:  # the kill: part of the next line reached the disk
            f.write(line[:int(cut * (len(line) - 1))])
        trials, runs, *_ = _read_journal(folder)
        assert [t["number"] for t in trials] == list(range(finished))
        assert len(runs) == finished


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 5), st.floats(0.01, 0.99), st.integers(1, 3))
def test_sweep_resume_keeps_every_row(tmp_path_factory: pytest.TempPathFactory, before: int,
                                      cut: float, after: int) -> None:
    folder: Path = tmp_path_factory.mktemp("sweep")
    rows = [{"run_id": f"r{k}", "status": "completed", "sample": k}
            for k in range(before + after + 1)]
    with open_journal(folder / JOURNAL) as journal:
        for row in rows[:before]:
            append_row(journal, row)
    torn = (json.dumps(rows[before]) + "\n").encode()
    with open(folder / JOURNAL, "ab") as f:
        f.write(torn[:max(1, int(cut * (len(torn) - 1)))])
    for _ in range(2):  # two resumes, each finishing runs
        with open_journal(folder / JOURNAL) as journal:
            for row in rows[before + 1:before + 1 + after]:
                append_row(journal, row)
    read = SweepFolder.__new__(SweepFolder)
    read.path = folder
    assert {r["run_id"] for r in read._read_rows()} == \
        {r["run_id"] for r in rows[:before] + rows[before + 1:before + 1 + after]}
