"""`PacingReport`: a paced run's per-step lateness saved as `lateness_us.npy` in its folder."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from twmr.observers.base import Observer, Outcome, RunStart

FILENAME = "lateness_us.npy"


class PacingReport(Observer):
    def __init__(self) -> None:
        self.folder: Path | None = None

    def started(self, run: RunStart) -> None:
        self.folder = run.folder

    def finished(self, outcome: Outcome) -> None:
        if self.folder is not None and outcome.lateness_us is not None:
            np.save(self.folder / FILENAME, outcome.lateness_us)
