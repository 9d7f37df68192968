"""`sweep_report`: what a sweep folder's `runs.parquet` says, as `summary.md` (the sweep, the
spread of every metric over the ok runs, the failed runs and their errors) and PNG plots (a box
plot of every metric, a histogram per metric, each metric against each varied parameter).

A metric is every numeric column that is neither a fixed column of the table nor a varied
parameter. The varied parameters are the `vary` names of `sweep.json`; without it, the columns
whose name holds a dot (`plant.scale`, `plant.pose[1]`).
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from twmr.sweeps.spec import SweepError

TABLE, SPEC = "runs.parquet", "sweep.json"
FIXED = ("run_id", "sweep_id", "sample", "status", "error", "wall_time_s", "step_time_s", "worker",
         "warnings")
ERROR_CHARS = 200


def sweep_report(folder: str | Path, out: str | Path | None = None) -> list[Path]:
    """Write the report of the sweep in `folder` into `out` (default `folder/report`): summary.md
    and the PNGs. The paths written, summary.md first."""
    folder = Path(folder)
    frame = _read_table(folder)
    info, note = _read_spec(folder)
    specs = _vary_specs(info)
    params = ([n for n in specs if n in frame.columns] if specs else
              [c for c in frame.columns if "." in str(c) and c not in FIXED])
    metrics = _metrics(frame, params)
    ok = frame[frame["status"] == "ok"]
    values = {m: _finite(ok[m]) for m in metrics}
    target = Path(out) if out is not None else folder / "report"
    target.mkdir(parents=True, exist_ok=True)
    summary = target / "summary.md"
    summary.write_text(_summary(folder, frame, info, note, specs, params, values),
                       encoding="utf-8")
    plotted = {m: v for m, v in values.items() if v.size}
    from twmr.registry import metric_units

    units = metric_units([str(m) for m in info.get("metrics") or []])
    return [summary, *_plots(frame, params, plotted, target, units)]


def _read_table(folder: Path) -> Any:
    """runs.parquet as a DataFrame; SweepError when it is missing, unreadable or no sweep table."""
    import pandas as pd

    path = folder / TABLE
    if not path.is_file():
        raise SweepError(f"{folder}: no {TABLE} there, so there is no sweep to report on. Fix: "
                         f"run `twmr sweep SCENARIO --vary NAME=SPEC --out {folder}` first, or "
                         f"give the folder a sweep wrote.")
    try:
        frame = pd.read_parquet(path)
    except Exception as err:  # noqa: BLE001 - pyarrow raises many kinds for a damaged file
        raise SweepError(f"{path}: cannot read it ({err}). Fix: run `twmr sweep` again on the "
                         f"folder to rewrite it.") from None
    missing = [c for c in ("run_id", "status") if c not in frame.columns]
    if missing:
        raise SweepError(f"{path}: no column {', '.join(missing)}, so it is not a table "
                         f"`twmr sweep` wrote. Fix: give the folder of a sweep.")
    return frame


def _read_spec(folder: Path) -> tuple[dict[str, Any], str]:
    """sweep.json as a dict ({} when absent) and a note when it cannot be read."""
    path = folder / SPEC
    if not path.is_file():
        return {}, f"no {SPEC} in the folder: varied parameters taken as the dotted columns"
    try:
        info = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as err:
        return {}, f"{SPEC} cannot be read ({err}): varied parameters taken as the dotted columns"
    if not isinstance(info, dict):
        return {}, f"{SPEC} is not a mapping: varied parameters taken as the dotted columns"
    return info, ""


def _vary_specs(info: dict[str, Any]) -> dict[str, str]:
    """{NAME: SPEC} from sweep.json's `vary` (a mapping, or a list of `NAME=SPEC` texts)."""
    vary = info.get("vary")
    if isinstance(vary, dict):
        return {str(k): str(v) for k, v in vary.items()}
    if isinstance(vary, list):
        pairs = [str(v).partition("=") for v in vary]
        return {name.strip(): spec.strip() for name, _, spec in pairs}
    return {}


def _metrics(frame: Any, params: list[str]) -> list[str]:
    """The metric columns: numeric (not boolean) or entirely empty, neither fixed nor varied."""
    from pandas.api.types import is_bool_dtype, is_numeric_dtype

    return [c for c in frame.columns if c not in FIXED and c not in params
            and not is_bool_dtype(frame[c])
            and (is_numeric_dtype(frame[c]) or frame[c].isna().all())]


