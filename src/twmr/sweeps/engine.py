"""`sweep`: the runs of a `SweepSpec` on a Dask cluster — a local one of worker processes, or an
existing one by its scheduler address — with the rows collected into `DIR/runs.parquet`.

- The folder is locked while the sweep runs and holds the rows of one sweep only
  (`twmr.sweeps.folder`).
- Each finished run's row is appended at once to `DIR/runs.jsonl` (flushed), so a sweep that is
  killed loses no finished run; `runs.parquet` is written from all rows at the end, also after
  Ctrl-C.
- A local cluster listens on 127.0.0.1 only, its dashboard off unless asked for. A scheduler
  address comes from the caller (`--scheduler`, `scheduler=`), never from a file: a Dask cluster
  runs code in this process (results are unpickled) and is trusted.
- A run's id is a hash of its overrides: a second invocation on the same folder skips every run
  already done (ok or failed) and runs only the new ones.
- Runs go to the workers in batches of a few (one Dask task each); each worker keeps the
  scenario built and sets it to each run's values (`twmr.sweeps.run`). A run that fails is a row
  with its error; a worker that dies (e.g. a crash inside an FMU) makes Dask retry its batch
  elsewhere, then each run of it alone, and a run that still kills its worker is recorded as
  failed.
"""
from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import math
import os
import signal
import threading
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from twmr.sweeps.folder import (
    IDENTITY,
    JOURNAL,
    SweepFolder,
    append_row,
    open_journal,
    write_table,
)
from twmr.sweeps.main_guard import unguarded_call
from twmr.sweeps.run import RunTask, execute_batch
from twmr.sweeps.spec import SweepError, SweepSpec, Vary, run_id

log = logging.getLogger("twmr.sweep")


@dataclass
class SweepOutcome:
    """What a sweep did: every row of the folder (earlier runs included), how many runs it ran
    now, how many of those failed, and whether it was interrupted."""

    rows: list[dict[str, Any]]
    ran: int
    failed: int
    skipped: int
    folder: Path
    interrupted: bool = False

    def frame(self) -> Any:
        """The rows as a pandas DataFrame (as in runs.parquet)."""
        import pandas as pd

        return pd.DataFrame(self.rows)


def overrides_of(values: dict[str, Any], varies: list[Vary], base: dict[str, Any]) -> list[str]:
    """`comp.param=value` texts for one run; elements of one vector are merged into it."""
    out: dict[str, Any] = {}
    for v in varies:
        key, index = v.target
        value = values[v.name]
        if index is None:
            out[key] = value
        else:
            vector = list(out.get(key, base[key]))
            vector[index] = value
            out[key] = vector
    return [f"{k}={json.dumps(v)}" for k, v in out.items()]


def check_names(scenario: Any, varies: list[Vary], option: str = "--vary") -> None:
    """Every NAME is an override of this scenario (its values are each run's business: a value
    out of range fails that run only)."""
    from twmr.registry import suggest

    comps = scenario.system.components
    for v in varies:
        key, index = v.target
        comp, _, param = key.rpartition(".")
        if key.startswith("events.") and "events" not in comps:
            from twmr.scenario.overrides import event_key

            try:
                event_key(scenario.spec, key)
            except ValueError as err:
                raise SweepError(f"{option} {v.name}: {err}") from None
            if index is not None:
                raise SweepError(f"{option} {v.name}: an event's keys have no elements.")
            continue
        if comp == "experiment":
            known = ["start", "stop", "step", "algorithm", "realtime"]
        elif comp in comps:
            known = ["step_multiple"] + [n for n, var in comps[comp].variables.items()
                                         if var.kind in ("parameter", "state", "input")]
        else:
            raise SweepError(f"{option} {v.name}: the scenario has no component '{comp}'"
                             f"{suggest(comp, list(comps))}. Fix: use one of "
                             f"{', '.join(comps)}, or 'experiment'.")
        if param not in known:
            raise SweepError(f"{option} {v.name}: '{comp}' has no parameter, state or input "
                             f"'{param}'{suggest(param, known)}. Fix: use one of "
                             f"{', '.join(known)}.")
        if index is not None and comp == "experiment":
            raise SweepError(f"{option} {v.name}: experiment settings have no elements.")


