"""What a sweep varies and the runs it makes: `--vary NAME=SPEC` (or a sweep file), sampled by
random draws, a Latin hypercube (`scipy.stats.qmc`) or a full grid, reproducibly from a seed.

NAME is any override `twmr.load` accepts (`plant.scale`, `slip.slip_gain`, `experiment.step`,
`ctrl.step_multiple`), or one element of a vector, 1-based (`plant.pose[1]`). SPEC:

- ``uniform:LO:HI``: uniform on [LO, HI];
- ``normal:MU:SIGMA``: normal;
- ``values:A,B,C``: one of the listed values (YAML scalars: numbers, true/false, text);
- ``grid:LO:HI:N``: N evenly spaced values from LO to HI.

Methods: ``random`` draws `samples` runs independently (`values`/`grid` uniformly among their
values); ``lhs`` stratifies every continuous distribution over `samples` runs (values and grids:
stratified over their indices); ``grid`` runs the full factorial of the `values`/`grid` specs
(each `uniform` becomes `samples` evenly spaced values; `normal` is refused).
"""
from __future__ import annotations

import hashlib
import json
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError

METHODS = ("random", "lhs", "grid")
#: the most runs one sweep makes (and the longest grid axis): its table is built in memory
MAX_RUNS = 100_000
_NAME = re.compile(r"^([A-Za-z_][\w-]*(?:\.[A-Za-z_]\w*)*)\.([A-Za-z_]\w*)(?:\[(\d+)\])?$")


class SweepError(CosimError):
    """A sweep that cannot be set up (a bad --vary, sweep file or option)."""


@dataclass(frozen=True)
class Vary:
    """One varied override: NAME (component.parameter, optionally [element], 1-based) and its
    distribution."""

    name: str
    kind: str
    args: tuple[Any, ...]

    @property
    def text(self) -> str:
        """The SPEC as written, e.g. 'uniform:0.9:1.1'."""
        if self.kind == "values":
            return "values:" + ",".join(str(a) for a in self.args)
        return ":".join([self.kind, *(f"{a:g}" for a in self.args)])

    @property
    def target(self) -> tuple[str, int | None]:
        """(override key 'comp.param', 0-based element or None)."""
        m = _NAME.match(self.name)
        assert m is not None
        index = int(m.group(3)) - 1 if m.group(3) else None
        return f"{m.group(1)}.{m.group(2)}", index

    @property
    def choices(self) -> list[Any] | None:
        """The discrete values of a `values` or `grid` spec (None for distributions)."""
        if self.kind == "values":
            return list(self.args)
        if self.kind == "grid":
            lo, hi, n = self.args
            return [float(v) for v in np.linspace(lo, hi, n)]
        return None

    def from_unit(self, u: np.ndarray) -> list[Any]:
        """Values for quantiles `u` in [0, 1)."""
        choices = self.choices
        if choices is not None:
            idx = np.minimum((u * len(choices)).astype(int), len(choices) - 1)
            return [choices[i] for i in idx]
        if self.kind == "uniform":
            lo, hi = self.args
            return [float(v) for v in lo + u * (hi - lo)]
        from scipy.stats import norm

        mu, sigma = self.args
        return [float(v) for v in norm.ppf(np.clip(u, 1e-12, 1 - 1e-12), mu, sigma)]


