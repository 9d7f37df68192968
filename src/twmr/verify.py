"""A run checked against a reference (`twmr verify`, `twmr.testing.assert_matches`): each signal
must stay inside a tolerance tube around the reference, as the FMI cross-check's csv-compare
judges results. The tube at time t spans the reference's values over [t - shift, t + shift]
(its samples in the window and its linear interpolation at the window's ends), widened by
abs + rel * (the largest magnitude in that span). The run is judged at its own points (what a
co-simulation computes; between them it has no values), over the reference's time span, which
the run must cover. The reference is linear between its samples, and held at its ends."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from twmr.core.errors import CosimError
from twmr.plots import port_columns
from twmr.result import Result, read_result


@dataclass(frozen=True)
class Tolerance:
    """The tube's half-height abs + rel |reference| [signal's unit] and half-width `shift` [s]."""

    abs: float = 0.0
    rel: float = 1e-3
    shift: float = 0.0

    def __post_init__(self) -> None:
        for name in ("abs", "rel", "shift"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise CosimError(f"the tolerance {name} is {value}. Fix: give a finite value of "
                                 f"at least 0.")
        if self.abs == self.rel == self.shift == 0.0:
            raise CosimError("every tolerance is 0: the tube is the reference itself. Fix: give "
                             "abs, rel or shift above 0.")


@dataclass(frozen=True)
class SignalVerdict:
    """One signal: whether it stays in the tube; where it leaves: the points outside, the first
    time outside, the largest distance outside the tube [unit] and its time."""

    name: str
    unit: str
    passed: bool
    points: int
    outside: int = 0
    first_out: float = math.nan
    worst: float = 0.0
    worst_time: float = math.nan
    note: str = ""


@dataclass
class Verdict:
    """Every signal's verdict; `passed` when all stay in their tubes."""

    signals: list[SignalVerdict]
    tolerance: Tolerance
    run: str = ""
    reference: str = ""
    tubes: dict[str, tuple[np.ndarray, ...]] = field(default_factory=dict, repr=False)

    @property
    def passed(self) -> bool:
        return all(s.passed for s in self.signals)

    def text(self) -> str:
        """A table: each signal, pass or FAIL, where and by how much it leaves its tube."""
        tol = self.tolerance
        lines = [f"{self.run} against {self.reference} (abs {tol.abs:g}, rel {tol.rel:g}, "
                 f"shift {tol.shift:g} s)"]
        width = max([len(s.name) for s in self.signals] + [6])
        for s in self.signals:
            if s.passed:
                lines.append(f"  {s.name:<{width}}  pass  ({s.points} points in the tube)")
            elif s.note:
                lines.append(f"  {s.name:<{width}}  FAIL  {s.note}")
            else:
                lines.append(f"  {s.name:<{width}}  FAIL  {s.outside} of {s.points} points out "
                             f"of the tube from t = {s.first_out:.6g} s; at most "
                             f"{s.worst:.4g}{' ' + s.unit if s.unit else ''} outside, at t = "
                             f"{s.worst_time:.6g} s")
        failed = sum(not s.passed for s in self.signals)
        lines.append(f"{len(self.signals) - failed} of {len(self.signals)} signals pass" +
                     ("" if not failed else f"; {failed} FAIL"))
        return "\n".join(lines)


