"""Fitting a scenario to measured data (`twmr fit`, `twmr.fit`): the values of chosen
parameters and initial states (`Estimate`) that make chosen signals of runs match measured ones,
over one or more experiments (each its data and its own overrides), by scipy's `least_squares`
(trust region reflective within the bounds) on the reruns of a built system (`twmr.build`);
with a global start, local fits from several points of a Latin hypercube over the bounds (on a
Dask cluster, one task each), the lowest cost kept.

Residuals: (model - data) / sigma at the data's times, the model linear between its recorded
points; sigma per signal (the measurement's standard deviation [signal's unit]; default: that of
the data column, so each signal weighs alike). Reported: the estimates, their standard errors
and 95 % confidence intervals from the Jacobian at the optimum (covariance s^2 (J^T J)^-1, s^2
the residuals' mean square over the degrees of freedom, as `scipy.optimize.curve_fit` with
`absolute_sigma=False`), their correlations, residual plots and the fitted scenario as YAML.

Every run is journalled in the fit's folder (its parameters, the file of its residuals and that
file's SHA-256): a fit asked again with the same settings and data reads the runs it has and
runs only the others, so a killed fit resumes where it stopped; a folder holding a fit of other
settings is refused.
"""
from __future__ import annotations

import hashlib
import json
import logging
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.result import Result, read_result

log = logging.getLogger(__name__)

JOURNAL, REPORT, FITTED = "runs.jsonl", "fit.json", "fitted.yaml"
#: relative step of the finite-difference Jacobian (a run's outputs are smooth to far less
#: than the square root of the machine epsilon)
DIFF_STEP = 1e-6
ESTIMATE_HINT = ("give NAME=LO:HI or NAME=LO:HI@START, e.g. --estimate plant.scale=0.5:2 or "
                 "--estimate 'plant.pose[1]=-1:1@0'")


@dataclass(frozen=True)
class Estimate:
    """A parameter or initial-state element `name` ('plant.scale', 'plant.pose[1]') estimated
    within [low, high] from `start` (None: the scenario's own value)."""

    name: str
    low: float
    high: float
    start: float | None = None

    @classmethod
    def parse(cls, text: str) -> Estimate:
        """`NAME=LO:HI` or `NAME=LO:HI@START`."""
        name, sep, spec = str(text).partition("=")
        bounds, _, start = spec.partition("@")
        try:
            lo, hi = (float(p) for p in bounds.split(":"))
            first = float(start) if start.strip() else None
        except ValueError:
            raise CosimError(f"--estimate {text!r}: cannot read it. Fix: {ESTIMATE_HINT}."
                             ) from None
        if not sep or not name.strip() or "." not in name:
            raise CosimError(f"--estimate {text!r}: no COMPONENT.NAME. Fix: {ESTIMATE_HINT}.")
        return cls(name.strip(), lo, hi, first)

    def __post_init__(self) -> None:
        if not (math.isfinite(self.low) and math.isfinite(self.high) and self.low < self.high):
            raise CosimError(f"estimate {self.name}: bounds {self.low:g} .. {self.high:g} are "
                             f"no finite range. Fix: give LO below HI.")
        if self.start is not None and not self.low <= self.start <= self.high:
            raise CosimError(f"estimate {self.name}: start {self.start:g} is outside "
                             f"{self.low:g} .. {self.high:g}. Fix: start within the bounds.")


@dataclass(frozen=True)
class Experiment:
    """Measured `data` (a run's folder or a result file: CSV, Parquet, .mat) and the overrides
    that make the scenario what it was when they were measured (with a run's folder, the
    overrides its summary records are added, except those of the estimated names); `until`
    [s]: only the data up to then, each run stopped there (an open-loop replay of a long
    record drifts far from any start: fit a stretch first)."""

    data: str | Path
    overrides: tuple[str, ...] = ()
    until: float | None = None


