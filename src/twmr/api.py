"""The Python entry points, re-exported by `twmr`: `load`, `simulate`, `read_result`.

    import twmr
    scenario = twmr.load("scenarios/paper_trajectory1_asmc.yaml", ["ctrl.k=20",
                                                                   "experiment.stop=5"])
    result = twmr.simulate(scenario, out="results/k20")      # or out=None: kept in memory
    df = result.to_pandas()

A run with a folder writes into a new folder beside it (`<out>.partial-<pid>-<random>`, a name no
other run uses) and only replaces `out` when it completes, so a failed or killed re-run never
destroys the previous result: a failed run's partial results go to `<out>.incomplete`, a killed
run's stay in `<out>.partial-<pid>-<random>` (never removed by a later run), and `read_result`
reads either.
"""
from __future__ import annotations

import contextlib
import dataclasses
import logging
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from twmr.core.errors import CosimError
from twmr.core.run import Options
from twmr.metricset import MetricSet
from twmr.observers.base import Observer
from twmr.result import Result, read_result
from twmr.scenario.structure import ScenarioSpec
from twmr.scenario.system import System

if TYPE_CHECKING:
    from twmr.master.gate import Gate

__all__ = ["Result", "Scenario", "build", "load", "read_result", "simulate", "sweep", "tune"]
log = logging.getLogger("twmr.run")


@dataclass
class Scenario:
    """A checked scenario: where it came from and its built `System`. Each `simulate` runs a
    freshly built system, so simulating the same scenario twice gives identical results."""

    source: str
    content: str | dict[str, Any] | ScenarioSpec
    base_dir: Path
    overrides: tuple[str, ...] = ()
    _system: System | None = field(default=None, repr=False)
    _spec: ScenarioSpec | None = field(default=None, repr=False)

    @property
    def spec(self) -> ScenarioSpec:
        """The scenario's structure (`twmr.scenario.structure`), with the overrides applied."""
        if self._spec is None:
            from twmr.scenario.build import scenario_spec

            self._spec = scenario_spec(self.content, self.source, self.base_dir, self.overrides)
        return self._spec

    @property
    def system(self) -> System:
        """The built system (built now if a run has used the previous one)."""
        if self._system is None:
            self._system = self._build()
        return self._system

    def fresh_system(self) -> System:
        """A system no run has touched; the one built at load is handed out once."""
        system = self.system
        self._system = None
        return system

    def _build(self) -> System:
        from twmr.scenario.build import build_system

        return build_system(self.spec)

    @property
    def name(self) -> str:
        """The scenario's file stem ('scenario' when it was given as text or a dict)."""
        stem = Path(self.source).stem if not self.source.startswith("<") else "scenario"
        return stem or "scenario"


def load(source: str | Path | dict[str, Any] | ScenarioSpec | Scenario,
         overrides: Sequence[str] = ()) -> Scenario:
    """A scenario from a YAML file path, a YAML string, a dict or a `ScenarioSpec` (the typed
    structure, `twmr.scenario.structure`), with `comp.name=value` overrides (also
    `experiment.stop|step|start|algorithm|realtime=...` and `comp.step_multiple=m`); a loaded
    `Scenario` as it is, or with more overrides. Raises `ScenarioError` listing every problem
    found."""
    from twmr.scenario.loaders import load_yaml, loader_of

    if isinstance(source, Scenario):
        if not overrides:
            return source
        scenario = Scenario(source.source, source.content, source.base_dir,
                            (*source.overrides, *overrides))
    elif isinstance(source, ScenarioSpec):
        scenario = Scenario(source.source, source, source.base_dir, tuple(overrides))
    elif isinstance(source, dict):
        scenario = Scenario("<dict>", source, Path.cwd(), tuple(overrides))
    elif isinstance(source, Path) or ("\n" not in source and (
            loader_of(source) is not None or Path(source).exists())):
        path = Path(source)
        loader = loader_of(path) or load_yaml
        if loader is load_yaml:  # its text is the scenario's content (sweeps identify by it)
            from twmr.scenario.yamlread import read_file

            text = read_file(path)
            scenario = Scenario(str(path), text, path.resolve().parent, tuple(overrides))
        else:
            from twmr.scenario.build import guarded

            spec = guarded(str(path), lambda: loader(path))
            scenario = Scenario(str(path), spec, spec.base_dir, tuple(overrides))
    else:
        scenario = Scenario("<string>", source, Path.cwd(), tuple(overrides))
    scenario.system  # noqa: B018 - build now: every problem is reported at load
    return scenario