def verify(run: str | Path | Result, reference: str | Path | Result,
           tolerance: Tolerance | None = None, signals: list[str] | None = None) -> Verdict:
    """`run` (a run's folder or a result file) against `reference` (one of those, or a CSV
    with 'name [unit]' headers or units.json) for `signals` (default: every signal both have);
    a reference's unit is converted to the run's. CosimError for what cannot be compared."""
    from twmr.blocks.datafiles import split_units

    tol = tolerance or Tolerance()
    ran, ref = _result(run), _result(reference)
    run_all, run_units = split_units(ran.columns, ran.units)
    names, units = split_units(ref.columns, ref.units)
    run_at = {n: j for j, n in enumerate(run_all)}
    ref_at = {n: j for j, n in enumerate(names)}
    for at, label in ((run_at, run), (ref_at, reference)):
        if "time" not in at:
            raise CosimError(f"{_label(label)}: no time column. Fix: give a result with a "
                             f"'time' column in seconds.")
    run_names = [c for c in run_all if c != "time"]
    chosen = [e for n in signals for e in port_columns(n, run_names) or [n]] if signals else \
        [n for n in run_names if n in ref_at]
    if not chosen:
        raise CosimError(f"{_label(run)} and {_label(reference)} have no signal in common (run: "
                         f"{', '.join(run_names[:8])}; reference: "
                         f"{', '.join(n for n in names if n != 'time')}). Fix: name them with "
                         f"--signals, or give a reference with the run's column names.")
    for name in chosen:
        for where, label in ((run_names, run), (names, reference)):
            if name not in where:
                from twmr.registry import suggest

                raise CosimError(f"{_label(label)}: no signal '{name}'{suggest(name, where)}. "
                                 f"Fix: name signals both have.")
    t_ref = np.asarray(ref.values[:, ref_at["time"]], dtype=float)
    t_run = np.asarray(ran.values[:, run_at["time"]], dtype=float)
    verdict = Verdict([], tol, _label(run), _label(reference))
    for name in chosen:
        unit = run_units[run_at[name]]
        y_ref = _in_unit(ref.values[:, ref_at[name]], units[ref_at[name]], unit, name, reference)
        verdict.signals.append(_judge(name, unit, t_run, ran.values[:, run_at[name]], t_ref,
                                      y_ref, tol, verdict.tubes))
    return verdict


def _judge(name: str, unit: str, t_run: np.ndarray, y_run: np.ndarray, t_ref: np.ndarray,
           y_ref: np.ndarray, tol: Tolerance, tubes: dict[str, tuple[np.ndarray, ...]]
           ) -> SignalVerdict:
    if len(t_ref) < 1 or not np.all(np.isfinite(y_ref)):
        return SignalVerdict(name, unit, False, 0, note="the reference has no finite values")
    span = max(t_ref[-1] - t_ref[0], 1.0)
    slack = 1e-9 * span + tol.shift
    if len(t_run) == 0 or t_run[0] > t_ref[0] + slack or t_run[-1] < t_ref[-1] - slack:
        covered = f"{t_run[0]:g} .. {t_run[-1]:g} s" if len(t_run) else "nothing"
        return SignalVerdict(name, unit, False, 0, note=f"the run covers {covered}, the "
                             f"reference {t_ref[0]:g} .. {t_ref[-1]:g} s")
    inside = (t_run >= t_ref[0] - 1e-9 * span) & (t_run <= t_ref[-1] + 1e-9 * span)
    times, values = t_run[inside], y_run[inside]
    lo, hi = tube(t_ref, y_ref, times, tol.shift)
    delta = tol.abs + tol.rel * np.maximum(np.abs(lo), np.abs(hi))
    below, above = lo - delta - values, values - hi - delta
    distance = np.maximum(np.maximum(below, above), 0.0)
    distance[~np.isfinite(values)] = math.inf
    tubes[name] = (times, values, lo - delta, hi + delta)
    out = np.flatnonzero(distance > 0.0)
    if not out.size:
        return SignalVerdict(name, unit, True, len(times))
    k = int(np.argmax(distance))
    return SignalVerdict(name, unit, False, len(times), int(out.size), float(times[out[0]]),
                         float(distance[k]), float(times[k]))


def tube(t_ref: np.ndarray, y_ref: np.ndarray, t: np.ndarray, shift: float
         ) -> tuple[np.ndarray, np.ndarray]:
    """The least and greatest value of the reference (linear between its samples) over
    [t - shift, t + shift] at each t."""
    mid = np.interp(t, t_ref, y_ref)
    if shift == 0.0:
        return mid, mid
    ends = np.interp(t - shift, t_ref, y_ref), np.interp(t + shift, t_ref, y_ref)
    lo, hi = np.minimum(mid, np.minimum(*ends)), np.maximum(mid, np.maximum(*ends))
    first = np.searchsorted(t_ref, t - shift, side="left")
    stop = np.searchsorted(t_ref, t + shift, side="right")
    some = stop > first
    if some.any():
        rmin, rmax = _range_extremes(y_ref, first[some], stop[some])
        lo[some], hi[some] = np.minimum(lo[some], rmin), np.maximum(hi[some], rmax)
    return lo, hi


