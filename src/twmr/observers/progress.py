"""`ProgressBar`: steps done, rate and time left on the terminal (tqdm), for long runs."""
from __future__ import annotations

from typing import Any

import numpy as np

from twmr.observers.base import Observer, Outcome, RunStart


class ProgressBar(Observer):
    def __init__(self) -> None:
        self._bar: Any = None
        self._done = 0

    def started(self, run: RunStart) -> None:
        from tqdm import tqdm

        self._bar = tqdm(total=run.n_steps, unit="step", unit_scale=True, mininterval=0.5,
                         leave=False, disable=None)

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        if self._bar is not None:
            self._bar.update(steps_done - self._done)
            self._done = steps_done

    def finished(self, outcome: Outcome) -> None:
        if self._bar is not None:
            self._bar.close()