def build(scenario: Scenario | str | Path | dict[str, Any], overrides: Sequence[str] = ()
          ) -> Any:
    """The scenario built once, to run again with other values without reading or building it
    anew: `twmr.build(path).run({"ctrl.k": 20})` (a `twmr.built.Built`; its rows are those of
    `simulate(load(path, ["ctrl.k=20"]))`)."""
    from twmr.built import build as build_once

    return build_once(scenario, overrides)


def simulate(scenario: Scenario | str | Path | dict[str, Any], out: str | Path | None = None,
             *, formats: Sequence[str] = (), observers: Sequence[Observer] = (),
             metrics: Sequence[str] = (), progress: bool = False,
             header: dict[str, Any] | None = None, live: str | None = None,
             compiled: str | None = None, options: Options | None = None,
             gate: Gate | None = None) -> Result:
    """Run a scenario to its stop time and return its `Result`.

    `out`: the run's folder (crash-consistent `result.arrows`, `summary.json`, the asked export
    `formats` of 'csv' / 'mat' / 'parquet'); None keeps the rows in memory. `metrics` names
    registered metric functions (e.g. 'tracking') whose figures go into `summary['metrics']`.
    `live`: '[HOST:]PORT' of a live view of the run in the browser (`docs/live.md`; its URL is
    logged), closed when the run ends. `options`: how the run goes (`twmr.Options`: the compiled
    loop, time per block, every FMU message); `compiled`: 'auto' | 'on' | 'off' sets
    `options.compiled` (docs/components.md; None: `TWMR_COMPILED`, default 'auto'). `gate`
    pauses, steps and stops the run from another thread (`twmr.master.gate`; `twmr.Stepping`
    drives one); a stopped run's result has status 'stopped'.
    Raises a `CosimError` (or `KeyboardInterrupt`) after every component is terminated; the
    results so far are in `<out>.incomplete` (see the module's docstring)."""
    from twmr.master.algorithm import algorithm_for
    from twmr.master.execution import Execution, held_signals
    from twmr.observers.store import ResultStore
    from twmr.observers.summary import SignalSummary

    if not isinstance(scenario, Scenario):
        scenario = load(scenario)
    metric_fns = _metric_functions(metrics)
    system = scenario.fresh_system()
    _check_metrics(metric_fns, system)
    options = options or Options()
    if compiled is not None:
        options = dataclasses.replace(options, compiled=compiled)
    algorithm = algorithm_for(system, options.compiled)
    store = ResultStore()
    summary = SignalSummary({"scenario": scenario.source, "overrides": list(scenario.overrides),
                             "algorithm": system.experiment.algorithm,
                             "start": system.experiment.start, "stop": system.experiment.stop,
                             "step": system.experiment.step,
                             **({"events": [m.plain() for m in system.events]}
                                if system.events else {}), **(header or {})})
    extra: list[Observer] = []
    if progress:
        from twmr.observers.progress import ProgressBar

        extra.append(ProgressBar())
    if live is not None:
        from twmr.master.gate import Gate
        from twmr.observers.live import LiveView

        gate = gate or Gate()
        extra.append(LiveView(live, gate=gate))
    if out is None:
        ex = Execution(system, [store, summary, *extra, *observers], algorithm=algorithm,
                       options=options, gate=gate)
        ex.run()
        result = Result(ex.columns, ex.units, store.data(), summary.document,
                        ticks=store.tick_table())
        _add_metrics(result, metric_fns, None)
        return result
    from twmr.observers.pacing import PacingReport

    final = Path(out)
    lock = _lock_folder(final)
    try:
        stage = _stage(final)
        ex = Execution(system, [store, summary, PacingReport(), *extra, *observers], stage,
                       algorithm=algorithm, options=options, gate=gate)
        error: BaseException | None = None
        try:
            ex.run()
        except BaseException as exc:  # noqa: BLE001 - the folder is settled, then it is raised
            error = exc
        with held_signals():  # a second Ctrl-C must not cut the saving short
            folder = _settle(stage, final, error is None)
            result = _finish_folder(folder, tuple(formats), metric_fns)
    finally:
        _unlock_folder(lock)
    if error is not None:
        error.partial_results = folder  # type: ignore[attr-defined]
        raise error
    return result


