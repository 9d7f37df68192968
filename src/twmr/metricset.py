"""`MetricSet`: what the entry-point group `twmr.metrics` registers — a function of a run's
`Result` giving named figures, what the run must record for it (`needs`), and the unit of each
figure (`units`, for reports). A plain function registered there is a set with no needs and no
units (`metric_set`). `signals` is the engine's own set, for any scenario."""
from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np


def _nothing_needed(columns: list[str]) -> str:
    return ""


@dataclass(frozen=True)
class MetricSet:
    """`compute(result) -> {figure: value}`; `needs(columns)` is '' when the recorded columns
    suffice, else what is missing (checked before a run); `units`: figure -> unit string."""

    compute: Callable[[Any], dict[str, Any]]
    needs: Callable[[list[str]], str] = _nothing_needed
    units: Mapping[str, str] = field(default_factory=dict)
    #: figures it gives beyond `units`' (a regular expression of their names; '' none)
    pattern: str = ""

    def __call__(self, result: Any) -> dict[str, Any]:
        return self.compute(result)

    def gives(self, figure: str) -> bool:
        """Whether `figure` is one of this set's figures (by `units` or `pattern`)."""
        return figure in self.units or bool(self.pattern and re.fullmatch(self.pattern, figure))


def metric_set(registered: Any) -> MetricSet:
    """A registered entry as a `MetricSet` (a plain function: no needs, no units)."""
    return registered if isinstance(registered, MetricSet) else MetricSet(registered)


def figure_name(column: str) -> str:
    """A recorded column as a name an objective can use: 'plant.pose[1]' -> 'plant_pose_1'."""
    return re.sub(r"\W+", "_", column).strip("_")


def _signals(result: Any) -> dict[str, Any]:
    out: dict[str, Any] = {}
    if len(result.values) == 0:
        return out
    for k, column in enumerate(result.columns[1:], 1):
        v = result.values[:, k]
        name = figure_name(column)
        out[f"ms_{name}"] = float(np.mean(v * v))
        out[f"peak_{name}"] = float(np.max(np.abs(v)))
        out[f"final_{name}"] = float(v[-1])
    return out


#: for every recorded column c (time excepted): ms_c (mean of c^2 over the recorded samples),
#: peak_c (largest |c|) and final_c (its last value); c as `figure_name` writes it
signals = MetricSet(_signals, pattern=r"(ms|peak|final)_\w+")

