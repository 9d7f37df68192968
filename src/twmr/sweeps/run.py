"""One run of a sweep, as a worker executes it: the scenario with the run's overrides, simulated,
reduced to one row (its values, status, error, times and metrics). Whatever goes wrong becomes the
row's error; nothing is raised, so a failed run never stalls the sweep.

A worker process keeps what it imported and compiled (the engine, the components' numba kernels)
from run to run, so only the first run on a worker pays for them.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class RunTask:
    """What a worker needs for one run (all picklable)."""

    run_id: str
    sample: int
    values: dict[str, Any]
    overrides: list[str]
    source: str
    content: str
    base_dir: str
    metrics: list[str] = field(default_factory=list)
    keep: str | None = None  # folder of the run's signals, or None


def execute(task: RunTask) -> dict[str, Any]:
    """The row of one run: run_id, sample, the varied values, status ('ok' / 'failed'), error,
    wall_time_s (everything), step_time_s (stepping only), worker, warnings (the texts the run
    logged, told once per sweep by the collecting process), then the metrics."""
    import os
    import socket

    from twmr.api import Scenario, simulate
    from twmr.core.errors import CosimError
    from twmr.core.warned import taken

    t0 = time.perf_counter()
    row: dict[str, Any] = {"run_id": task.run_id, "sample": task.sample, **task.values,
                           "status": "ok", "error": "", "wall_time_s": float("nan"),
                           "step_time_s": float("nan"),
                           "worker": f"{socket.gethostname()}:{os.getpid()}", "warnings": []}
    try:
        scenario = Scenario(task.source, task.content, Path(task.base_dir), tuple(task.overrides))
        with taken(row["warnings"]):
            result = simulate(scenario, task.keep, metrics=task.metrics)
        row["step_time_s"] = float(result.summary.get("wall_time_s", float("nan")))
        for key, value in (result.summary.get("metrics") or {}).items():
            row[key] = value
    except CosimError as err:
        row.update(status="failed", error=str(err))
    except Exception as err:  # noqa: BLE001 - any failure is the run's, recorded in its row
        row.update(status="failed", error=f"{type(err).__name__}: {err}")
    row["wall_time_s"] = time.perf_counter() - t0
    return row