#: what a folder `simulate` may replace holds only these (a previous run's results)
_RESULT_FILES = ("result.arrows", "summary.json")


def _lock_folder(final: Path) -> Any:
    """Hold `.<out>.lock` beside the results folder for the run (`flock`, let go by the kernel
    when the process dies); CosimError naming the holder when another run holds it, since the
    second result would silently replace the first."""
    import fcntl
    import json
    import socket

    path = final.absolute().with_name(f".{final.name}.lock")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        lock = open(path, "a+", encoding="utf-8")  # noqa: SIM115 - closed by the caller
    except OSError as err:
        raise CosimError(f"cannot create {path} ({err.strerror or err}). Fix: give a results "
                         f"folder you can write.") from None
    try:
        fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.seek(0)
        holder = lock.read().strip() or "a process"
        lock.close()
        raise CosimError(f"the results folder '{final}' is in use by another run ({holder}); "
                         f"its result would replace this one's. Fix: wait for it to end, or "
                         f"give another --out.") from None
    lock.seek(0)
    lock.truncate(0)
    lock.write(json.dumps({"pid": os.getpid(), "host": socket.gethostname()}) + "\n")
    lock.flush()
    return lock


def _unlock_folder(lock: Any) -> None:
    """Let go of `_lock_folder`'s lock, its file removed (nothing of it stays beside the
    results; one a killed run left is taken over by the next)."""
    with contextlib.suppress(OSError):
        os.unlink(lock.name)
    lock.close()


def _stage(final: Path) -> Path:
    """A new folder beside `final` for this run, after checking that `final` may be replaced:
    it does not exist, is empty, or holds a previous run's results; it is no symbolic link and
    neither the working folder nor one of its parents."""
    where = f"the results folder '{final}'"
    try:
        if final.is_symlink():
            raise CosimError(f"{where} is a symbolic link; results are never written through "
                             f"one. Fix: give the real folder it points to, or another --out.")
        final = final.absolute()
        cwd = Path.cwd().resolve()
        if final.resolve() == cwd or final.resolve() in cwd.parents or \
                final.name in ("", ".", ".."):
            raise CosimError(f"{where} is the working folder or one of its parents, which a "
                             f"run would replace. Fix: give a folder of its own, e.g. --out "
                             f"results/run1.")
        if final.exists():
            if not final.is_dir():
                raise CosimError(f"{where} exists and is not a folder. Fix: choose another "
                                 f"--out.")
            entries = list(final.iterdir())
            if entries and not any((final / f).is_file() for f in _RESULT_FILES):
                raise CosimError(f"{where} holds files that are not a twmr result ("
                                 f"{', '.join(e.name for e in entries[:3])}...), which a run "
                                 f"would replace. Fix: give an empty or a new folder.")
        final.parent.mkdir(parents=True, exist_ok=True)
        stage = _unique(final, "partial")
        stage.mkdir()
    except CosimError:
        raise
    except OSError as err:
        raise CosimError(f"cannot create {where} ({err.strerror or err}). Fix: give a folder "
                         f"you can write, with a shorter name, whose parents are folders."
                         ) from None
    return stage


