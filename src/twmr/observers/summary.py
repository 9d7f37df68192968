"""`SignalSummary`: per recorded column, first / last / min / max / RMS, kept as the rows stream
by (NaN-safe), and `summary.json` written when the run ends."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core import jsonvalues
from twmr.observers.base import Observer, Outcome, RunStart

FILENAME = "summary.json"


class SignalSummary(Observer):
    """Streams statistics of every recorded column; writes `folder/summary.json` at the end with
    `header` (what the caller knows of the run), the outcome, units and the statistics."""

    def __init__(self, header: dict[str, Any] | None = None):
        self.header = dict(header or {})
        self.document: dict[str, Any] = {}
        self._run: RunStart | None = None
        self._first: np.ndarray | None = None
        self._last: np.ndarray | None = None

    def started(self, run: RunStart) -> None:
        self._run = run
        k = len(run.columns)
        self._min = np.full(k, np.inf)
        self._max = np.full(k, -np.inf)
        self._squares = np.zeros(k)
        self._count = np.zeros(k)

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        if not len(block):
            return
        if self._first is None:
            self._first = block[0].copy()
        self._last = block[-1].copy()
        columns = np.ascontiguousarray(block.T)  # the figures below, several times faster
        with np.errstate(over="ignore", invalid="ignore"):
            squares = np.einsum("ij,ij->i", columns, columns)
        # finite sums: so is every value (a NaN or Inf makes its column's sum one)
        if np.isfinite(squares).all() or np.isfinite(block).all():
            self._min = np.fmin(self._min, columns.min(axis=1))
            self._max = np.fmax(self._max, columns.max(axis=1))
            self._squares += squares
            self._count += len(block)
            return
        with np.errstate(invalid="ignore"):
            self._min = np.fmin(self._min, np.nanmin(block, axis=0))
            self._max = np.fmax(self._max, np.nanmax(block, axis=0))
        finite = np.isfinite(block)
        with np.errstate(over="ignore"):  # |x| > 1e154: its square is inf, so is the rms
            self._squares += np.where(finite, block * block, 0.0).sum(axis=0)
        self._count += finite.sum(axis=0)

    def signals(self) -> dict[str, dict[str, Any]]:
        """Per column (time excluded): unit, first, last, min, max, rms."""
        run = self._run
        first, last = self._first, self._last
        if run is None or first is None or last is None:
            return {}
        out = {}
        for j, (name, unit) in enumerate(zip(run.columns, run.units, strict=False)):
            if j == 0:
                continue
            rms = math.sqrt(self._squares[j] / self._count[j]) if self._count[j] else math.nan
            out[name] = {"unit": unit, "first": float(first[j]),
                         "last": float(last[j]), "min": float(self._min[j]),
                         "max": float(self._max[j]), "rms": rms}
        return out

    def finished(self, outcome: Outcome) -> None:
        run = self._run
        self.document = {
            **self.header, "status": outcome.status, "error": outcome.error,
            "steps": outcome.n_steps, "steps_done": outcome.steps_done,
            "wall_time_s": round(outcome.wall_time, 4),
            "realtime_factor": round(outcome.realtime_factor, 2),
            "units": dict(zip(run.columns, run.units, strict=False)) if run else {},
            "ports": run.metadata.get("ports", {}) if run else {},
            "signals": self.signals(), "pacing": outcome.extra,
            "statistics": outcome.statistics,
        }
        if outcome.stopped_by is not None:
            self.document["stopped_by"] = outcome.stopped_by
        if outcome.fired:
            self.document["fired"] = list(outcome.fired)
        if run is not None and run.folder is not None:
            write_summary(self.document, run.folder / FILENAME)


def write_summary(document: dict[str, Any], path: Path) -> None:
    """Standard JSON, non-finite numbers as the strings NaN, Infinity, -Infinity
    (`twmr.core.jsonvalues`; `twmr.read_result` reads them back as floats)."""
    path.write_text(jsonvalues.dumps(document, indent=2) + "\n")