def _finite(column: Any) -> np.ndarray:
    """The finite values of a column, as floats."""
    import pandas as pd

    v = pd.to_numeric(column, errors="coerce").to_numpy(dtype=float)
    return v[np.isfinite(v)]


def _fmt(value: Any) -> str:
    """A number to 6 significant digits; anything else as text."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.number)):
        return str(value)
    return f"{value:.6g}"


def _cell(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("|", "\\|").replace("\n", " ")


def _first_line(error: Any) -> str:
    """The first non-empty line of an error, cut to ERROR_CHARS characters."""
    lines = [ln.strip() for ln in str(error or "").splitlines() if ln.strip()]
    if not lines:
        return "(no error message)"
    line = lines[0]
    return line if len(line) <= ERROR_CHARS else line[:ERROR_CHARS - 1] + "…"


def _observed(column: Any) -> str:
    """What values a parameter took in the runs: a numeric range or the distinct values."""
    from pandas.api.types import is_bool_dtype, is_numeric_dtype

    if is_numeric_dtype(column) and not is_bool_dtype(column):
        v = _finite(column)
        return f"{_fmt(v.min())} … {_fmt(v.max())}" if v.size else "no finite value"
    distinct = sorted({str(x) for x in column.dropna()})
    return ", ".join(distinct) if distinct else "none"


def _summary(folder: Path, frame: Any, info: dict[str, Any], note: str, specs: dict[str, str],
             params: list[str], values: dict[str, np.ndarray]) -> str:
    """The text of summary.md."""
    ok = frame["status"] == "ok"
    n_ok, n_failed = int(ok.sum()), int((~ok).sum())
    lines = [f"# Sweep report: {folder.name or folder}", "", "## Sweep", ""]
    for key in ("scenario", "method", "samples", "seed"):
        if key in info:
            lines.append(f"- {key}: `{info[key]}`")
    if info.get("metrics"):
        lines.append(f"- metrics asked for: {', '.join(map(str, info['metrics']))}")
    lines.append(f"- folder: `{folder}`")
    if note:
        lines.append(f"- note: {note}")
    lines += ["", "| varied parameter | spec | values in the runs |", "|---|---|---|"]
    for name in dict.fromkeys([*specs, *params]):
        seen = _observed(frame[name]) if name in frame.columns else "not in the table"
        lines.append(f"| `{name}` | {_cell(specs.get(name, '?'))} | {_cell(seen)} |")
    lines += ["", "## Runs", "", f"{len(frame)} runs: {n_ok} ok, {n_failed} failed."]
    if "wall_time_s" in frame.columns:
        wall = _finite(frame.loc[ok, "wall_time_s"])
        if wall.size:
            lines.append(f"Wall time per ok run: median {_fmt(np.median(wall))} s, "
                         f"max {_fmt(wall.max())} s, total {_fmt(wall.sum())} s.")
    lines += ["", f"## Metrics (over the {n_ok} ok runs)", ""]
    if values:
        lines += ["| metric | median | 5 % | 95 % | min | max | ok runs with a finite value |",
                  "|---|---:|---:|---:|---:|---:|---:|"]
        for name, v in values.items():
            if v.size:
                p5, p50, p95 = np.percentile(v, [5, 50, 95])
                row = [p50, p5, p95, v.min(), v.max()]
                lines.append(f"| `{name}` | " + " | ".join(_fmt(x) for x in row)
                             + f" | {v.size} |")
            else:
                lines.append(f"| `{name}` | no finite value | | | | | 0 |")
    else:
        lines.append("No metric column in the table.")
    lines += ["", "## Failures", ""]
    failed = frame[~ok]
    if failed.empty:
        lines.append("none")
    for _, row in failed.iterrows():
        given = ", ".join(f"{p}={_fmt(row[p])}" for p in params)
        lines.append(f"- `{row['run_id']}`" + (f" ({given})" if given else "")
                     + f": {_first_line(row.get('error'))}")
    return "\n".join(lines) + "\n"


def _safe(name: str) -> str:
    """A file-name-safe form of a column name."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", str(name))


def _positions(column: Any) -> tuple[np.ndarray, list[str] | None]:
    """x positions of a parameter's values: the numbers themselves, or the index of each
    category (with the category labels) for text and booleans; NaN where there is no value."""
    import pandas as pd
    from pandas.api.types import is_bool_dtype, is_numeric_dtype

    if is_numeric_dtype(column) and not is_bool_dtype(column):
        return column.to_numpy(dtype=float), None
    labels = sorted({str(x) for x in column.dropna()})
    index = {label: i for i, label in enumerate(labels)}
    x = np.array([math.nan if pd.isna(v) else index[str(v)] for v in column], dtype=float)
    return x, labels