def vector_bases(scenario: Any, varies: list[Vary]) -> dict[str, Any]:
    """The scenario's own value of every vector an element of which is varied."""
    comps = scenario.system.components
    bases: dict[str, Any] = {}
    for v in varies:
        key, index = v.target
        if index is None:
            continue
        comp, _, param = key.rpartition(".")
        value = comps[comp].get(param)  # the name is known: check_names ran first
        if not isinstance(value, tuple) or index >= len(value):
            size = len(value) if isinstance(value, tuple) else "a scalar"
            raise SweepError(f"--vary {v.name}: '{key}' has {size} element(s); element "
                             f"{index + 1} does not exist. Fix: index from 1 to its size.")
        bases[key] = value
    return bases


def refuse_unguarded_workers() -> None:
    """SweepError when the running script starts local worker processes from its top level,
    outside `if __name__ == "__main__":` (each worker would import it again and start its own):
    said before any worker starts, from the public call, so the traceback is short."""
    unguarded = unguarded_call()
    if unguarded is not None:
        raise SweepError(f"{unguarded[0]} line {unguarded[1]} starts local worker processes at "
                         f"the script's top level; each worker imports the script again "
                         f"(multiprocessing's spawn) and would start its own. Fix: put that "
                         f"call, and what it needs, under `if __name__ == \"__main__\":` (or "
                         f"give scheduler= a running cluster).")


def dask_client(workers: int | None, scheduler: str | None, dashboard: bool = False,
                pooled: bool = True) -> tuple[Any, Any]:
    """(client, cluster or None): a LocalCluster of worker processes on 127.0.0.1 (with its
    dashboard on 127.0.0.1 when `dashboard`), or the given scheduler, or (`pooled`) a client of
    the open `twmr.Workers` pool that fits `workers` (`twmr.sweeps.pool`; cluster None: the
    caller closes only its client)."""
    from twmr.core.extras import require

    require("dask.distributed", "a sweep on Dask")
    import dask
    from dask.distributed import Client, LocalCluster

    # failures are the rows' business, and what Dask says while it is torn down after Ctrl-C
    # (tracebacks of its event loop) is not the user's: Dask's loggers and those it uses
    families = ("distributed", "tornado", "asyncio")
    for name in [*families, *(n for n in logging.root.manager.loggerDict
                              if n.split(".")[0] in families)]:
        logging.getLogger(name).setLevel(logging.CRITICAL)
    if scheduler:
        try:
            return Client(scheduler, timeout="10s"), None
        except (OSError, TimeoutError) as err:
            raise SweepError(f"--scheduler {scheduler}: no Dask scheduler answers there "
                             f"({err}). Fix: start one with `dask scheduler` and workers with "
                             f"`dask worker {scheduler}`, or leave --scheduler out.") from None
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool)
                                or workers < 1):
        raise SweepError(f"--workers {workers!r}: give a whole number of at least 1 (or leave "
                         f"it out: one per core).")
    if pooled and not dashboard:
        client = _pool_client(workers)
        if client is not None:
            return client, None
    refuse_unguarded_workers()
    n = workers or os.cpu_count() or 1
    cluster = None
    try:
        with _ctrl_c_deferred(), warnings.catch_warnings(), \
                dask.config.set({SPAWN_ENVIRON: worker_environ()}):
            warnings.simplefilter("ignore")  # e.g. "port 8787 is in use"
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   host="127.0.0.1",
                                   dashboard_address="127.0.0.1:0" if dashboard else None,
                                   silence_logs=logging.CRITICAL)
        if dashboard:
            log.info("sweep: the Dask dashboard is at %s", cluster.dashboard_link)
        return Client(cluster), cluster
    except BaseException:
        if cluster is not None:
            from twmr.master.execution import held_signals

            with held_signals():
                close_client(None, cluster, [])
        raise


#: the open `twmr.Workers` pools (`twmr.sweeps.pool`), innermost last
OPEN_POOLS: list[Any] = []


def _pool_client(workers: int | None) -> Any:
    """A new client of the innermost open pool when `workers` fits it (None or its size), else
    None: the caller starts a cluster of its own."""
    if not OPEN_POOLS or (workers is not None and workers != OPEN_POOLS[-1].n):
        return None
    from dask.distributed import Client

    return Client(OPEN_POOLS[-1].cluster)


