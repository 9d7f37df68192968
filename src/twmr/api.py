"""The Python entry points, re-exported by `twmr`: `load`, `simulate`, `read_result`.

    import twmr
    scenario = twmr.load("scenarios/paper_trajectory1_asmc.yaml", ["ctrl.k=20",
                                                                   "experiment.stop=5"])
    result = twmr.simulate(scenario, out="results/k20")      # or out=None: kept in memory
    df = result.to_pandas()

A run with a folder writes into a new folder beside it (`<out>.partial-<pid>`) and only replaces
`out` when it completes, so a failed or killed re-run never destroys the previous result: a failed
run's partial results go to `<out>.incomplete`, a killed run's stay in `<out>.partial-<pid>`, and
`read_result` reads either.
"""
from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

from twmr.core.errors import CosimError, Location, Problem, ScenarioError
from twmr.observers.base import Observer
from twmr.result import Result, read_result
from twmr.scenario.system import System

__all__ = ["Scenario", "load", "simulate", "read_result", "Result"]


@dataclass
class Scenario:
    """A checked scenario: where it came from and its built `System`. Each `simulate` runs a
    freshly built system, so simulating the same scenario twice gives identical results."""

    source: str
    content: str | dict[str, Any]
    base_dir: Path
    overrides: tuple[str, ...] = ()
    _system: System | None = field(default=None, repr=False)

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
        from twmr.scenario.build import loads

        return loads(self.content, self.source, self.base_dir, self.overrides)

    @property
    def name(self) -> str:
        """The scenario's file stem ('scenario' when it was given as text or a dict)."""
        stem = Path(self.source).stem if not self.source.startswith("<") else "scenario"
        return stem or "scenario"


def load(source: str | Path | dict[str, Any], overrides: Sequence[str] = ()) -> Scenario:
    """A scenario from a YAML file path, a YAML string or a dict, with `comp.name=value`
    overrides (also `experiment.stop|step|start|algorithm|realtime=...` and
    `comp.step_multiple=m`). Raises `ScenarioError` listing every problem found."""
    if isinstance(source, dict):
        scenario = Scenario("<dict>", source, Path.cwd(), tuple(overrides))
    elif isinstance(source, Path) or ("\n" not in source and (
            Path(source).suffix.lower() in (".yaml", ".yml") or Path(source).exists())):
        path = Path(source)
        try:
            text = path.read_text()
        except (OSError, UnicodeDecodeError) as err:
            why = getattr(err, "strerror", None) or err
            raise ScenarioError(Problem(Location(str(path)), f"cannot read the scenario: {why}.",
                                        "give the path of a readable YAML file (UTF-8), a YAML "
                                        "string or a dict.")) from None
        scenario = Scenario(str(path), text, path.resolve().parent, tuple(overrides))
    else:
        scenario = Scenario("<string>", source, Path.cwd(), tuple(overrides))
    scenario.system  # noqa: B018 - build now: every problem is reported at load
    return scenario


def simulate(scenario: Scenario | str | Path | dict[str, Any], out: str | Path | None = None,
             *, formats: Sequence[str] = (), observers: Sequence[Observer] = (),
             metrics: Sequence[str] = (), progress: bool = False,
             header: dict[str, Any] | None = None) -> Result:
    """Run a scenario to its stop time and return its `Result`.

    `out`: the run's folder (crash-consistent `result.arrows`, `summary.json`, the asked export
    `formats` of 'csv' / 'mat' / 'parquet'); None keeps the rows in memory. `metrics` names
    registered metric functions (e.g. 'tracking') whose figures go into `summary['metrics']`.
    Raises a `CosimError` (or `KeyboardInterrupt`) after every component is terminated; the
    results so far are in `<out>.incomplete` (see the module's docstring)."""
    from twmr.master.execution import Execution
    from twmr.observers.store import ResultStore
    from twmr.observers.summary import SignalSummary

    if not isinstance(scenario, Scenario):
        scenario = load(scenario)
    metric_fns = _metric_functions(metrics)
    system = scenario.fresh_system()
    store = ResultStore()
    summary = SignalSummary({"scenario": scenario.source, "overrides": list(scenario.overrides),
                             "algorithm": system.experiment.algorithm,
                             "start": system.experiment.start, "stop": system.experiment.stop,
                             "step": system.experiment.step, **(header or {})})
    extra: list[Observer] = []
    if progress:
        from twmr.observers.progress import ProgressBar

        extra.append(ProgressBar())
    if out is None:
        ex = Execution(system, [store, summary, *extra, *observers])
        ex.run()
        result = Result(ex.columns, ex.units, store.data(), summary.document)
        _add_metrics(result, metric_fns, None)
        return result
    from twmr.observers.pacing import PacingReport

    final = Path(out)
    stage = _stage(final)
    ex = Execution(system, [store, summary, PacingReport(), *extra, *observers], stage)
    error: BaseException | None = None
    try:
        ex.run()
    except BaseException as exc:  # noqa: BLE001 - the folder is settled, then it is raised
        error = exc
    folder = _settle(stage, final, error is None)
    result = _finish_folder(folder, tuple(formats), metric_fns)
    if error is not None:
        error.partial_results = folder  # type: ignore[attr-defined]
        raise error
    return result


def _stage(final: Path) -> Path:
    """A new folder beside `final` for this run."""
    final = final.absolute()
    if final.exists() and not final.is_dir():
        raise CosimError(f"{final} exists and is not a folder. Fix: choose another --out.")
    final.parent.mkdir(parents=True, exist_ok=True)
    stage = final.with_name(f"{final.name}.partial-{os.getpid()}")
    if stage.exists():
        shutil.rmtree(stage)
    stage.mkdir()
    return stage


def _settle(stage: Path, final: Path, completed: bool) -> Path:
    """Completed: `stage` replaces `final`. Otherwise it becomes `<final>.incomplete`."""
    target = final.absolute() if completed else final.absolute().with_name(f"{final.name}.incomplete")
    old = target.with_name(f"{target.name}.old-{os.getpid()}")
    if target.exists():
        target.rename(old)
    stage.rename(target)
    if old.exists():
        shutil.rmtree(old, ignore_errors=True)
    return target


def _finish_folder(folder: Path, formats: tuple[str, ...],
                   metric_fns: dict[str, Callable[[Result], dict[str, Any]]]) -> Result:
    from twmr.observers.writers import export

    result = read_result(folder)
    if formats and len(result):
        export(result.columns, [result.units[c] for c in result.columns], result.values, folder,
               formats)
    _add_metrics(result, metric_fns, folder)
    return result


def _metric_functions(names: Sequence[str]) -> dict[str, Callable[[Result], dict[str, Any]]]:
    from twmr.registry import metric

    return {name: metric(name) for name in names}


def _add_metrics(result: Result, fns: dict[str, Callable[[Result], dict[str, Any]]],
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