@dataclass
class FitResult:
    """The estimates [name -> value], their standard errors, 95 % intervals and correlations;
    the final cost (half the sum of squared weighted residuals), the runs made and read from the
    journal, and the fit's folder."""

    estimates: dict[str, float]
    stderr: dict[str, float]
    interval: dict[str, tuple[float, float]]
    correlation: np.ndarray
    cost: float
    runs: int
    resumed: int
    folder: Path | None
    status: str
    residual_rms: dict[str, float] = field(default_factory=dict)
    #: each local fit of a global start: its start, what it found, its cost and runs
    starts: list[dict[str, Any]] = field(default_factory=list)

    def text(self) -> str:
        """A table of the estimates with their intervals."""
        width = max(len(n) for n in self.estimates)
        lines = [f"{'estimate':<{width}}  {'value':>12}  {'std. error':>11}  95 % interval"]
        for name, value in self.estimates.items():
            lo, hi = self.interval[name]
            lines.append(f"{name:<{width}}  {value:>12.6g}  {self.stderr[name]:>11.3g}  "
                         f"[{lo:.6g}, {hi:.6g}]")
        rms = ", ".join(f"{k} {v:.3g}" for k, v in self.residual_rms.items())
        lines.append(f"cost {self.cost:.6g} after {self.runs} runs ({self.resumed} read from "
                     f"the journal); {self.status}; residual RMS: {rms}")
        if len(self.starts) > 1:
            costs = sorted(s["cost"] for s in self.starts)
            near = sum(c <= costs[0] * (1 + 1e-6) + 1e-12 for c in costs)
            lines.append(f"global start: {len(self.starts)} local fits, {near} of them reached "
                         f"the lowest cost; the others stopped at "
                         f"{', '.join(f'{c:.4g}' for c in costs[near:]) or 'none'}")
        return "\n".join(lines)


@dataclass
class _Measured:
    times: np.ndarray
    columns: dict[str, np.ndarray]  # model signal -> measured values
    overrides: tuple[str, ...]
    label: str
    digest: str


def fit(scenario: str | Path | Any, data: Sequence[str | Path | Experiment] | str | Path,
        estimate: Sequence[str | Estimate], match: Sequence[str] | Mapping[str, str],
        *, sigma: Mapping[str, float] | None = None, overrides: Sequence[str] = (),
        out: str | Path | None = None, max_runs: int = 200, starts: int = 1, seed: int = 0,
        workers: int | None = None, scheduler: str | None = None) -> FitResult:
    """Estimate `estimate` so that the signals `match` (model signal names; a mapping: model
    signal -> data column) of runs of `scenario` match `data` (one or more experiments).
    `sigma`: per signal the measurement's standard deviation (default: the data column's).
    `out`: the fit's folder (journal, fit.json, fitted.yaml, residuals.png; None: nothing
    written, nothing resumed). At most `max_runs` runs per local fit. `starts` > 1: a global
    start — local fits from the given start and from `starts - 1` points of a Latin hypercube
    over the bounds (`seed`), the lowest cost kept; on a Dask cluster of `workers` local
    processes or at `scheduler` when either is given, one local fit a task."""
    from twmr.api import load
    from twmr.built import build

    estimates = [e if isinstance(e, Estimate) else Estimate.parse(e) for e in estimate]
    names = [e.name for e in estimates]
    if len(set(names)) != len(names):
        raise CosimError(f"an estimate is named twice ({', '.join(names)}). Fix: name each once.")
    if not isinstance(starts, int) or isinstance(starts, bool) or starts < 1:
        raise CosimError(f"starts {starts!r}: give a whole number of at least 1 (1: one local "
                         f"fit from the start values).")
    pairs = dict(match) if isinstance(match, Mapping) else {m: m for m in match}
    if not pairs:
        raise CosimError("no signal to match. Fix: name the model signals the data measures "
                         "(--match plant.pose[1],plant.pose[2]).")
    experiments = _experiments(data)
    loaded = load(scenario, list(overrides))
    built = build(loaded)
    measured = [_measure(e, pairs, set(names)) for e in experiments]
    start = np.array([_start(built, e) for e in estimates])
    sigmas = {s: float((sigma or {}).get(s) or _spread(measured, s)) for s in pairs}
    bad = [s for s, v in sigmas.items() if not (math.isfinite(v) and v > 0)]
    if bad:
        raise CosimError(f"sigma of {', '.join(bad)} is not above 0 (a constant measured "
                         f"signal has no spread to weigh it by). Fix: give --sigma NAME=VALUE.")
    key = _key(loaded, overrides, estimates, pairs, sigmas, measured)
    folder = Path(out) if out is not None else None
    tasks = [_Local(loaded, estimates, measured, sigmas, x0, max_runs, folder, key, k)
             for k, x0 in enumerate(_start_points(estimates, start, starts, seed))]
    if len(tasks) > 1 and (workers is not None or scheduler):
        outcomes = _on_cluster(tasks, workers, scheduler)
    else:
        outcomes = []
        for task in tasks:
            outcomes.append(_solve(task))
            if len(tasks) > 1:
                log.info("fit: start %d of %d: cost %.6g", task.number + 1, len(tasks),
                         outcomes[-1]["cost"])
    best = min(outcomes, key=lambda o: o["cost"])
    m_total, p = len(best["fun"]), len(estimates)
    stderr, interval, corr = _uncertainty(best["jac"], best["fun"], best["x"], m_total, p)
    result = FitResult({e.name: float(v) for e, v in zip(estimates, best["x"], strict=True)},
                       dict(zip(names, stderr, strict=True)),
                       dict(zip(names, interval, strict=True)), corr, float(best["cost"]),
                       sum(o["made"] for o in outcomes), sum(o["read"] for o in outcomes),
                       folder, best["message"], _rms(best["fun"], measured, pairs),
                       [{"start": [float(v) for v in t.start], "found": [float(v) for v in o["x"]],
                         "cost": o["cost"], "runs": o["made"] + o["read"]}
                        for t, o in zip(tasks, outcomes, strict=True)])
    if folder is not None:
        _report(folder, result, loaded, estimates, overrides, built, measured, sigmas)
    return result


