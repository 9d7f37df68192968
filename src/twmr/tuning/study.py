"""`tune`: an Optuna study (TPE, seeded) over a scenario's parameters, each trial the scenario run
over the same N realisations (common random numbers: drawn once from `seed` as a sweep draws its
runs), its objective an aggregate of a metric expression over them. Trials are asked in batches of B
(Optuna ask/tell; the pending trials of a batch are told to the sampler as constant liars) and the B
x N runs of a batch go to the workers at once; the next batch is asked while one runs (two in
flight, at fixed points: after the batch before the one running is told), or, lockstep, once the
batch before it is told. The proposals depend on the seed, B and lockstep, not on the number of
workers nor on when runs end. A baseline scenario, run once over the same realisations, gives its
figures to the expressions as `base_<figure>`.

Folder `DIR` (locked while the tune runs, as a sweep's folder):
- `tune.json`: what the study is (scenario hash, params, objective, realisations...); a second
  tune into a folder holding trials must be the same study, and continues it up to `trials` in
  all;
- `trials.jsonl`: the baseline's runs (first line, when there is a baseline), then one line per
  finished trial, flushed (Ctrl-C or a kill keeps every finished trial; the batch being run is
  dropped);
- `trials.parquet` (a row per trial: parameters, objective, spread, status, violations) and
  `realisations.parquet` (a row per run), written at the end, also after Ctrl-C;
- `baseline.parquet`: the baseline's runs;
- `best.yaml`: the scenario with the best feasible trial's parameters set; `report/`.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from twmr.core.warned import SweepWarnings
from twmr.sweeps.engine import (
    Finished,
    check_names,
    close_client,
    dask_client,
    failed_row,
    lost_error,
    no_worker,
    overrides_of,
    settled,
    vector_bases,
)
from twmr.sweeps.folder import append_row, open_journal, release_lock, take_lock
from twmr.sweeps.run import RunTask, execute, execute_batch
from twmr.sweeps.spec import SweepSpec, Vary, run_id
from twmr.tuning.objective import (
    Constraint,
    Expression,
    Param,
    TuneError,
    aggregate,
    check_aggregate,
    unknown_names,
)

log = logging.getLogger("twmr.tuning")
DESCRIPTION, JOURNAL = "tune.json", "trials.jsonl"
TRIALS, REALISATIONS, BEST = "trials.parquet", "realisations.parquet", "best.yaml"
BASELINE = "baseline.parquet"
BASE = "base_"  # prefix of a baseline figure in the expressions
VALIDATION_RUNS = "validation.parquet"
TRAINING, VALIDATION, TEST = "training", "validation", "test"
#: what each part's seed stream adds to the seed (far apart: seeds of studies do not collide)
STREAMS = {TRAINING: 0, VALIDATION: 1_000_003, TEST: 2_000_029}
_OURS = {DESCRIPTION, JOURNAL, TRIALS, REALISATIONS, BASELINE, BEST, VALIDATION_RUNS, ".lock",
         "report"}


@dataclass
class TuneSpec:
    """A whole tune: the scenario, the searched parameters, the objective and its aggregate,
    the constraints, the realisations (varied overrides, how many, their seed)."""

    scenario: str
    params: list[Param]
    objective: Expression
    vary: list[Vary] = field(default_factory=list)
    realisations: int = 1
    trials: int = 30
    seed: int = 0
    aggregate: str = "mean"
    constraints: list[Constraint] = field(default_factory=list)
    metrics: list[str] = field(default_factory=list)
    fixed: list[str] = field(default_factory=list)
    method: str = "random"
    baseline: str | None = None
    start: list[dict[str, Any]] = field(default_factory=list)
    #: realisations drawn apart from the training ones (their own seed stream), never optimised
    #: on: the `validate_top` best trials by training objective run on them and the best is
    #: chosen there; `test` further ones run by the chosen trial alone (reported only)
    validation: int = 0
    validate_top: int = 5
    test: int = 0

    def check(self) -> None:
        """TuneError when the tune is ill-formed."""
        if not self.params:
            raise TuneError("nothing to tune. Fix: give at least one --param NAME=SPEC.")
        names = [p.name for p in self.params]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise TuneError(f"--param {', '.join(twice)} given twice. Fix: give each once.")
        clash = sorted(set(names) & {v.name for v in self.vary})
        if clash:
            raise TuneError(f"{clash[0]} is both tuned (--param) and varied (--vary). Fix: "
                            f"give it in one of them.")
        for what, n in (("--trials", self.trials), ("--realisations", self.realisations)):
            if not isinstance(n, int) or isinstance(n, bool) or n < 1:
                raise TuneError(f"{what} {n!r} is not a positive whole number. Fix: give "
                                f"e.g. {what} 10.")
        if not self.vary and self.realisations != 1:
            raise TuneError(f"--realisations {self.realisations} without --vary: every "
                            f"realisation would be the same run. Fix: give --vary NAME=SPEC "
                            f"(what differs between realisations), or --realisations 1.")
        if not self.metrics:
            from twmr.registry import metrics

            raise TuneError(f"no registered metric set gives "
                            f"{', '.join(self.objective.names) or 'a figure of the objective'}. "
                            f"Fix: give --metrics NAME (one of: "
                            f"{', '.join(sorted(metrics())) or 'none installed'}), or name "
                            f"the figures of one in --objective.")
        check_aggregate(self.aggregate)
        by_name = {p.name: p for p in self.params}
        for i, point in enumerate(self.start, 1):
            missing = sorted(set(by_name) - set(point))
            extra = sorted(set(point) - set(by_name))
            if missing or extra:
                what = f"no value of {missing[0]}" if missing else f"{extra[0]} is not tuned"
                raise TuneError(f"--start {i}: {what}. Fix: give every --param NAME=VALUE once "
                                f"in each --start, and nothing else.")
            for name, value in point.items():
                if not by_name[name].contains(value):
                    raise TuneError(f"--start {i}: {name}={value!r} is outside its range "
                                    f"{by_name[name].text}. Fix: give a value inside it.")
        for what, n in (("--validation", self.validation), ("--test", self.test)):
            if not isinstance(n, int) or isinstance(n, bool) or n < 0:
                raise TuneError(f"{what} {n!r} is not a whole number >= 0. Fix: give e.g. "
                                f"{what} 20 (0: none).")
        if (self.validation or self.test) and not self.vary:
            raise TuneError("--validation/--test without --vary: every realisation would be the "
                            "training one. Fix: give --vary NAME=SPEC (what differs between "
                            "realisations).")
        if self.test and not self.validation:
            raise TuneError("--test without --validation: the test set judges the trial chosen "
                            "on validation. Fix: give --validation N too.")
        if not isinstance(self.validate_top, int) or isinstance(self.validate_top, bool) or \
                self.validate_top < 1:
            raise TuneError(f"--validate-top {self.validate_top!r} is not a positive whole "
                            f"number. Fix: give e.g. --validate-top 5.")
        uses_base = [n for n in self.names() if n.startswith(BASE)]
        if uses_base and not self.baseline:
            raise TuneError(f"'{uses_base[0]}' is a baseline figure, and no baseline is given. "
                            f"Fix: give --baseline SCENARIO (run once over the same "
                            f"realisations), or leave the {BASE} names out.")

    def names(self) -> list[str]:
        """The figure names the objective and the constraints use."""
        return [*self.objective.names, *(n for c in self.constraints for n in c.expression.names)]

    def table(self, part: str = TRAINING) -> list[dict[str, Any]]:
        """The realisations of `part` (training, validation, test): one {NAME: value} each, the
        same for every trial and every call; each part drawn from a seed stream of its own."""
        if not self.vary:
            return [{}]
        n = {TRAINING: self.realisations, VALIDATION: self.validation, TEST: self.test}[part]
        seed = self.seed + STREAMS[part]
        return SweepSpec(self.scenario, self.vary, n, self.method, seed).samples_table() \
            if n else []

    def described(self, content: str, baseline: str = "") -> dict[str, Any]:
        """What identifies the study (everything but the number of trials and the batch)."""
        return {"scenario": self.scenario,
                "scenario_sha256": hashlib.sha256(content.encode()).hexdigest(),
                "params": {p.name: p.text for p in self.params},
                "objective": self.objective.text, "aggregate": self.aggregate,
                "constraints": [c.text for c in self.constraints],
                "vary": {v.name: v.text for v in self.vary}, "realisations": self.realisations,
                "method": self.method, "seed": self.seed, "metrics": list(self.metrics),
                "set": list(self.fixed), "baseline": self.baseline,
                "start": [dict(sorted(p.items())) for p in self.start],
                "baseline_sha256": hashlib.sha256(baseline.encode()).hexdigest()
                if self.baseline else None,
                **({"validation": self.validation, "validate_top": self.validate_top,
                    "test": self.test} if self.validation else {})}


@dataclass
class TuneOutcome:
    """What a tune did: every trial's row (earlier calls' included), the runs' rows, how many
    trials ran now, the best feasible trial's row (None if there is none), the folder."""

    trials: list[dict[str, Any]]
    runs: list[dict[str, Any]]
    ran: int
    folder: Path
    best: dict[str, Any] | None = None
    interrupted: bool = False
    baseline: list[dict[str, Any]] = field(default_factory=list)
    #: held-out parts (validation, test): trial -> (its row there, its runs); and the
    #: baseline's runs there
    held: dict[str, dict[int, tuple[dict[str, Any], list[dict[str, Any]]]]] = \
        field(default_factory=dict)
    held_baseline: dict[str, list[dict[str, Any]]] = field(default_factory=dict)

    def frame(self) -> Any:
        import pandas as pd

        return pd.DataFrame(self.trials)