def parse_vary(text: str, where: str = "--vary") -> Vary:
    """`NAME=SPEC` as a Vary; SweepError naming `where` when it cannot be read."""
    name, sep, spec = str(text).partition("=")
    name, spec = name.strip(), spec.strip()
    hint = ("write NAME=uniform:LO:HI, normal:MU:SIGMA, values:A,B,C or grid:LO:HI:N, e.g. "
            "--vary plant.scale=uniform:0.9:1.1")
    if not sep or not _NAME.match(name):
        raise SweepError(f"{where} {text!r}: cannot read it. Fix: {hint}.")
    kind, _, rest = spec.partition(":")
    parts = rest.split(":") if rest else []
    try:
        if kind == "values":
            import yaml

            values = [_scalar(yaml.safe_load(v)) for v in rest.split(",")] if rest else []
            if not values or any(v is None for v in values):
                raise ValueError("give at least one value, separated by commas")
            return Vary(name, kind, tuple(values))
        numbers = tuple(float(p) for p in parts)
        if not all(math.isfinite(x) for x in numbers):
            raise ValueError("numbers must be finite")
        if kind in ("uniform", "normal") and len(numbers) == 2:
            if kind == "uniform" and not numbers[0] <= numbers[1]:
                raise ValueError(f"LO {numbers[0]:g} is above HI {numbers[1]:g}")
            if kind == "normal" and not numbers[1] >= 0:
                raise ValueError(f"SIGMA {numbers[1]:g} is negative")
            return Vary(name, kind, numbers)
        if kind == "grid" and len(numbers) == 3:
            n = numbers[2]
            if n != int(n) or n < 1:
                raise ValueError(f"N = {parts[2]} is not a positive whole number")
            if n > MAX_RUNS:
                raise ValueError(f"N = {parts[2]} is more than the {MAX_RUNS:,} runs a sweep "
                                 f"makes at most")
            return Vary(name, kind, (numbers[0], numbers[1], int(n)))
    except ValueError as err:
        raise SweepError(f"{where} {text!r}: {err}. Fix: {hint}.") from None
    raise SweepError(f"{where} {text!r}: '{spec}' is not a distribution this sweep knows. "
                     f"Fix: {hint}.")