def _start_points(estimates: list[Estimate], start: np.ndarray, starts: int, seed: int
                  ) -> list[np.ndarray]:
    """The given start, then `starts - 1` points of a Latin hypercube over the bounds."""
    points = [start]
    if starts > 1:
        from scipy.stats import qmc

        lows = np.array([e.low for e in estimates])
        highs = np.array([e.high for e in estimates])
        unit = qmc.LatinHypercube(d=len(estimates), seed=seed).random(starts - 1)
        points += list(lows + unit * (highs - lows))
    return points


@dataclass
class _Local:
    """One local least-squares fit from `start`, made where it runs (this process or a Dask
    worker), journalled as start `number` of the fit in `folder` (None: not journalled)."""

    scenario: Any
    estimates: list[Estimate]
    measured: list[_Measured]
    sigmas: dict[str, float]
    start: np.ndarray
    max_runs: int
    folder: Path | None
    key: str
    number: int


def _solve(task: _Local) -> dict[str, Any]:
    """The local fit of `task`: its optimum x, cost, residuals and Jacobian there, scipy's
    message, the runs made and those read from its journal."""
    from scipy.optimize import least_squares

    from twmr.built import build

    built = build(task.scenario)
    journal = _Journal(task.folder, task.key, task.number) if task.folder is not None else None
    runs = {"made": 0, "read": 0}
    estimates, measured = task.estimates, task.measured

    def residuals(x: np.ndarray) -> np.ndarray:
        if journal is not None and (kept := journal.get(x)) is not None:
            runs["read"] += 1
            return kept
        parts = []
        for m in measured:
            values = [f"{e.name}={float(v)!r}" for e, v in zip(estimates, x, strict=True)]
            try:
                result = built.run([*m.overrides, *values])
            except CosimError as err:
                raise CosimError(f"fit: the run of {m.label} with {', '.join(values)} failed: "
                                 f"{err}") from None
            parts.append(_residuals(result, m, task.sigmas))
        r = np.concatenate(parts)
        runs["made"] += 1
        if journal is not None:
            journal.add(x, r)
        if (runs["made"] + runs["read"]) % 10 == 0:
            log.info("fit: %d runs, cost %.6g", runs["made"] + runs["read"], 0.5 * r @ r)
        return r

    lows, highs = np.array([e.low for e in estimates]), np.array([e.high for e in estimates])
    solved = least_squares(residuals, task.start, bounds=(lows, highs), method="trf",
                           diff_step=DIFF_STEP, x_scale="jac", max_nfev=task.max_runs)
    return {"x": solved.x, "cost": float(solved.cost), "fun": solved.fun, "jac": solved.jac,
            "message": str(solved.message), **runs}