def _range_extremes(y: np.ndarray, first: np.ndarray, stop: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """min and max of y[first[i]:stop[i]] for each i (each range non-empty): a sparse table of
    the powers of two up to the longest range."""
    longest = int((stop - first).max())
    mins, maxs = [y], [y]
    width = 1
    while 2 * width <= longest:
        a, b = mins[-1], maxs[-1]
        mins.append(np.minimum(a[:-width], a[width:]))
        maxs.append(np.maximum(b[:-width], b[width:]))
        width *= 2
    length = stop - first
    level = np.floor(np.log2(length)).astype(int)
    rmin, rmax = np.empty(len(first)), np.empty(len(first))
    for k in np.unique(level):
        sel = level == k
        i, j = first[sel], stop[sel] - (1 << k)
        rmin[sel] = np.minimum(mins[k][i], mins[k][j])
        rmax[sel] = np.maximum(maxs[k][i], maxs[k][j])
    return rmin, rmax


def _in_unit(values: np.ndarray, src: str, dst: str, name: str, where: object) -> np.ndarray:
    values = np.asarray(values, dtype=float)
    if not src or not dst or src == dst:
        return values
    from twmr.core.units import UnitError, conversion

    try:
        gain, offset = conversion(src, dst)
    except UnitError as err:
        raise CosimError(f"{_label(where)}: signal '{name}' is in '{src}', the run's in '{dst}' "
                         f"({err}). Fix: compare a signal with its own quantity.") from None
    return gain * values + offset


def _result(source: str | Path | Result) -> Result:
    return source if isinstance(source, Result) else read_result(source)


def _label(source: object) -> str:
    if isinstance(source, Result):
        return str(source.folder) if source.folder is not None else "the run"
    return str(source)


def plot(verdict: Verdict, path: str | Path) -> list[Path]:
    """Per signal, left: the tube (shaded) and the run, its points outside in red; right: how far
    each point is beyond the tube's edge (negative: the margin inside it), 0 marked."""
    from twmr.plots import axis_label, pyplot, save

    plt = pyplot()
    shown = [s for s in verdict.signals if s.name in verdict.tubes]
    rows = max(len(shown), 1)
    fig, axes = plt.subplots(rows, 2, figsize=(11, 2.2 * rows + 0.6), sharex=True,
                             squeeze=False, gridspec_kw={"width_ratios": (3, 2)})
    for (ax, ex), s in zip(axes, shown, strict=False):
        times, values, lo, hi = verdict.tubes[s.name]
        beyond = np.maximum(values - hi, lo - values)
        bad = ~(beyond <= 0.0)
        ax.fill_between(times, lo, hi, color="#56B4E9", alpha=0.45, lw=0, label="tube")
        ax.plot(times, values, color="#000000", lw=0.9, label="run")
        if bad.any():
            ax.plot(times[bad], np.where(np.isfinite(values[bad]), values[bad], hi[bad]), "o",
                    color="#D55E00", ms=2.5, label="outside")
        ax.set_ylabel(axis_label(s.name, s.unit), fontsize=8)
        ax.set_title(f"{s.name}: {'pass' if s.passed else 'FAIL'}", fontsize=9, loc="left")
        ax.legend(fontsize=7, loc="upper right", frameon=False)
        ex.axhline(0.0, color="#D55E00", lw=0.8)
        ex.plot(times, np.where(np.isfinite(beyond), beyond, np.nan), color="#000000", lw=0.9)
        ex.fill_between(times, 0.0, np.where(bad & np.isfinite(beyond), beyond, 0.0),
                        color="#D55E00", alpha=0.5, lw=0)
        ex.set_ylabel(axis_label("beyond the tube", s.unit), fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    fig.tight_layout()
    return save(fig, path)
