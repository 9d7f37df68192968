"""The report of a tune folder (`report/`): the objective of every trial with its spread and the
best so far (`history`), the objective against each tuned parameter (`scatter`), and Optuna's
fANOVA parameter importance (`importance`), in the shared plot style (`twmr.plots`)."""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from twmr.plots import legend_outside, line_style, pyplot, save, spans_decades
from twmr.tuning.objective import parse_param
from twmr.tuning.study import DESCRIPTION, TRIALS

log = logging.getLogger("twmr.tuning")


def tune_report(folder: Path, out: Path | None = None) -> list[Path]:
    """Write the report of the tune in `folder` into `out` (default folder/report); the files."""
    import pandas as pd

    described = json.loads((folder / DESCRIPTION).read_text(encoding="utf-8"))
    trials = pd.read_parquet(folder / TRIALS)
    out = out or folder / "report"
    params = [parse_param(f"{k}={v}") for k, v in described["params"].items()]
    label = f"{described['aggregate']} of {described['objective']}"
    plt = pyplot()
    written: list[Path] = []

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for i, (status, group) in enumerate(trials.groupby("status", sort=True)):
        ax.errorbar(group["trial"], group["objective"], yerr=group["spread"], fmt="o", ms=3,
                    capsize=2, linestyle="none", color=line_style(i + 1)["color"],
                    label=f"trials ({status}), ± spread")
    ok = trials[trials["status"] == "ok"].sort_values("trial")
    if len(ok):
        ax.step(ok["trial"], np.minimum.accumulate(ok["objective"].to_numpy()), where="post",
                label="best so far", **line_style(0))
    ax.set_xlabel("trial")
    ax.set_ylabel(label)
    log_objective = spans_decades(trials["objective"])
    if log_objective:
        ax.set_yscale("log")
    legend_outside(ax)
    written += save(fig, out / "history")

    fig, axes = plt.subplots(1, len(params), figsize=(3.2 * len(params), 3), squeeze=False)
    for ax, p in zip(axes[0], params, strict=True):
        ax.scatter(ok[p.name], ok["objective"], s=10, c=ok["trial"], cmap="viridis")
        if p.kind == "log":
            ax.set_xscale("log")
        if log_objective:
            ax.set_yscale("log")
        ax.set_xlabel(p.name)
        ax.set_ylabel(label)
    written += save(fig, out / "scatter")

    importance = _importance(params, ok)
    if importance:
        fig, ax = plt.subplots(figsize=(5, 0.5 + 0.4 * len(importance)))
        names = list(importance)
        ax.barh(names, [importance[n] for n in names], color=line_style(0)["color"])
        ax.invert_yaxis()
        ax.set_xlabel("importance (fANOVA, share of the objective's variance)")
        written += save(fig, out / "importance")
    return written


def _importance(params: list, ok: object) -> dict[str, float]:
    """Optuna's fANOVA importance of each parameter from the feasible trials ({} when there are
    too few, or one parameter only)."""
    import optuna
    from optuna.trial import create_trial

    rows = ok.to_dict("records")  # type: ignore[attr-defined]
    if len(params) < 2 or len(rows) < 4:
        return {}
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize")
    dists = {p.name: p.distribution() for p in params}
    for row in rows:
        study.add_trial(create_trial(params={p.name: _plain(row[p.name]) for p in params},
                                     distributions=dists, value=float(row["objective"])))
    try:
        return dict(optuna.importance.get_param_importances(study))
    except (RuntimeError, ValueError) as err:
        log.warning("no parameter importance: %s", err)
        return {}


def _plain(value: object) -> object:
    return value.item() if hasattr(value, "item") else value
