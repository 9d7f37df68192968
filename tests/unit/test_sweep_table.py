"""runs.parquet built from the rows' buffers (`twmr.sweeps.table`) reads back by pandas as the
table pandas writes from the same rows, and writing it imports no pandas."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from twmr.sweeps.folder import write_table
from twmr.sweeps.table import arrow_table

ROWS = [
    {"run_id": "b", "sweep_id": "s", "sample": 1, "k": 2, "mode": "fast", "status": "failed",
     "error": "diverged at t = 17.7 s", "wall_time_s": math.nan, "worker": "", "warnings": [],
     "flag": None, "note": None},
    {"run_id": "a", "sweep_id": "s", "sample": 0, "k": 1.5, "mode": None, "status": "ok",
     "error": "", "wall_time_s": 0.25, "worker": "h:1", "warnings": ["slow", "ünïcode"],
     "rmse": np.float64(0.125), "flag": True, "steps": 3, "note": None},
    {"run_id": "c", "sweep_id": "s", "sample": 2, "k": 3.0, "mode": "slow", "status": "ok",
     "error": "", "wall_time_s": 0.5, "worker": "h:2", "warnings": [], "rmse": 0.5,
     "flag": False, "steps": 4, "note": None},
]


def test_the_table_reads_back_as_the_one_pandas_writes(tmp_path: Path) -> None:
    (tmp_path / "runs.jsonl").write_text("{}\n")
    write_table(ROWS, tmp_path)
    ours = pd.read_parquet(tmp_path / "runs.parquet")
    frame = pd.DataFrame(ROWS).sort_values("sample", kind="stable").reset_index(drop=True)
    frame.to_parquet(tmp_path / "pandas.parquet", index=False)
    theirs = pd.read_parquet(tmp_path / "pandas.parquet")
    assert list(ours["run_id"]) == ["a", "b", "c"] and not (tmp_path / "runs.jsonl").exists()
    assert list(ours.columns) == list(theirs.columns)
    assert {c: str(t) for c, t in ours.dtypes.items() if c != "note"} == \
        {c: str(t) for c, t in theirs.dtypes.items() if c != "note"}
    pd.testing.assert_frame_equal(ours.drop(columns=["warnings", "note"]),
                                  theirs.drop(columns=["warnings", "note"]))
    assert [list(w) for w in ours["warnings"]] == [["slow", "ünïcode"], [], []]
    assert ours["note"].isna().all() and math.isnan(ours["rmse"][1])


def test_values_it_does_not_build_are_left_to_pandas() -> None:
    assert arrow_table([{"x": 1.0}, {"x": "one"}], ["x"]) is None
    assert arrow_table([{"x": {"nested": 1}}], ["x"]) is None


def test_writing_the_table_imports_no_pandas(tmp_path: Path) -> None:
    code = (f"import sys\nfrom pathlib import Path\nfrom twmr.sweeps.folder import write_table\n"
            f"write_table({ROWS!r}, Path({str(tmp_path)!r}))\nprint('pandas' in sys.modules)")
    code = code.replace("nan", "float('nan')").replace("np.float64(0.125)", "0.125")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False" and (tmp_path / "runs.parquet").exists()