def _on_cluster(tasks: list[_Local], workers: int | None, scheduler: str | None
                ) -> list[dict[str, Any]]:
    """The local fits of `tasks` on a Dask cluster, one task each."""
    from twmr.sweeps.engine import dask_client

    client, cluster = dask_client(workers, scheduler)
    try:
        futures = client.map(_solve, tasks, pure=False,
                             key=[f"fit-start-{t.number}" for t in tasks])
        return list(client.gather(futures))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def _experiments(data: Sequence[str | Path | Experiment] | str | Path) -> list[Experiment]:
    items = [data] if isinstance(data, str | Path) else list(data)
    if not items:
        raise CosimError("no data to fit to. Fix: give --data RUN_OR_FILE.")
    return [d if isinstance(d, Experiment) else Experiment(d) for d in items]


def _measure(e: Experiment, pairs: Mapping[str, str], estimated: set[str]) -> _Measured:
    """The data of experiment `e`: its times and matched columns, its overrides."""
    from twmr.blocks.datafiles import split_units
    from twmr.registry import suggest

    path = Path(e.data)
    result = read_result(path)
    names, _ = split_units(result.columns, result.units)
    at = {n: j for j, n in enumerate(names)}
    if "time" not in at:
        raise CosimError(f"{path}: no time column. Fix: give data with a 'time' column [s].")
    columns = {}
    for model, column in pairs.items():
        if column not in at:
            raise CosimError(f"{path}: no column '{column}'{suggest(column, names)} to match "
                             f"'{model}'. Fix: match signals the data has (--match "
                             f"MODEL=COLUMN for another name).")
        values = result.values[:, at[column]]
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise CosimError(f"{path}: column '{column}' has no number at row {bad[0]} "
                             f"(counted from 0). Fix: drop or fill the rows without a value.")
        columns[model] = np.asarray(values, dtype=float)
    recorded = tuple(o for o in result.summary.get("overrides", [])
                     if o.partition("=")[0].strip() not in estimated)
    times = np.asarray(result.values[:, at["time"]], dtype=float)
    stop: tuple[str, ...] = ()
    if e.until is not None:
        keep = times <= e.until + 1e-9 * max(1.0, abs(e.until))
        if keep.sum() < 2:
            raise CosimError(f"{path}: fewer than two rows up to until = {e.until:g} s. Fix: "
                             f"give a later until.")
        times, columns = times[keep], {k: v[keep] for k, v in columns.items()}
        stop = (f"experiment.stop={e.until!r}",)
    digest = _digest(path) + ("" if e.until is None else f"@{e.until!r}")
    return _Measured(times, columns, recorded + tuple(e.overrides) + stop, str(path), digest)


def _start(built: Any, e: Estimate) -> float:
    """The estimate's start: given, or the scenario's value (which must lie in the bounds)."""
    if e.start is not None:
        return e.start
    comp_name, _, var = e.name.rpartition(".")
    var, _, index = var.partition("[")
    comp = built.system.components.get(comp_name)
    if comp is None or var not in comp.variables:
        raise CosimError(f"estimate {e.name}: no such parameter or state in the scenario. Fix: "
                         f"name COMPONENT.PARAMETER or COMPONENT.STATE[i].")
    value = comp.get(var)
    if index:
        value = value[int(index.rstrip("]")) - 1]
    value = float(value)
    if not e.low <= value <= e.high:
        raise CosimError(f"estimate {e.name}: the scenario's value {value:g} is outside "
                         f"{e.low:g} .. {e.high:g}. Fix: give a start (NAME=LO:HI@START).")
    return value