def _unique(final: Path, what: str) -> Path:
    """`<final>.<what>-<pid>-<random>`: a sibling no other run names, even one with this
    process id (ids are reused, inside containers at once), so none is ever overwritten."""
    import secrets

    return final.with_name(f"{final.name}.{what}-{os.getpid()}-{secrets.token_hex(4)}")


def _settle(stage: Path, final: Path, completed: bool) -> Path:
    """Completed: `stage` replaces `final`. Otherwise it becomes `<final>.incomplete`. If the
    rename fails, the results stay in `stage`, which is returned."""
    final = final.absolute()
    target = final if completed else final.with_name(f"{final.name}.incomplete")
    old = _unique(target, "old")
    try:
        if target.is_symlink() or target.is_file():
            target.unlink()
        elif target.exists():
            target.rename(old)
        stage.rename(target)
    except OSError as err:
        log.warning("could not move the results to %s (%s); they are in %s", target, err, stage)
        return stage
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)
    return target


def _finish_folder(folder: Path, formats: tuple[str, ...],
                   metric_fns: dict[str, MetricSet]) -> Result:
    from twmr.observers.writers import export

    result = read_result(folder)
    if formats and len(result):
        export(result.columns, [result.units[c] for c in result.columns], result.values, folder,
               formats, result.ticks)
    _add_metrics(result, metric_fns, folder)
    return result


def _metric_functions(names: Sequence[str]) -> dict[str, MetricSet]:
    from twmr.metricset import metric_set
    from twmr.registry import metric

    return {name: metric_set(metric(name)) for name in names}


def _check_metrics(fns: dict[str, MetricSet], system: System) -> None:
    """Refuse, before running, a metric set whose `needs(columns)` names what is missing."""
    from twmr.master.execution import columns_of

    if not fns:
        return
    columns = columns_of(system, system.record.signals)[0]
    for name, fn in fns.items():
        missing = fn.needs(columns)
        if missing:
            raise CosimError(f"the metric set '{name}' {missing}, which this scenario does not "
                             f"record. Fix: record them, or leave it out.")


def _add_metrics(result: Result, fns: dict[str, MetricSet],
                 folder: Path | None) -> None:
    if not fns or not len(result):
        return
    figures: dict[str, Any] = {}
    for fn in fns.values():
        figures.update(fn(result))
    result.summary["metrics"] = figures
    if folder is not None:
        from twmr.observers.summary import FILENAME, write_summary

        write_summary(result.summary, folder / FILENAME)


def sweep(scenario: str | Path, vary: dict[str, str] | Sequence[str], *, samples: int = 20,
          method: str = "random", seed: int = 0, out: str | Path | None = None,
          workers: int | None = None, scheduler: str | None = None,
          metrics: Sequence[str] = (), overrides: Sequence[str] = (),
          keep_signals: bool = False, dashboard: bool = False, progress: bool = False) -> Any:
    """Run `scenario` once per sample of `vary` ({NAME: SPEC} or ['NAME=SPEC', ...]; SPEC
    uniform:LO:HI, normal:MU:SIGMA, values:A,B,C or grid:LO:HI:N) on Dask: `workers` local
    worker processes on 127.0.0.1 (default: the cores; `dashboard`: with Dask's dashboard on
    127.0.0.1) or the cluster at `scheduler` (a cluster you trust: it runs code in this
    process; see docs/security.md). Rows go to
    `out/runs.parquet` (default sweeps/<scenario name>); runs already there are skipped.
    Returns a `twmr.sweeps.SweepOutcome` (`.frame()` is the table as a DataFrame).

    Local workers are processes started by `multiprocessing`'s spawn: a script that calls this
    needs the usual `if __name__ == "__main__":` guard."""
    from twmr.sweeps import spec_from
    from twmr.sweeps import sweep as run_sweep
    from twmr.sweeps.engine import refuse_unguarded_workers

    if scheduler is None:
        refuse_unguarded_workers()
    texts = [f"{k}={v}" for k, v in vary.items()] if isinstance(vary, dict) else list(vary)
    spec = spec_from(str(scenario), texts, samples=samples, method=method, seed=seed,
                     metrics=list(metrics), fixed=list(overrides))
    folder = Path(out) if out is not None else Path("sweeps") / (Path(str(scenario)).stem or
                                                                   "scenario")
    return run_sweep(spec, folder, workers=workers, scheduler=scheduler,
                     keep_signals=keep_signals, dashboard=dashboard, progress=progress)