def tune(spec: TuneSpec, out: str | Path, *, workers: int | None = 1,
         scheduler: str | None = None, batch: int | None = None, lockstep: bool = False,
         progress: bool = False
         ) -> TuneOutcome:
    """Run the study `spec` into folder `out` (see the module's docstring): `workers` 1 runs in
    this process; more (or None: one per core) on a local Dask cluster on 127.0.0.1, or the
    trusted cluster at `scheduler`. `batch`: trials asked and run together (default: the number
    of workers; give it to reproduce a study on another cluster); the next batch is asked (and
    on a cluster queued) while one runs, at fixed points of the study, or, `lockstep`, only once
    every trial before it is told (the proposals of the tunes before pipelining)."""
    from twmr.api import load

    spec.check()
    if batch is not None and (not isinstance(batch, int) or isinstance(batch, bool) or
                              batch < 1):
        raise TuneError(f"--batch {batch!r} is not a positive whole number. Fix: give e.g. "
                        f"--batch 2 (trials run together), or leave it out (the workers).")
    table = spec.table()
    scenario = load(spec.scenario, list(spec.fixed))
    check_names(scenario, [p.as_vary() for p in spec.params], "--param")
    check_names(scenario, spec.vary)
    bases = vector_bases(scenario, spec.vary)
    base_scenario = load(spec.baseline) if spec.baseline else None
    if base_scenario is not None:
        check_names(base_scenario, spec.vary, "--vary (in the baseline)")
    from twmr.registry import metric

    for name in spec.metrics:
        metric(name)
    content, base_content = _text(scenario), _text(base_scenario) if base_scenario else ""
    folder = Path(out).resolve()
    described = spec.described(content, base_content)
    lock = _open_folder(folder, described)
    journal: IO[str] | None = None
    client = cluster = bar = None
    done, done_runs, done_base, held, held_base = _read_journal(folder)
    outcome = TuneOutcome(done, done_runs, 0, folder, baseline=done_base, held=held,
                          held_baseline=held_base)
    warned = SweepWarnings(log, REALISATIONS)
    try:
        left = spec.trials - len(outcome.trials)
        if left > 0 or (base_scenario is not None and not outcome.baseline):
            if workers != 1 or scheduler:
                client, cluster = dask_client(workers, scheduler)
            journal = open_journal(folder / JOURNAL)
        if base_scenario is not None and not outcome.baseline:
            outcome.baseline = _run_baseline(spec, base_scenario, base_content, table, client)
            for r in outcome.baseline:
                warned.add(r["run_id"], r.get("warnings", []))
            assert journal is not None
            append_row(journal, {"baseline": outcome.baseline})
        base = {r["sample"]: {f"{BASE}{k}": v for k, v in r.items()
                              if isinstance(v, int | float) and not isinstance(v, bool)}
                for r in outcome.baseline}
        if batch is None:
            batch = _workers_of(client) if client is not None else 1
        study = _study(spec, outcome.trials)
        for point in spec.start[len(outcome.trials):]:
            study.enqueue_trial(point)
        dists = {p.name: p.distribution() for p in spec.params}
        # a worker's runs of the study, so its built system takes the loop compiled for it as
        # soon as they repay it (as a sweep's workers do)
        share = -(-left * len(table) // (_workers_of(client) if client is not None else 1))

        def record(trial: Any, row: dict[str, Any], runs: list[dict[str, Any]]) -> None:
            nonlocal bar
            _tell(study, trial, row)
            assert journal is not None  # opened when trials are left
            append_row(journal, {"trial": row, "runs": runs})
            outcome.trials.append(row)
            outcome.runs.extend(runs)
            for r in runs:
                warned.add(r["run_id"], r.get("warnings", []))
            outcome.ran += 1
            if progress and bar is None:  # after the first trial: its figures are checked
                from tqdm import tqdm

                bar = tqdm(total=spec.trials, initial=len(outcome.trials) - 1,
                           unit="trial", dynamic_ncols=True, desc="tune")
            if bar is not None:
                best = _best(outcome.trials)
                bar.set_postfix(best=f"{best['objective']:.4g}" if best else "-",
                                refresh=False)
                bar.update(1)

        # two batches in flight: the next one asked (and, on a cluster, queued) while one
        # runs, at fixed points — before the one running is told — so the order of asks and
        # tells, and with it every proposal, is the same in this process and on any cluster

        def launch() -> tuple[list[Any], _Launched, float]:
            nonlocal left
            asked = [study.ask(dists) for _ in range(min(batch, left))]
            left -= len(asked)
            tasks = _tasks(spec, scenario, content, bases, table, asked, share)
            return asked, _launch(tasks, client, f"trial{asked[0].number}"), time.perf_counter()

        flight = launch() if left > 0 else None
        while flight is not None:
            following = launch() if left > 0 and not lockstep else None
            asked, launched, t0 = flight
            every = _land(launched, client, f"trial{asked[0].number}")
            for trial, (row, runs) in zip(asked, _rows(
                    spec, table, asked, every, base, time.perf_counter() - t0), strict=True):
                record(trial, row, runs)
            flight = launch() if lockstep and left > 0 else following
        if spec.validation:
            if journal is None:
                journal = open_journal(folder / JOURNAL)
            if client is None and (workers != 1 or scheduler) and _unvalidated(spec, outcome):
                client, cluster = dask_client(workers, scheduler)
            _held_out(spec, scenario, content, bases, base_scenario, client, outcome, journal)
    except KeyboardInterrupt as stop:
        outcome.interrupted = True
        stop.partial_results = folder  # type: ignore[attr-defined]  # shown by the CLI
        raise
    finally:
        from twmr.master.execution import held_signals

        with held_signals():
            if bar is not None:
                bar.close()
            if journal is not None:
                journal.close()
            close_client(client, cluster, [])
            warned.close()
            outcome.best = _chosen(spec, outcome)
            _write(outcome, spec, scenario)
            release_lock(lock)
    return outcome


def _text(scenario: Any) -> str:
    """A scenario's text (an SSP's content as sorted JSON)."""
    return scenario.content if isinstance(scenario.content, str) else \
        json.dumps(scenario.content, sort_keys=True, default=str)


def _workers_of(client: Any) -> int:
    """How many workers the cluster has now (at least 1)."""
    return max(1, len(client.scheduler_info().get("workers", {})))


def _run_tasks(tasks: list[RunTask], client: Any, prefix: str) -> list[dict[str, Any]]:
    """The rows of `tasks` (in their order): in this process, or on the cluster all at once,
    one Dask task per worker (consecutive runs: a task costs a scheduling round trip); the
    runs of a batch lost with its worker (a crash inside an FMU) run again one by one, so only
    the run that crashes fails."""
    return _land(_launch(tasks, client, prefix), client, prefix)


@dataclass
class _Launched:
    """Runs sent to the cluster: the tasks, their batches and the batches' futures."""

    tasks: list[RunTask]
    batches: list[list[RunTask]]
    futures: list[Any]


def _launch(tasks: list[RunTask], client: Any, prefix: str) -> _Launched:
    """`tasks` sent to the cluster at once, one Dask task per worker (no cluster: kept, to run
    in this process when landed)."""
    if client is None:
        return _Launched(tasks, [], [])
    per = max(1, math.ceil(len(tasks) / _workers_of(client)))
    batches = [tasks[i:i + per] for i in range(0, len(tasks), per)]
    futures = client.map(execute_batch, batches, pure=False,
                         key=[f"{prefix}-{b[0].sample}-{b[0].run_id}-{len(b)}" for b in batches])
    return _Launched(tasks, batches, futures)


def _land(launched: _Launched, client: Any, prefix: str) -> list[dict[str, Any]]:
    """The rows of launched tasks (in their order), once they have run (`_run_tasks`)."""
    if client is None:
        return [execute(t) for t in launched.tasks]
    from dask.distributed import as_completed

    futures, batches = launched.futures, launched.batches
    rows: dict[int, dict[str, Any]] = {}
    alone: list[RunTask] = []
    done = Finished(as_completed(futures), client, futures)
    for future in done:
        settled(future)
    for future, batch in zip(futures, batches, strict=True):
        if future.status == "finished":
            rows.update(zip(map(id, batch), future.result(), strict=True))
        elif len(batch) > 1 and not future.cancelled() and not done.gave_up:
            alone += batch
        else:
            error = no_worker() if future.cancelled() else lost_error(future.exception())
            rows.update((id(t), failed_row(t, error)) for t in batch)
    if alone:
        again = client.map(execute, alone, pure=False,
                           key=[f"{prefix}-alone-{t.sample}-{t.run_id}" for t in alone])
        for future in Finished(as_completed(again), client, again):
            settled(future)
        rows.update((id(t), f.result() if f.status == "finished" else failed_row(
            t, no_worker() if f.cancelled() else lost_error(f.exception())))
            for f, t in zip(again, alone, strict=True))
    return [rows[id(t)] for t in launched.tasks]


def _run_baseline(spec: TuneSpec, scenario: Any, content: str, table: list[dict[str, Any]],
                  client: Any) -> list[dict[str, Any]]:
    """The baseline scenario over the realisations (once per study); TuneError if a run fails
    or lacks a figure the expressions use."""
    bases = vector_bases(scenario, spec.vary)
    tasks = [RunTask(run_id(values, []), i, values, overrides_of(values, spec.vary, bases),
                     scenario.source, content, str(scenario.base_dir), list(spec.metrics))
             for i, values in enumerate(table)]
    runs = _run_tasks(tasks, client, "baseline")
    failed = [r for r in runs if r["status"] != "ok"]
    if failed:
        raise TuneError(f"--baseline {spec.baseline}: realisation {failed[0]['sample']} failed: "
                        f"{failed[0]['error']}. Fix: give a baseline that runs in every "
                        f"realisation.")
    wanted = [n[len(BASE):] for n in spec.names() if n.startswith(BASE)]
    problem = unknown_names(wanted, runs[0], spec.metrics)
    if problem:
        raise TuneError(f"--baseline {spec.baseline}: {problem}")
    return runs


def _open_folder(folder: Path, described: dict[str, Any]) -> IO[str]:
    """Lock `folder` (created if needed) after checking it holds only this study's files."""
    if folder.is_symlink() or (folder.exists() and not folder.is_dir()):
        raise TuneError(f"{folder} is not a folder. Fix: give a new or empty folder as --out.")
    if folder.exists():
        foreign = sorted(e.name for e in folder.iterdir() if e.name not in _OURS and
                         not e.name.startswith("."))
        if foreign:
            raise TuneError(f"{folder} holds files that are not a tune's ({', '.join(foreign[:3])}"
                            f"); a tune would write among them. Fix: give a new or empty "
                            f"folder as --out.")
    folder.mkdir(parents=True, exist_ok=True)
    lock = take_lock(folder, "tune")
    try:
        path = folder / DESCRIPTION
        journal = folder / JOURNAL
        if path.exists() and journal.exists() and journal.stat().st_size > 0:
            try:
                before = json.loads(path.read_text(encoding="utf-8"))
            except ValueError:
                before = None
            if not isinstance(before, dict):
                raise TuneError(f"{path} is not a description written by `twmr tune`. Fix: give "
                                f"another --out.")
            for key, value in described.items():
                if before.get(key) != value:
                    raise TuneError(f"{folder} holds another study ({key}: {before.get(key)!r}, "
                                    f"now {value!r}); its trials would be mixed with these. "
                                    f"Fix: give another --out, or the same {key} as before.")
        partial = folder / f".{DESCRIPTION}.{os.getpid()}.tmp"
        partial.write_text(json.dumps(described, indent=2) + "\n")
        os.replace(partial, path)
    except BaseException:
        release_lock(lock)
        raise
    return lock


def _read_journal(folder: Path) -> tuple[list[dict[str, Any]], list[dict[str, Any]],
                                         list[dict[str, Any]], dict[str, Any], dict[str, Any]]:
    """The trials and runs already done (the journal's last line may be cut short by a kill),
    the baseline's runs, the held-out parts' rows and runs by trial, the baseline's runs
    there."""
    path = folder / JOURNAL
    trials: list[dict[str, Any]] = []
    runs: list[dict[str, Any]] = []
    baseline: list[dict[str, Any]] = []
    held: dict[str, Any] = {}
    held_base: dict[str, Any] = {}
    if not path.exists():
        return trials, runs, baseline, held, held_base
    lines = path.read_text(encoding="utf-8", errors="replace").split("\n")
    for number, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
            if "baseline" in entry:
                baseline = list(entry["baseline"])
                continue
            if "held_out" in entry:
                part = entry["held_out"]
                held.setdefault(part["part"], {})[int(part["trial"])] = (part["row"],
                                                                         part["runs"])
                continue
            if "held_out_baseline" in entry:
                part = entry["held_out_baseline"]
                held_base[part["part"]] = list(part["runs"])
                continue
            trial, trial_runs = entry["trial"], entry["runs"]
        except (ValueError, KeyError, TypeError):
            if number >= len(lines) - 1:
                continue
            raise TuneError(f"{path}:{number}: not a line written by `twmr tune`. Fix: give "
                            f"another --out.") from None
        trials.append(trial)
        runs.extend(trial_runs)
    return trials, runs, baseline, held, held_base


def _study(spec: TuneSpec, done: list[dict[str, Any]]) -> Any:
    """An Optuna study in memory holding the finished trials; its TPE sampler seeded from the
    seed and their number, so a resumed tune goes on reproducibly; the trials of a batch still
    running count as their worst finished trial's value (constant liar), so a batch spreads."""
    from twmr.core.extras import require

    optuna = require("optuna", "tuning")
    from optuna.trial import TrialState, create_trial

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with warnings.catch_warnings():  # constant_liar is "experimental"
        warnings.simplefilter("ignore")
        sampler = optuna.samplers.TPESampler(seed=spec.seed + len(done), constant_liar=True)
    study = optuna.create_study(direction="minimize", sampler=sampler)
    dists = {p.name: p.distribution() for p in spec.params}
    for row in done:
        ok = row["status"] != "failed" and math.isfinite(row["objective"])
        study.add_trial(create_trial(
            params={p.name: row[p.name] for p in spec.params}, distributions=dists,
            value=row["objective"] if ok else None,
            constraints=_constraints(row, len(spec.constraints)) if ok else None,
            state=TrialState.COMPLETE if ok else TrialState.FAIL))
    return study


def _evaluate(spec: TuneSpec, scenario: Any, content: str, bases: dict[str, Any],
              table: list[dict[str, Any]], trials: list[Any], client: Any,
              base: dict[int, dict[str, Any]]) -> list[tuple[dict[str, Any], list[dict[str, Any]]]]:
    """A batch of trials: the scenario with each one's parameters over every realisation, all
    the runs at once; each trial's row and its runs' rows (in realisation order)."""
    t0 = time.perf_counter()
    every = _run_tasks(_tasks(spec, scenario, content, bases, table, trials), client,
                       f"trial{trials[0].number}")
    return _rows(spec, table, trials, every, base, time.perf_counter() - t0)


def _tasks(spec: TuneSpec, scenario: Any, content: str, bases: dict[str, Any],
           table: list[dict[str, Any]], trials: list[Any], share: int = 0) -> list[RunTask]:
    """The runs of `trials`: each one's parameters over every realisation; `share`: the runs
    of the study a worker is expected to make (`RunTask.share`)."""
    tasks: list[RunTask] = []
    for trial in trials:
        params = {p.name: trial.params[p.name] for p in spec.params}
        fixed = [*spec.fixed, *(f"{k}={json.dumps(v)}" for k, v in params.items())]
        tasks += [RunTask(run_id(values, fixed), i, values,
                          [*fixed, *overrides_of(values, spec.vary, bases)], scenario.source,
                          content, str(scenario.base_dir), list(spec.metrics), share=share)
                  for i, values in enumerate(table)]
    return tasks


def _rows(spec: TuneSpec, table: list[dict[str, Any]], trials: list[Any],
          every: list[dict[str, Any]], base: dict[int, dict[str, Any]], wall: float
          ) -> list[tuple[dict[str, Any], list[dict[str, Any]]]]:
    """Each trial's row and its runs' rows, from the rows of all their runs in order."""
    n = len(table)
    return [_trial_row(spec, trial, every[j * n:(j + 1) * n], base, wall)
            for j, trial in enumerate(trials)]


def _trial_row(spec: TuneSpec, trial: Any, runs: list[dict[str, Any]],
               base: dict[int, dict[str, Any]], wall: float
               ) -> tuple[dict[str, Any], list[dict[str, Any]]]:
    """A trial's row from its runs (the baseline's figures of each realisation beside them)."""
    params = {p.name: trial.params[p.name] for p in spec.params}
    ok = [r for r in runs if r["status"] == "ok"]
    names = spec.names()
    for r in ok:
        problem = unknown_names(names, {**r, **base.get(r["sample"], {})}, spec.metrics)
        if problem:
            raise TuneError(f"--objective/--constraint: {problem}")
    for r in runs:
        r["trial"] = trial.number
        r["value"] = spec.objective.value({**r, **base.get(r["sample"], {})}) \
            if r["status"] == "ok" else math.nan
    values = np.array([r["value"] for r in runs])
    row: dict[str, Any] = {"trial": trial.number, **params, "objective": math.nan,
                           "spread": math.nan, "status": "failed", "runs_ok": len(ok),
                           "error": next((r["error"] for r in runs if r["status"] != "ok"), "")}
    if len(ok) == len(runs) and np.all(np.isfinite(values)):
        row["objective"] = aggregate(values, spec.aggregate)
        row["spread"] = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
        row["status"] = "ok"
    elif len(ok) == len(runs):
        row["error"] = f"the objective is not a finite number in {np.sum(~np.isfinite(values))} " \
                       f"realisation(s)"
    for i, c in enumerate(spec.constraints):
        held = np.array([c.expression.value({**r, **base.get(r["sample"], {})}) for r in ok]) \
            if ok else np.array([math.inf])
        row[f"violation_{i}"] = c.violation(held) if np.all(np.isfinite(held)) else math.inf
        if row["status"] == "ok" and row[f"violation_{i}"] > 0:
            row["status"] = "infeasible"
    row["wall_time_s"] = wall
    return row, runs


def _tell(study: Any, trial: Any, row: dict[str, Any]) -> None:
    from optuna.trial import TrialState

    if row["status"] == "failed":
        study.tell(trial, state=TrialState.FAIL)
        return
    n = sum(1 for key in row if key.startswith("violation_"))
    for name, value in _constraints(row, n).items():
        trial.set_constraint(name, value)
    study.tell(trial, row["objective"])


def _constraints(row: dict[str, Any], n: int) -> dict[str, float]:
    """A trial's constraint values for Optuna (<= 0: held)."""
    return {f"violation_{i}": float(row[f"violation_{i}"]) for i in range(n)}


def _ranked(spec: TuneSpec, outcome: TuneOutcome) -> list[dict[str, Any]]:
    """The `validate_top` feasible trials of the lowest training objective (first of equals)."""
    ok = [t for t in outcome.trials if t["status"] == "ok"]
    return sorted(ok, key=lambda t: (t["objective"], t["trial"]))[:spec.validate_top]


def _unvalidated(spec: TuneSpec, outcome: TuneOutcome) -> bool:
    """Whether a held-out run is still to be made."""
    done = outcome.held.get(VALIDATION, {})
    if any(t["trial"] not in done for t in _ranked(spec, outcome)):
        return True
    chosen = _chosen(spec, outcome)
    return bool(spec.test and chosen is not None and
                chosen["trial"] not in outcome.held.get(TEST, {}))


def _held_out(spec: TuneSpec, scenario: Any, content: str, bases: dict[str, Any],
              base_scenario: Any, client: Any, outcome: TuneOutcome, journal: IO[str]) -> None:
    """The best trials by training objective on the validation realisations (the ones not yet
    run there), then the one chosen there on the test realisations; journalled as they end."""
    from types import SimpleNamespace

    for part in (VALIDATION, TEST):
        if part == TEST:
            chosen = _chosen(spec, outcome)
            wanted = [chosen] if spec.test and chosen is not None else []
        else:
            wanted = _ranked(spec, outcome)
        done = outcome.held.setdefault(part, {})
        todo = [t for t in wanted if t["trial"] not in done]
        if not todo:
            continue
        table = spec.table(part)
        if base_scenario is not None and part not in outcome.held_baseline:
            runs = _run_baseline(spec, base_scenario, _text(base_scenario), table, client)
            outcome.held_baseline[part] = runs
            append_row(journal, {"held_out_baseline": {"part": part, "runs": runs}})
        base = {r["sample"]: {f"{BASE}{k}": v for k, v in r.items()
                              if isinstance(v, int | float) and not isinstance(v, bool)}
                for r in outcome.held_baseline.get(part, [])}
        trials = [SimpleNamespace(number=t["trial"], params={p.name: t[p.name]
                                                             for p in spec.params})
                  for t in todo]
        for trial, (row, runs) in zip(trials, _evaluate(spec, scenario, content, bases, table,
                                                         trials, client, base), strict=True):
            for r in runs:
                r["part"] = part
            done[trial.number] = (row, runs)
            append_row(journal, {"held_out": {"part": part, "trial": trial.number, "row": row,
                                              "runs": runs}})


def _chosen(spec: TuneSpec, outcome: TuneOutcome) -> dict[str, Any] | None:
    """The best trial: by training objective, or — with validation realisations — by its
    objective on them among those validated that hold every constraint there too; its row
    carries its figures on the held-out parts (`validation_objective`, `gap`, `test_...`)."""
    if not spec.validation:
        return _best(outcome.trials)
    by_number = {t["trial"]: t for t in outcome.trials}
    validated = outcome.held.get(VALIDATION, {})
    ok = [(row["objective"], n) for n, (row, _) in validated.items()
          if row["status"] == "ok" and n in by_number]
    if not ok:
        return None
    number = min(ok)[1]
    return {**by_number[number], **_held_figures(outcome, number)}


def _held_figures(outcome: TuneOutcome, number: int) -> dict[str, Any]:
    """A trial's figures on the held-out parts it ran on."""
    out: dict[str, Any] = {}
    for part, rows in outcome.held.items():
        if number in rows:
            row = rows[number][0]
            out[f"{part}_objective"] = row["objective"]
            out[f"{part}_spread"] = row["spread"]
            out[f"{part}_status"] = row["status"]
    if "validation_objective" in out:
        train = next(t["objective"] for t in outcome.trials if t["trial"] == number)
        out["gap"] = out["validation_objective"] - train
    return out


def _best(trials: list[dict[str, Any]]) -> dict[str, Any] | None:
    """The feasible trial of the lowest objective (the first of equals)."""
    ok = [t for t in trials if t["status"] == "ok"]
    return min(ok, key=lambda t: t["objective"]) if ok else None


def _write(outcome: TuneOutcome, spec: TuneSpec, scenario: Any) -> None:
    """trials.parquet, realisations.parquet (written whole, then renamed) and best.yaml."""
    import pandas as pd

    folder = outcome.folder
    trials = [{**t, **_held_figures(outcome, t["trial"])} for t in outcome.trials]
    held_runs = [r for part in outcome.held.values() for _, runs in part.values() for r in runs]
    for rows, name in ((trials, TRIALS), (outcome.runs, REALISATIONS),
                       (outcome.baseline, BASELINE), (held_runs, VALIDATION_RUNS)):
        if not rows:
            continue
        partial = folder / f".{name}.{os.getpid()}.part"
        pd.DataFrame(rows).to_parquet(partial, index=False)
        os.replace(partial, folder / name)
    if outcome.best is not None:
        text = best_yaml(scenario, spec, outcome.best)
        if text is not None:
            partial = folder / f".{BEST}.{os.getpid()}.tmp"
            partial.write_text(text, encoding="utf-8")
            os.replace(partial, folder / BEST)


def best_yaml(scenario: Any, spec: TuneSpec, best: dict[str, Any]) -> str | None:
    """The scenario's YAML with the best trial's parameters (and the --set overrides) set; None
    for a scenario that is no YAML text (an SSP)."""
    from twmr.scenario.written import yaml_with

    held = "".join(f", on {spec.validation if part == VALIDATION else spec.test} {part} "
                   f"realisation(s) {best[f'{part}_objective']:.6g}"
                   for part in (VALIDATION, TEST) if f"{part}_objective" in best)
    head = (f"# {scenario.source} tuned by `twmr tune`: trial {best['trial']}, {spec.aggregate} "
            f"of {spec.objective.text} over {spec.realisations} realisation(s) = "
            f"{best['objective']:.6g} (spread {best['spread']:.3g}){held}\n"
            f"# relative paths in it are relative to {scenario.base_dir}\n")
    settings: list[str | tuple[str, Any]] = [*spec.fixed]
    settings += [(p.name, best[p.name]) for p in spec.params]
    return yaml_with(scenario, settings, head)