def _plots(frame: Any, params: list[str], values: dict[str, np.ndarray], target: Path,
           units: dict[str, str]) -> list[Path]:
    """The figures (PNG and SVG) of the metrics that have a finite value, each axis with the
    metric's unit when its set declares one; the PNG paths written."""
    if not values:
        return []
    import pandas as pd

    from twmr.plots import axis_label, legend_outside, line_style, pyplot, save

    plt = pyplot()
    written = []

    def keep(fig: Any, name: str) -> None:
        written.append(save(fig, target / name)[0])

    def label(name: str) -> str:
        return axis_label(name, units.get(name, ""))

    fig, axes = _grid(plt, len(values), 2.6, 3.4)
    for ax, (name, v) in zip(axes, values.items(), strict=False):
        ax.boxplot(v, widths=0.5)
        ax.set_xticks([])
        ax.set_title(name, fontsize=9)
        ax.set_ylabel(label(name))
        ax.grid(True, axis="y", alpha=0.3)
    fig.suptitle(f"Each metric over the {len(next(iter(values.values())))} ok runs")
    keep(fig, "metrics_boxplot.png")

    for name, v in values.items():
        fig, ax = plt.subplots(figsize=(7, 3.6))
        ax.hist(v, bins=min(30, max(5, math.ceil(math.sqrt(v.size)))), alpha=0.85,
                color=line_style(0)["color"])
        p5, p50, p95 = np.percentile(v, [5, 50, 95])
        unit = f" {units[name]}" if units.get(name) else ""
        ax.axvline(p50, color="k", lw=1.2, label=f"median {p50:.3g}{unit}")
        for p, text in ((p5, "5 %"), (p95, "95 %")):
            ax.axvline(p, color="k", lw=0.8, ls="--", label=f"{text} {p:.3g}{unit}")
        ax.set_xlabel(label(name))
        ax.set_ylabel("ok runs")
        ax.set_title(f"{name} over {v.size} ok runs: median {p50:.3g}{unit}, 90 % between "
                     f"{p5:.3g} and {p95:.3g}{unit}", fontsize=9)
        legend_outside(ax)
        ax.grid(True, alpha=0.3)
        keep(fig, f"hist_{_safe(name)}.png")

    if not params:
        return written
    ok = (frame["status"] == "ok").to_numpy()
    positions = {p: _positions(frame[p]) for p in params}
    jitter = np.random.default_rng(0).uniform(-0.15, 0.15, len(frame))
    for name in values:
        y = pd.to_numeric(frame[name], errors="coerce").to_numpy(dtype=float)
        fig, axes = _grid(plt, len(params), 4.2, 3.4)
        for ax, p in zip(axes, params, strict=False):
            x, labels = positions[p]
            if labels is not None:
                x = x + jitter
                ax.set_xticks(range(len(labels)), labels)
            shown = ok & np.isfinite(x) & np.isfinite(y)
            ax.scatter(x[shown], y[shown], s=16, alpha=0.7, label=f"ok ({int(shown.sum())})",
                       color=line_style(0)["color"])
            lost = ~ok & np.isfinite(x)
            if lost.any():
                bottom, top = ax.get_ylim()
                ax.plot(x[lost], np.full(int(lost.sum()), bottom), "x", ms=8, mew=1.5,
                        clip_on=False, label=f"failed ({int(lost.sum())})",
                        color=line_style(1)["color"])
                ax.set_ylim(bottom, top)
            ax.set_xlabel(p)
            ax.set_ylabel(label(name))
            ax.set_title(f"{name} against {p}", fontsize=9)
            ax.legend(fontsize=7)
            ax.grid(True, alpha=0.3)
        fig.suptitle(f"{name} against the varied parameters")
        keep(fig, f"scatter_{_safe(name)}.png")
    return written


def _grid(plt: Any, n: int, width: float, height: float) -> tuple[Any, list[Any]]:
    """A figure of n subplots, at most 4 a row (the spare ones hidden), and those n axes."""
    cols = min(4, n)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(width * cols, height * rows), squeeze=False)
    flat = list(axes.ravel())
    for ax in flat[n:]:
        ax.set_visible(False)
    return fig, flat[:n]