def _scalar(value: Any) -> Any:
    """A YAML scalar, with '1e-3'-style text (YAML 1.1 reads it as text) as a number."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


@dataclass
class SweepSpec:
    """A whole sweep: the scenario, what varies, how it is sampled, which metrics are kept."""

    scenario: str
    vary: list[Vary]
    samples: int = 20
    method: str = "random"
    seed: int = 0
    metrics: list[str] = field(default_factory=list)
    fixed: list[str] = field(default_factory=list)  # overrides applied to every run

    def check(self) -> None:
        """SweepError when the sweep is ill-formed or would make more than MAX_RUNS runs."""
        if self.method not in METHODS:
            raise SweepError(f"--method {self.method!r} is unknown. Fix: use one of "
                             f"{', '.join(METHODS)}.")
        if not _whole(self.samples) or self.samples < 1:
            raise SweepError(f"--samples {self.samples!r} is not a positive whole number. Fix: "
                             f"give the number of runs, e.g. --samples 20.")
        if not _whole(self.seed) or self.seed < 0:
            raise SweepError(f"--seed {self.seed!r} is not a whole number from 0 up. Fix: give "
                             f"e.g. --seed 1.")
        names = [v.name for v in self.vary]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise SweepError(f"{', '.join(twice)} varied twice. Fix: give each NAME once.")
        if not self.vary:
            raise SweepError("nothing to vary. Fix: give at least one --vary NAME=SPEC.")
        if self.method == "grid" and any(v.kind == "normal" for v in self.vary):
            raise SweepError("a grid cannot hold a normal distribution. Fix: use --method "
                             "random or lhs, or give values:/grid: for that parameter.")
        runs = self.samples
        if self.method == "grid":
            runs = math.prod(len(v.args) if v.kind == "values" else
                             v.args[2] if v.kind == "grid" else self.samples for v in self.vary)
        if runs > MAX_RUNS:
            raise SweepError(f"the sweep would make {runs:,} runs, more than the {MAX_RUNS:,} "
                             f"one sweep makes at most. Fix: give fewer --samples (or shorter "
                             f"grids); a larger study is several sweeps (other seeds, other "
                             f"--out folders).")

    def samples_table(self) -> list[dict[str, Any]]:
        """One {NAME: value} per run, in run order; the same for the same seed."""
        self.check()
        if self.method == "grid":
            axes = [v.choices if v.choices is not None else
                    [float(x) for x in np.linspace(v.args[0], v.args[1], self.samples)]
                    for v in self.vary]
            grid = np.array(np.meshgrid(*[np.arange(len(a)) for a in axes], indexing="ij"))
            idx = grid.reshape(len(axes), -1).T
            return [{v.name: axes[k][i]
                     for k, (v, i) in enumerate(zip(self.vary, row, strict=True))}
                    for row in idx]
        rng = np.random.default_rng(self.seed)
        if self.method == "lhs":
            from scipy.stats import qmc

            u = qmc.LatinHypercube(d=len(self.vary), seed=rng).random(self.samples)
        else:
            u = rng.random((self.samples, len(self.vary)))
        columns = [v.from_unit(u[:, k]) for k, v in enumerate(self.vary)]
        return [{v.name: columns[k][i] for k, v in enumerate(self.vary)}
                for i in range(self.samples)]


def _whole(value: Any) -> bool:
    """An int that is no bool (YAML reads `true` as one)."""
    return isinstance(value, int) and not isinstance(value, bool)


def run_id(values: dict[str, Any], fixed: Sequence[str] = ()) -> str:
    """The id of the run with these overrides: a hash of them (12 hex digits), so a resumed
    sweep recognises the runs it has done."""
    text = json.dumps({"vary": {k: values[k] for k in sorted(values)}, "fixed": list(fixed)},
                      sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:12]


#: what a sweep file may hold: key -> (what its value is, the test of it)
_FILE_KEYS: dict[str, tuple[str, Any]] = {
    "scenario": ("the path of the scenario file", lambda v: isinstance(v, str) and v),
    "vary": ("a mapping of NAME to SPEC, e.g. 'plant.scale: uniform:0.9:1.1'",
             lambda v: isinstance(v, dict) and all(isinstance(x, str | int | float) and
                                                    not isinstance(x, bool) for x in v.values())),
    "samples": ("a positive whole number", lambda v: _whole(v) and v >= 1),
    "method": (f"one of {', '.join(METHODS)}", lambda v: v in METHODS),
    "seed": ("a whole number from 0 up", lambda v: _whole(v) and v >= 0),
    "metrics": ("a list of metric set names, e.g. [tracking]",
                lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v)),
    "set": ("a list of overrides, e.g. ['experiment.stop=1.0']",
            lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v)),
    "workers": ("a positive whole number of local worker processes",
                lambda v: _whole(v) and v >= 1),
    "out": ("the path of the sweep's folder", lambda v: isinstance(v, str) and v),
    "keep_signals": ("true or false", lambda v: isinstance(v, bool)),
}


def read_sweep_file(path: Path) -> dict[str, Any]:
    """A sweep file (YAML): scenario, vary {NAME: SPEC}, samples, method, seed, metrics, set,
    workers, out, keep_signals, each checked before anything is drawn or allocated. A scheduler
    address is never read from a file (see docs/sweeps.md)."""
    from twmr.scenario.yamlread import read, read_file

    data, lines = read(read_file(path), str(path))
    if not isinstance(data, dict):
        raise SweepError(f"{path}: a sweep file is a mapping (scenario:, vary:, samples:, ...). "
                         f"Fix: see docs/sweeps.md.")
    if "scheduler" in data:
        raise SweepError(f"{lines.at('scheduler')}: a sweep file cannot name a Dask scheduler: "
                         f"a cluster runs code in twmr and is trusted, so only the person "
                         f"running the sweep chooses one. Fix: remove 'scheduler:' from the "
                         f"file and give `--scheduler ADDRESS` on the command line (or "
                         f"scheduler= to twmr.sweep) for a cluster you trust.")
    unknown = sorted(set(data) - set(_FILE_KEYS))
    if unknown:
        raise SweepError(f"{lines.at(unknown[0])}: unknown key(s) {', '.join(unknown)}. Fix: "
                         f"use {', '.join(sorted(_FILE_KEYS))}.")
    for key, value in data.items():
        what, valid = _FILE_KEYS[key]
        if not valid(value):
            raise SweepError(f"{lines.at(key)}: {key} is {_shown(value)}, not {what}. Fix: "
                             f"write {key}: as {what}.")
    data["vary"] = [parse_vary(f"{k}={v}", f"{lines.at('vary', k)}")
                    for k, v in (data.get("vary") or {}).items()]
    return data


def _shown(value: Any) -> str:
    """A value as a message shows it: short, with its YAML type."""
    text = repr(value)
    text = text if len(text) <= 40 else text[:37] + "..."
    return f"{text} (a {type(value).__name__})"