SPAWN_ENVIRON = "distributed.nanny.pre-spawn-environ"
#: what Dask sets by default before it starts a worker that a sweep's worker does without:
#: glibc's trim threshold, set at all, stops glibc from raising its mmap threshold, so every
#: run's row buffers (a few hundred kB) are mapped afresh and paged in (the paper scenario's
#: runs stepped 0.3-0.45 ms longer in such a worker)
DASK_DEFAULT_ENVIRON = {"MALLOC_TRIM_THRESHOLD_": 65536}


def worker_environ() -> dict[str, Any]:
    """Dask's environment for a new worker process, without the defaults a sweep does without
    (a value the user configured is kept)."""
    import dask

    return {k: v for k, v in dask.config.get(SPAWN_ENVIRON, {}).items()
            if DASK_DEFAULT_ENVIRON.get(k, object()) != v}


@contextlib.contextmanager
def _ctrl_c_deferred() -> Iterator[None]:
    """Ctrl-C held back until the end of the block, where it is raised, and never seen by the
    worker processes started inside: a terminal sends it to the whole process group, and this
    process stops the workers after saving the rows. Main thread only; elsewhere nothing
    changes."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    from multiprocessing import resource_tracker

    # blocked in this thread: inherited by the threads it starts and the processes those start
    # (across exec, for good); a Ctrl-C that another thread of this process takes is noted.
    # The resource tracker unblocks Ctrl-C in the thread that starts it: started here, first.
    resource_tracker.ensure_running()
    held: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, _frame: held.append(signum))
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        signal.signal(signal.SIGINT, previous)
    if held:
        raise KeyboardInterrupt


def sweep(spec: SweepSpec, out: str | Path, *, workers: int | None = None,
          scheduler: str | None = None, keep_signals: bool = False, dashboard: bool = False,
          progress: bool = False, on_row: Callable[[dict[str, Any]], None] | None = None
          ) -> SweepOutcome:
    """Run the sweep `spec` into folder `out` (see the module's docstring). Raises SweepError
    (or the scenario's ScenarioError) before anything runs when the sweep is ill-formed."""
    from twmr.api import load
    from twmr.fmi.guard import isolation_advice

    table = spec.samples_table()
    scenario = load(spec.scenario, list(spec.fixed))
    for advice in isolation_advice(scenario.system.components):
        log.warning("warning: %s", advice)
    check_names(scenario, spec.vary)
    bases = vector_bases(scenario, spec.vary)
    folder = Path(out).resolve()  # absolute: workers on a shared file system write there
    content = scenario.content if isinstance(scenario.content, str) else \
        json.dumps(scenario.content, sort_keys=True)
    with SweepFolder(folder, spec, content) as place:
        tasks = _tasks(spec, scenario, content, bases, table, place, keep_signals)
        outcome = SweepOutcome(place.rows, 0, 0, len(table) - len(tasks), folder)
        if tasks:
            _collect(tasks, place, outcome, workers=workers, scheduler=scheduler,
                     dashboard=dashboard, progress=progress, on_row=on_row)
        else:
            write_table(outcome.rows, folder)
    return outcome


def _tasks(spec: SweepSpec, scenario: Any, content: str, bases: dict[str, Any],
           table: list[dict[str, Any]], place: SweepFolder, keep_signals: bool
           ) -> list[RunTask]:
    """The runs of `table` the folder does not hold yet."""
    done_ids = {r["run_id"] for r in place.rows}
    tasks: list[RunTask] = []
    for i, values in enumerate(table):
        rid = run_id(values, spec.fixed)
        if rid in done_ids:
            continue  # done before, or the same overrides drawn twice: the same run
        done_ids.add(rid)
        keep = str(place.path / "runs" / rid) if keep_signals else None
        tasks.append(RunTask(rid, i, values, overrides_of(values, spec.vary, bases),
                             scenario.source, content, str(scenario.base_dir),
                             list(spec.metrics), keep, list(spec.fixed)))
    return tasks


def _collect(tasks: list[RunTask], place: SweepFolder, outcome: SweepOutcome, *,
             workers: int | None, scheduler: str | None, dashboard: bool, progress: bool,
             on_row: Callable[[dict[str, Any]], None] | None) -> None:
    """Run `tasks` on Dask; each row into the journal and `outcome` as it comes; runs.parquet
    from every row at the end, also after Ctrl-C."""
    from twmr.core.warned import SweepWarnings
    from twmr.master.execution import held_signals

    folder = place.path
    warned = SweepWarnings(log)
    futures: list[Any] = []
    client = cluster = bar = journal = None
    try:
        client, cluster = dask_client(workers, scheduler, dashboard)
        if progress:
            from tqdm import tqdm

            bar = tqdm(total=len(tasks), unit="run", dynamic_ncols=True, desc="sweep")
        journal = open_journal(folder / JOURNAL)
        from dask.distributed import as_completed

        slots = sum(client.nthreads().values()) or 1
        share = -(-len(tasks) // slots)  # a worker's runs
        for task in tasks:
            task.share = share
        batches = batched(tasks, slots)
        futures = client.map(execute_batch, batches, pure=False,
                             key=[f"runs-{b[0].run_id}-{len(b)}" for b in batches])
        by_key = {f.key: b for f, b in zip(futures, batches, strict=True)}
        pending = as_completed(futures)
        # the runs of lost batches, run again alone and one after another: a run queued beside
        # one that kills its worker would be lost with it (Dask counts every task the dead
        # worker held), so only the killing run fails
        lane: list[RunTask] = []

        def next_alone() -> None:
            task = lane.pop(0)
            f = client.submit(execute_batch, [task], pure=False, key=f"run-{task.run_id}")
            by_key[f.key] = [task]
            pending.add(f)
            futures.append(f)

        done = Finished(pending, client, futures)
        for future in done:
            settled(future)
            batch = by_key[future.key]
            alone = future.key.startswith("run-")
            if future.status != "finished" and len(batch) > 1 and not done.gave_up:
                lane += batch  # lost with its worker
                if not any(not f.done() and f.key.startswith("run-") for f in futures):
                    next_alone()
                continue
            if alone and lane and not done.gave_up:
                next_alone()
            if future.status == "finished":
                rows = future.result()
            else:  # the worker died under it (several times), the task was lost, no worker
                error = no_worker() if done.gave_up else lost_error(future.exception())
                rows = [failed_row(task, error) for task in batch]
            if done.gave_up and lane:
                rows += [failed_row(task, no_worker()) for task in lane]
                lane.clear()
            for row in rows:
                row = {"run_id": row["run_id"], IDENTITY: place.sweep_id, **row}
                warned.add(row["run_id"], row["warnings"])
                outcome.rows.append(row)  # first: the table at the end is written from these
                append_row(journal, row)
                outcome.ran += 1
                outcome.failed += row["status"] != "ok"
                if on_row is not None:
                    on_row(row)
                if bar is not None:
                    bar.set_postfix(failed=outcome.failed, refresh=False)
                    bar.update(1)
    except KeyboardInterrupt as stop:
        outcome.interrupted = True
        stop.partial_results = folder  # type: ignore[attr-defined]  # shown by the CLI
        raise
    finally:
        with held_signals():  # a second Ctrl-C must not cut the saving short
            if bar is not None:
                bar.close()
            if journal is not None:
                journal.close()
            close_client(client, cluster, futures)
            write_table(outcome.rows, folder)
            warned.close()


#: the most runs in one Dask task (a batch costs one scheduling; its rows come when it ends)
MAX_BATCH = 16


def batched(tasks: list[RunTask], workers: int) -> list[list[RunTask]]:
    """`tasks` in batches of consecutive runs: about four batches per worker, so the workers
    stay busy to the end, and at most `MAX_BATCH` runs each, so rows keep coming."""
    size = max(1, min(MAX_BATCH, len(tasks) // (4 * max(1, workers))))
    return [tasks[i:i + size] for i in range(0, len(tasks), size)]


def close_client(client: Any, cluster: Any, futures: list[Any]) -> None:
    """Stop the runs left, then the client and the local cluster, without a word (what Dask
    says while it is torn down after Ctrl-C is not the user's business)."""
    try:
        if client is not None:
            if futures:
                client.cancel(futures)
            client.close(timeout=10)
        if cluster is not None:
            cluster.close(timeout=10)
    except BaseException:  # noqa: BLE001 - closing after Ctrl-C must not hide the rows
        log.debug("closing the Dask cluster failed", exc_info=True)


#: how long a sweep waits with no Dask worker at all before it fails the runs left [s]
NO_WORKER_PATIENCE = 60.0


def no_worker() -> str:
    """The error of a run no worker was left to run."""
    return (f"no Dask worker was left to run it (the workers died and none came back within "
            f"{NO_WORKER_PATIENCE:g} s). Fix: run the sweep again with --resume: the runs done "
            f"are kept; look at what killed the workers (memory, a crash in native code).")


class Finished:
    """The futures of `pending` (a dask `as_completed`) as they finish. When the cluster has
    had no worker for `NO_WORKER_PATIENCE` s (killed, and not replaced), the futures left in
    `futures` are cancelled and given as they are (`gave_up` set): a sweep never waits on
    workers that will not come."""

    def __init__(self, pending: Any, client: Any, futures: list[Any]):
        self.pending, self.client, self.futures = pending, client, futures
        self.gave_up = False

    def __iter__(self) -> Iterator[Any]:
        alone_since: float | None = None
        checked = time.monotonic()
        given: set[Any] = set()  # keys (a finished future may go back to pending: its data
        while not self.pending.is_empty():  # was on a worker that died)
            if self.pending.has_ready():
                future = next(self.pending)
                given.add(future.key)
                yield future
                continue
            self._wait()
            now = time.monotonic()
            if now - checked < 1.0:
                continue
            checked = now
            if self.client.nthreads():
                alone_since = None
                continue
            alone_since = alone_since if alone_since is not None else now
            if now - alone_since >= NO_WORKER_PATIENCE:
                self.gave_up = True
                left = [f for f in self.futures if not f.done() and f.key not in given]
                self.client.cancel(left)
                log.warning("no Dask worker for %g s: the %d batches left fail",
                            NO_WORKER_PATIENCE, len(left))
                yield from left
                return


    def _wait(self) -> None:
        """Until a future finishes (woken by it, not polled) or 1 s has passed."""
        left = [f for f in self.futures if not f.done()]
        if not left:  # finished, and not yet handed to `pending` by its callback
            time.sleep(0.001)
            return
        from dask.distributed import wait

        with contextlib.suppress(TimeoutError, asyncio.TimeoutError):
            wait(left, timeout=1.0, return_when="FIRST_COMPLETED")


def settled(future: Any) -> None:
    """Wait (at most `NO_WORKER_PATIENCE` s) for a future that finished and then lost its
    result with the worker that held it: Dask computes it again."""
    if future.status in ("lost", "pending"):
        from dask.distributed import wait

        with contextlib.suppress(TimeoutError):
            wait([future], timeout=NO_WORKER_PATIENCE)


def failed_row(task: RunTask, error: str) -> dict[str, Any]:
    """The row of a run that did not run to its end on a worker."""
    return {"run_id": task.run_id, "sample": task.sample, **task.values, "status": "failed",
            "error": error, "wall_time_s": math.nan, "step_time_s": math.nan, "worker": "",
            "warnings": []}


def lost_error(exc: BaseException | None) -> str:
    """The error of a run whose worker process died under it."""
    if type(exc).__name__ == "KilledWorker":
        return ("the worker process running it died each time it was tried (a crash inside "
                "native code, e.g. an FMU, or the memory limit). Fix: run this case alone with "
                "`twmr run` (with `isolate: true` on its FMUs) to see what happens.")
    return f"the run was lost by Dask: {type(exc).__name__}: {exc}"


def spec_from(scenario: str, vary: Sequence[str | Vary], **options: Any) -> SweepSpec:
    """A SweepSpec from a scenario path and `NAME=SPEC` texts (or Vary objects)."""
    from twmr.sweeps.spec import parse_vary

    varies = [v if isinstance(v, Vary) else parse_vary(v) for v in vary]
    spec = SweepSpec(str(scenario), varies, **options)
    spec.check()
    return spec
