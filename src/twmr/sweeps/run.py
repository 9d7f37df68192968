"""One run of a sweep, as a worker executes it: the scenario with the run's overrides, simulated,
reduced to one row (its values, status, error, times and metrics). Whatever goes wrong becomes the
row's error; nothing is raised, so a failed run never stalls the sweep.

A worker process keeps what it imported and compiled (the engine, the components' numba kernels)
from run to run, so only the first run on a worker pays for them, and it keeps each scenario it
ran built (`twmr.built.Built`, by the scenario's content and the overrides it was built with):
a later run of it sets the components to the run's values instead of reading and building the
scenario again. `execute_batch` runs several tasks in one call (one Dask task for several runs).
"""
from __future__ import annotations

import time
from collections import OrderedDict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: scenarios a worker keeps built (the least recently run one is dropped first)
KEEP_BUILT = 4
_built: OrderedDict[tuple[str, str, str, tuple[str, ...]], Any] = OrderedDict()


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
    #: overrides the worker's built system includes (the same for every run of a sweep);
    #: the run's are `built_with` + `overrides`
    built_with: list[str] = field(default_factory=list)
    #: the runs of the sweep a worker is expected to make (`twmr.built.Built.expect`)
    share: int = 0


def execute(task: RunTask) -> dict[str, Any]:
    """The row of one run: run_id, sample, the varied values, status ('ok' / 'failed'), error,
    wall_time_s (everything), step_time_s (stepping only), worker, warnings (the texts the run
    logged, told once per sweep by the collecting process), then the metrics."""
    import os
    import socket

    from twmr.core.errors import CosimError
    from twmr.core.warned import taken

    t0 = time.perf_counter()
    row: dict[str, Any] = {"run_id": task.run_id, "sample": task.sample, **task.values,
                           "status": "ok", "error": "", "wall_time_s": float("nan"),
                           "step_time_s": float("nan"),
                           "worker": f"{socket.gethostname()}:{os.getpid()}", "warnings": []}
    try:
        with taken(row["warnings"]):
            result = built_for(task).run(task.overrides, out=task.keep, metrics=task.metrics)
        row["step_time_s"] = float(result.summary.get("wall_time_s", float("nan")))
        for key, value in (result.summary.get("metrics") or {}).items():
            row[key] = value
    except CosimError as err:
        row.update(status="failed", error=str(err))
    except Exception as err:  # noqa: BLE001 - any failure is the run's, recorded in its row
        row.update(status="failed", error=f"{type(err).__name__}: {err}")
    row["wall_time_s"] = time.perf_counter() - t0
    return row


def execute_batch(tasks: list[RunTask]) -> list[dict[str, Any]]:
    """The rows of `tasks`, run one after the other in this worker."""
    return [execute(task) for task in tasks]


def built_for(task: RunTask) -> Any:
    """This worker's built system of the task's scenario and `built_with` overrides (built now
    on first use)."""
    from twmr.api import Scenario
    from twmr.built import Built

    key = (task.source, task.content, task.base_dir, tuple(task.built_with))
    built = _built.get(key)
    if built is None:
        scenario = Scenario(task.source, task.content, Path(task.base_dir),
                            tuple(task.built_with))
        built = Built(scenario)
        _built[key] = built
        while len(_built) > KEEP_BUILT:
            _built.popitem(last=False)
    _built.move_to_end(key)
    built.expect(task.share)
    return built