def tune(scenario: str | Path, params: dict[str, str] | Sequence[str], objective: str, *,
         vary: dict[str, str] | Sequence[str] = (), realisations: int = 1, trials: int = 30,
         seed: int = 0, aggregate: str = "mean", constraints: Sequence[str] = (),
         metrics: Sequence[str] = (), overrides: Sequence[str] = (),
         method: str = "random", out: str | Path | None = None, workers: int | None = 1,
         scheduler: str | None = None, batch: int | None = None, lockstep: bool = False,
         baseline: str | Path | None = None, start: Sequence[dict[str, Any]] = (),
         validation: int = 0, validate_top: int = 5, test: int = 0,
         report: bool = True, progress: bool = False) -> Any:
    """Tune `params` ({NAME: SPEC} or ['NAME=SPEC', ...]; SPEC LO:HI, log:LO:HI, int:LO:HI or
    values:A,B,C) of `scenario` to minimise `aggregate` (mean, median, max, qP) of the metric
    expression `objective` over `realisations` runs drawn once from `vary` and `seed` (the same for
    every trial), subject to `constraints` ('EXPR<=BOUND' in every realisation), in `trials` Optuna
    TPE trials in all (a folder holding fewer continues), asked `batch` at a time (default: the
    workers), the next batch asked while one runs (`lockstep`: only once the one before is told, as
    tunes did before; slower on a cluster). `workers` 1 runs in this process; more on local Dask
    workers on 127.0.0.1. `baseline`: a scenario run once over the same realisations, its figures
    named `base_<figure>` in `objective` and `constraints`. `start`: points ({NAME: value} of every
    param) tried first, in order, before the sampler proposes. `validation`: realisations drawn
    apart (never optimised on) on which the `validate_top` best trials by training objective run,
    the best chosen there; `test`: further ones the chosen trial runs on (reported only); the
    trials' rows then carry `validation_objective`, `gap` and `test_objective`. Writes `out`
    (default tunes/<scenario name>): trials.parquet, realisations.parquet, baseline.parquet,
    best.yaml, report/. Returns a `twmr.tuning.TuneOutcome`."""
    from twmr.sweeps import parse_vary
    from twmr.tuning import Expression, TuneSpec, parse_constraint, parse_param
    from twmr.tuning import tune as run_tune
    from twmr.tuning.report import tune_report

    def texts(given: dict[str, str] | Sequence[str]) -> list[str]:
        return [f"{k}={v}" for k, v in given.items()] if isinstance(given, dict) else list(given)

    goal, limits = Expression(objective), [parse_constraint(c) for c in constraints]
    if not metrics:
        from twmr.registry import sets_giving

        metrics = sets_giving(goal.names + [n for c in limits for n in c.expression.names])
    spec = TuneSpec(str(scenario), [parse_param(t) for t in texts(params)],
                    goal, [parse_vary(t) for t in texts(vary)], realisations,
                    trials, seed, aggregate, limits,
                    list(metrics), list(overrides), method,
                    str(baseline) if baseline is not None else None,
                    [dict(p) for p in start], validation, validate_top, test)
    folder = Path(out) if out is not None else Path("tunes") / (Path(str(scenario)).stem or
                                                                  "scenario")
    outcome = run_tune(spec, folder, workers=workers, scheduler=scheduler, batch=batch,
                       lockstep=lockstep, progress=progress)
    if report and outcome.trials:
        tune_report(outcome.folder)
    return outcome
