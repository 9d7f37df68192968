"""The master: the `Algorithm` interface and the generated fixed-step loop, `Execution`."""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from twmr.core.run import RunContext
from twmr.master.algorithm import Algorithm, NonFinite, make_algorithm
from twmr.master.execution import Execution, Pacer, RunInterrupted, columns_of
from twmr.observers.base import Observer
from twmr.observers.store import ResultStore
from twmr.scenario.system import System


def simulate(system: System, folder: str | Path | None = None,
             observers: Sequence[Observer] = (), check_finite: bool = True) -> np.ndarray:
    """Run a built `system` to its stop time; the recorded rows as a structured array (`time` and
    one field per recorded scalar). With `folder`, the rows are also streamed to
    `folder/result.arrows`. Raises `ComponentError` on a failure, after every component is
    terminated. (The user-facing entry point is `twmr.simulate`.)"""
    store = ResultStore()
    if folder is not None:
        Path(folder).mkdir(parents=True, exist_ok=True)
    ex = Execution(system, [store, *observers], folder, check_finite)
    ex.run()
    values = store.data() if folder is None else _read(Path(folder))
    dtype = np.dtype([(c, "<f8") for c in ex.columns])
    return np.ascontiguousarray(values).view(dtype).reshape(-1)


def _read(folder: Path) -> np.ndarray:
    from twmr.observers.store import FILENAME, read_store

    return read_store(folder / FILENAME)[2]


__all__ = [
    "Algorithm",
    "Execution",
    "NonFinite",
    "Pacer",
    "RunContext",
    "RunInterrupted",
    "columns_of",
    "make_algorithm",
    "simulate",
]