def _residuals(result: Result, m: _Measured, sigmas: Mapping[str, float]) -> np.ndarray:
    t = np.asarray(result["time"], dtype=float)
    if m.times[0] < t[0] - 1e-9 or m.times[-1] > t[-1] + 1e-9:
        raise CosimError(f"{m.label}: the data spans {m.times[0]:g} .. {m.times[-1]:g} s, the "
                         f"run {t[0]:g} .. {t[-1]:g} s. Fix: run over the data's span "
                         f"(--set experiment.stop=...).")
    parts = []
    for model, measured in m.columns.items():
        if model not in result.columns:
            raise CosimError(f"the run records no '{model}'. Fix: record it (record: signals) "
                             f"and match signals it records.")
        simulated = np.interp(m.times, t, np.asarray(result[model], dtype=float))
        parts.append((simulated - measured) / sigmas[model])
    return np.concatenate(parts)


def _spread(measured: list[_Measured], signal: str) -> float:
    return float(np.std(np.concatenate([m.columns[signal] for m in measured])))


def _uncertainty(jac: np.ndarray, fun: np.ndarray, x: np.ndarray, m: int, p: int
                 ) -> tuple[list[float], list[tuple[float, float]], np.ndarray]:
    """Standard errors, 95 % intervals and correlations from J at the optimum."""
    from scipy import stats

    dof = max(m - p, 1)
    s2 = float(fun @ fun) / dof
    cov = np.linalg.pinv(jac.T @ jac) * s2
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    q = float(stats.t.ppf(0.975, dof))
    outer = np.outer(std, std)
    corr = np.divide(cov, outer, out=np.full_like(cov, np.nan), where=outer > 0)
    return ([float(s) for s in std], [(float(v - q * s), float(v + q * s))
                                      for v, s in zip(x, std, strict=True)], corr)


def _rms(fun: np.ndarray, measured: list[_Measured], pairs: Mapping[str, str]
         ) -> dict[str, float]:
    """Per signal, the RMS of its weighted residuals over all experiments."""
    out: dict[str, list[np.ndarray]] = {s: [] for s in pairs}
    k = 0
    for m in measured:
        for s in m.columns:
            n = len(m.times)
            out[s].append(fun[k:k + n])
            k += n
    return {s: float(np.sqrt(np.mean(np.concatenate(v) ** 2))) for s, v in out.items()}


