"""`SignalSummary`: the figures of chunks of finite rows (its quick path) are those numpy computes
over all the rows at once; a chunk holding NaN or Inf leaves NaN out of min / max and both out
of the RMS."""
from __future__ import annotations

import math

import numpy as np

from twmr.observers.base import Outcome, RunStart
from twmr.observers.summary import SignalSummary


def summary_of(chunks: list[np.ndarray]) -> dict[str, dict[str, float]]:
    s = SignalSummary()
    s.started(RunStart(("time", "a", "b"), ("s", "m", "V"), 0.1, 10, None, "<test>", {}))
    for i, chunk in enumerate(chunks):
        s.rows(chunk, i)
    s.finished(Outcome(n_steps=10))
    return s.document["signals"]


def test_finite_chunks_give_the_figures_of_all_rows() -> None:
    rows = np.column_stack([np.arange(10) * 0.1, np.sin(np.arange(10)), -3.0 + np.arange(10)])
    got = summary_of([rows[:3], rows[3:4], rows[4:]])
    for j, name in ((1, "a"), (2, "b")):
        col = rows[:, j]
        assert got[name]["min"] == col.min() and got[name]["max"] == col.max()
        assert got[name]["first"] == col[0] and got[name]["last"] == col[-1]
        assert math.isclose(got[name]["rms"], math.sqrt(np.mean(col * col)), rel_tol=1e-15)


def test_a_chunk_with_nan_or_inf_leaves_them_out_of_the_rms() -> None:
    rows = np.column_stack([np.arange(6) * 0.1, [1.0, 2.0, np.nan, 4.0, -1.0, 0.5],
                            [0.0, np.inf, 1.0, 1.0, 1.0, 1.0]])
    got = summary_of([rows[:2], rows[2:]])
    assert got["a"]["min"] == -1.0 and got["a"]["max"] == 4.0
    assert math.isclose(got["a"]["rms"], math.sqrt((1 + 4 + 16 + 1 + 0.25) / 5))
    assert got["b"]["max"] == np.inf and got["b"]["min"] == 0.0
    assert math.isclose(got["b"]["rms"], math.sqrt(4 / 5))


def test_finite_values_whose_squares_overflow_count_in_every_figure() -> None:
    """Every value finite, one column's squares beyond the float range: its RMS is Inf, each
    row still counts, and the other column's figures are those of finite rows."""
    rows = np.column_stack([np.arange(4) * 0.1, [1e200, -2e200, 3.0, 4.0], [1.0, 2.0, 3.0, 4.0]])
    got = summary_of([rows[:2], rows[2:]])
    assert got["a"]["min"] == -2e200 and got["a"]["max"] == 1e200 and got["a"]["rms"] == math.inf
    assert math.isclose(got["b"]["rms"], math.sqrt(30 / 4), rel_tol=1e-15)
