"""The master: algorithms (Gauss-Seidel, Jacobi, multi-rate), execution and the recorder."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from twmr.master.algorithm import ALGORITHMS, generate
from twmr.master.execution import Execution, Pacer, RunInfo
from twmr.master.recorder import Recorder, columns_of
from twmr.scenario.system import System


def simulate(system: System, result_path: str | Path | None = None, progress: bool = False,
             check_finite: bool = True) -> np.ndarray:
    """Run `system` to its stop time; the recorded structured array (time + one column per
    recorded scalar). Raises `ComponentError` on a failure, with the results so far on disk."""
    return Execution(system, result_path, progress, check_finite).run()


__all__ = ["simulate", "Execution", "Recorder", "RunInfo", "Pacer", "generate", "ALGORITHMS",
           "columns_of"]