def _digest(path: Path) -> str:
    """SHA-256 of the data (a folder: its result.arrows)."""
    file = path / "result.arrows" if path.is_dir() else path
    h = hashlib.sha256()
    with open(file, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _key(scenario: Any, overrides: Sequence[str], estimates: list[Estimate],
         pairs: Mapping[str, str], sigmas: Mapping[str, float], measured: list[_Measured]
         ) -> str:
    """What the journal's runs depend on: the scenario's text, the overrides, the estimates,
    the matches, the weights and each experiment's data and overrides."""
    content = scenario.content if isinstance(scenario.content, str) else repr(scenario.content)
    parts = {"scenario": hashlib.sha256(content.encode()).hexdigest(),
             "overrides": list(overrides), "estimates": [vars(e) for e in estimates],
             "match": dict(pairs), "sigma": dict(sigmas),
             "data": [(m.digest, list(m.overrides)) for m in measured]}
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()


class _Journal:
    """The runs of a fit in `folder`: one JSON line per run (parameters, residual file, its
    SHA-256), keyed by the fit's settings."""

    def __init__(self, folder: Path, key: str, number: int = 0):
        self.folder, self.key = folder, key
        folder.mkdir(parents=True, exist_ok=True)
        # start 0 of a global start in runs.jsonl and runs/, start k in runs.k.jsonl, runs.k/
        self.runs_dir = folder / ("runs" if number == 0 else f"runs.{number}")
        self.runs_dir.mkdir(exist_ok=True)
        self.path = folder / (JOURNAL if number == 0 else f"runs.{number}.jsonl")
        self.runs: dict[tuple[float, ...], tuple[str, str]] = {}
        if not self.path.exists():
            self.path.write_text(json.dumps({"key": key}) + "\n")
            return
        lines = self.path.read_text().splitlines()
        head = json.loads(lines[0]) if lines else {}
        if head.get("key") != key:
            raise CosimError(f"{folder}: holds a fit of other settings or data. Fix: give another "
                             f"--out, or remove the folder to fit anew.")
        for line in lines[1:]:
            try:
                entry = json.loads(line)
            except ValueError:  # a line cut by a kill
                continue
            self.runs[tuple(entry["x"])] = (entry["file"], entry["sha256"])

    def get(self, x: np.ndarray) -> np.ndarray | None:
        """The residuals of the run at x, if journalled and its file is intact."""
        found = self.runs.get(tuple(float(v) for v in x))
        if found is None:
            return None
        file = self.runs_dir / found[0]
        try:
            data = file.read_bytes()
        except OSError:
            return None
        if hashlib.sha256(data).hexdigest() != found[1]:
            return None
        return np.frombuffer(data, dtype="<f8").copy()

    def add(self, x: np.ndarray, r: np.ndarray) -> None:
        name = f"{len(self.runs):05d}.f8"
        data = np.ascontiguousarray(r, dtype="<f8").tobytes()
        tmp = self.runs_dir / f".{name}.tmp"
        tmp.write_bytes(data)
        os.replace(tmp, self.runs_dir / name)
        point = [float(v) for v in x]
        digest = hashlib.sha256(data).hexdigest()
        with open(self.path, "a") as f:
            f.write(json.dumps({"x": point, "file": name, "sha256": digest}) + "\n")
        self.runs[tuple(point)] = (name, digest)


def _report(folder: Path, result: FitResult, scenario: Any, estimates: list[Estimate],
            overrides: Sequence[str], built: Any, measured: list[_Measured],
            sigmas: Mapping[str, float]) -> None:
    """fit.json, fitted.yaml and residuals.png in `folder`."""
    from twmr.scenario.written import yaml_with

    names = list(result.estimates)
    report = {"estimates": result.estimates, "stderr": result.stderr,
              "interval_95": {k: list(v) for k, v in result.interval.items()},
              "correlation": {a: {b: _finite(result.correlation[i, j])
                                  for j, b in enumerate(names)} for i, a in enumerate(names)},
              "cost": result.cost, "runs": result.runs, "resumed": result.resumed,
              "status": result.status, "sigma": dict(sigmas),
              "residual_rms": result.residual_rms,
              "bounds": {e.name: [e.low, e.high] for e in estimates},
              **({"starts": result.starts} if len(result.starts) > 1 else {}),
              "data": [m.label for m in measured]}
    _write(folder / REPORT, json.dumps(report, indent=2))
    settings: list[str | tuple[str, Any]] = [*overrides, *result.estimates.items()]
    head = (f"# {scenario.source} fitted by `twmr fit` to {', '.join(m.label for m in measured)}"
            f": cost {result.cost:.6g}; 95 % intervals in {REPORT}\n")
    text = yaml_with(scenario, settings, head)
    if text is not None:
        _write(folder / FITTED, text)
    _plot(folder / "residuals", result, built, measured)


def _finite(v: float) -> float | None:
    return float(v) if math.isfinite(v) else None


def _write(path: Path, text: str) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def _plot(path: Path, result: FitResult, built: Any, measured: list[_Measured]) -> None:
    """Per experiment and signal: the data, the fitted model; below, the residual."""
    from twmr.plots import line_style, pyplot, save

    plt = pyplot()
    values = [f"{k}={v!r}" for k, v in result.estimates.items()]
    rows = [(m, s) for m in measured for s in m.columns]
    fig, axes = plt.subplots(len(rows), 2, figsize=(11, 2.2 * len(rows) + 0.6), squeeze=False,
                             gridspec_kw={"width_ratios": (3, 2)})
    runs = {id(m): built.run([*m.overrides, *values]) for m in measured}
    for (ax, res), (m, s) in zip(axes, rows, strict=True):
        run = runs[id(m)]
        model = np.interp(m.times, np.asarray(run["time"]), np.asarray(run[s]))
        ax.plot(m.times, m.columns[s], ".", ms=2, label="data", **{"color": "#999999"})
        ax.plot(m.times, model, lw=1.0, label="fitted model", **line_style(0))
        ax.set_title(f"{s} ({Path(m.label).name})", fontsize=9, loc="left")
        ax.legend(fontsize=7, frameon=False)
        res.plot(m.times, model - m.columns[s], lw=0.8, **line_style(1))
        res.axhline(0.0, color="#000000", lw=0.6)
        res.set_ylabel("model - data", fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    save(fig, path)
