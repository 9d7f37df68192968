"""`twmr.Workers`: one local cluster for the sweeps and tunes inside a `with` block — the rows of
every call come from the pool's worker processes, a call asking for another number of workers
starts its own, and the pool's processes are gone once the block ends."""
from __future__ import annotations

import os
import time
from pathlib import Path

import pandas as pd
import pytest

import twmr

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
LOOP = ROOT / "tests" / "fixtures" / "scenarios" / "loop_tune.yaml"
HEIGHT = "ref.height=uniform:0.5:1.5"


def _pids(rows: pd.DataFrame) -> set[int]:
    return {int(w.rpartition(":")[2]) for w in rows["worker"]}


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return True


def test_sweeps_and_tunes_in_a_pool_share_its_workers(tmp_path: Path) -> None:
    with twmr.Workers(2) as pool:
        pids = set(pool.pids)
        assert len(pids) == 2
        first = twmr.sweep(LOOP, [HEIGHT], samples=6, out=tmp_path / "a").frame()
        second = twmr.sweep(LOOP, [HEIGHT], samples=6, workers=2, out=tmp_path / "b").frame()
        assert (first["status"] == "ok").all() and (second["status"] == "ok").all()
        assert _pids(first) <= pids and _pids(second) <= pids
        tune = twmr.tune(LOOP, ["ctrl.k=log:0.3:30"], "ms_err_y", vary=[HEIGHT],
                         realisations=2, trials=2, metrics=["signals"], workers=2,
                         report=False, out=tmp_path / "t")
        assert _pids(pd.DataFrame(tune.runs)) <= pids
        other = twmr.sweep(LOOP, [HEIGHT], samples=3, workers=1, out=tmp_path / "c").frame()
        assert not _pids(other) & pids  # another number of workers: a cluster of its own
        assert set(pool.pids) == pids  # the calls left the pool as it was
    deadline = time.monotonic() + 30.0
    while any(_alive(p) for p in pids) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not any(_alive(p) for p in pids)
