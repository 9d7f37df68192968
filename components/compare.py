"""`twmr compare A.yaml B.yaml ...`: run scenarios, print Table III side by side, save figures.

Figures (PNG, in `results/compare/` unless `--out`): XY paths of every run against the reference,
x and y tracking errors over time, wheel torques, and the adaptive estimate d_hat where recorded.
"""
from __future__ import annotations

import re
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from twmr.components.metrics import DEFINITIONS, errors, tracking_metrics
from twmr.core import jsonvalues
from twmr.core.errors import CosimError
from twmr.plots import legend_outside, line_style, pyplot, save

METRICS = ("settling_time_x", "settling_time_y", "peak_error_x", "peak_error_y", "mse_x", "mse_y")
UNITS = {"settling_time": "s", "peak_error": "m", "mse": "m2"}


def labels(paths: list[Path]) -> list[str]:
    """A name per scenario: its file's stem, with as many of its folders in front as tell two
    files of one stem apart ('a/x', 'b/x'); the same file twice is refused."""
    resolved = [p.resolve() for p in paths]
    twice = {str(p) for p in resolved if resolved.count(p) > 1}
    if twice:
        raise CosimError(f"{sorted(twice)[0]} is given twice. Fix: name each scenario once.")
    depth = 0
    while True:
        names = ["/".join((*p.parent.parts[len(p.parent.parts) - depth:], p.stem)) if depth
                 else p.stem for p in resolved]
        if len(set(names)) == len(names):
            return names
        depth += 1


def run_scenario(path: Path, out: Path, overrides: Sequence[str] = (),
                 label: str = "") -> np.ndarray:
    """Load and run one scenario, results in `out/<label>/` (default: its stem); the recorded
    structured array."""
    import twmr

    print(f"running {path} ...", file=sys.stderr)
    result = twmr.simulate(twmr.load(path, overrides), out / (label or path.stem),
                           progress=True)
    return np.array(result.data)


def table(results: dict[str, dict[str, float]]) -> str:
    """Table III as text: one row per metric, one column per scenario."""
    names = list(results)
    width = max(14, *(len(n) for n in names))
    lines = ["metric".ljust(22) + "".join(n.rjust(width + 2) for n in names)]
    for m in METRICS:
        unit = UNITS[m.rsplit("_", 1)[0]]
        row = f"{m} [{unit}]".ljust(22)
        row += "".join(f"{results[n].get(m, float('nan')):>{width + 2}.4g}" for n in names)
        lines.append(row)
    lines.append("")
    lines += [f"{k}: {v}" for k, v in DEFINITIONS.items()]
    return "\n".join(lines)


def _columns(data: np.ndarray, port: str) -> list[str]:
    return [n for n in data.dtype.names or () if re.search(rf"\.{port}\[\d+\]$", n)]


def figures(runs: dict[str, np.ndarray], out: Path) -> list[Path]:
    """XY paths with the reference, x/y errors, torques and d_hat of every run, one colour per
    run (wheels by dash); PNG and SVG, the paths written."""
    plt = pyplot()
    written = []
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    first = next(iter(runs.values()))
    ref = _columns(first, "position")
    if ref:
        ax.plot(first[ref[0]], first[ref[1]], color="0.55", lw=3, label="reference")
    for i, (name, data) in enumerate(runs.items()):
        pose = _columns(data, "pose")
        if pose:
            ax.plot(data[pose[0]], data[pose[1]], lw=1.3, label=name, **line_style(i))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    legend_outside(ax)
    ax.set_title("Paths of the robot's point M and the reference", fontsize=10)
    written += save(fig, out / "xy.png")
    for axis, k in (("x", 1), ("y", 2)):
        fig, ax = plt.subplots(figsize=(7.5, 3.5))
        for i, (name, data) in enumerate(runs.items()):
            e = errors(data)
            if e is not None:
                ax.plot(e[0], e[k], lw=1.1, label=name, **line_style(i))
        ax.set_xlabel("time [s]")
        ax.set_ylabel(f"tracking error e_{axis} [m]")
        ax.grid(True, alpha=0.3)
        legend_outside(ax)
        ax.set_title(f"Tracking error in {axis} of each run", fontsize=10)
        written += save(fig, out / f"error_{axis}.png")
    for port, label in (("torque", "wheel torque [N.m]"), ("d_hat", "adaptive estimate d_hat")):
        if not any(_columns(d, port) for d in runs.values()):
            continue
        fig, ax = plt.subplots(figsize=(7.5, 3.8))
        for i, (name, data) in enumerate(runs.items()):
            for wheel, c in zip(("right", "left"), _columns(data, port), strict=False):
                style = {**line_style(i), "linestyle": "-" if wheel == "right" else "--"}
                ax.plot(data["time"], data[c], lw=0.9, label=f"{name}, {wheel} wheel", **style)
        ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
        legend_outside(ax)
        ax.set_title(f"{label[0].upper()}{label[1:].split(' [')[0]} of each run (solid: right "
                     f"wheel, dashed: left)", fontsize=10)
        written += save(fig, out / f"{port}.png")
    return written


def compare(paths: list[Path], as_json: bool = False, out: Path | None = None,
            overrides: Sequence[str] = ()) -> int:
    """Run every scenario, print the table (or JSON keyed by scenario, then metric), save
    figures."""
    out = out or Path("results") / "compare"
    runs = {name: run_scenario(p, out, overrides, name)
            for p, name in zip(paths, labels(paths), strict=True)}
    results: dict[str, dict[str, Any]] = {}
    for name, data in runs.items():
        m = tracking_metrics(data)
        if not m:
            raise CosimError(f"{name}: the result has no reference position and pose to compare. "
                             f"Fix: record the trajectory's `position` and the plant's `pose`.")
        results[name] = m
    written = figures(runs, out)
    (out / "table.json").write_text(jsonvalues.dumps(results, indent=2) + "\n")
    if as_json:
        print(jsonvalues.dumps(results))
    else:
        print(table(results))
        print(f"\nfigures: {', '.join(str(p) for p in written)}")
    return 0

