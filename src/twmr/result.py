"""`Result`: the recorded signals of one run, and `read_result` for a run's folder or any export.

`result.time`, `result["plant.pose[1]"]` (a column), `result.data` (a numpy structured array, one
field per column), `result.to_pandas()` (a DataFrame, time column `time`, units in `attrs`),
`result.summary` (what `summary.json` says: status, error, statistics, pacing).

Recorded Binary ports (`result.binary`) are kept at their ticks (`twmr.observers.ticks`):
`result["n1.CanChannel.Tx_Data"]` is the bytes of each tick (an object array),
`result.tick_times(name)` their times [s], `result.ticks` the table of every port by time.
"""
from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.core.jsonvalues import revive
from twmr.observers.store import FILENAME as STORE
from twmr.observers.store import read_store
from twmr.observers.summary import FILENAME as SUMMARY
from twmr.observers.ticks import FILENAME as TICKS
from twmr.observers.ticks import TickTable, instant, read_ticks
from twmr.observers.writers import format_of_suffix, result_formats
from twmr.registry import FORMATS, plugins


class Result:
    """Recorded columns (time first) of one run, with their units and the run's summary; the
    recorded Binary ports at their ticks (`ticks`)."""

    def __init__(self, columns: list[str], units: list[str], values: np.ndarray,
                 summary: dict[str, Any] | None = None, folder: Path | None = None,
                 intact: bool = True, ticks: TickTable | None = None):
        self.columns = list(columns)
        self.units = dict(zip(columns, units, strict=False))
        self.values = np.ascontiguousarray(values, dtype=float).reshape(-1, len(columns))
        self.summary = summary or {}
        self.folder = folder
        #: False when the store ended in a torn chunk (the run was killed while writing it)
        self.intact = intact
        self.ticks = ticks if ticks is not None else TickTable()

    @property
    def binary(self) -> list[str]:
        """The recorded Binary ports ('n1.CanChannel.Tx_Data')."""
        return self.ticks.names

    def tick_times(self, name: str) -> np.ndarray:
        """The times [s] of the ticks of Binary port `name` (those of `result[name]`)."""
        return self._ticks_of(name)[0]

    def _ticks_of(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        if name not in self.ticks.names:
            raise KeyError(f"no Binary port '{name}'; recorded: {', '.join(self.binary)}")
        return self.ticks.ticks(name)

    @property
    def status(self) -> str:
        """'completed', 'failed', 'interrupted', or 'unknown' (no summary: the run was killed)."""
        return str(self.summary.get("status", "unknown"))

    @property
    def data(self) -> np.ndarray:
        """The values as a numpy structured array (a view, no copy)."""
        dtype = np.dtype([(c, "<f8") for c in self.columns])
        return self.values.view(dtype).reshape(-1)

    @property
    def time(self) -> np.ndarray:
        return self.values[:, 0]

    def __getitem__(self, column: str) -> np.ndarray:
        if column in self.ticks.names:
            return self._ticks_of(column)[1]
        try:
            return self.values[:, self.columns.index(column)]
        except ValueError:
            raise KeyError(f"no column '{column}'; recorded: "
                           f"{', '.join(self.columns + self.binary)}") from None

    def __len__(self) -> int:
        return len(self.values)

    def __repr__(self) -> str:
        span = f", t = {self.time[0]:g}..{self.time[-1]:g} s" if len(self) else ""
        binary = f", {len(self.binary)} Binary ports at {len(self.ticks)} times" \
            if self.binary else ""
        return (f"<Result {self.status}: {len(self)} rows x {len(self.columns) - 1} signals"
                f"{span}{binary}{f', in {self.folder}' if self.folder else ''}>")

    def plot(self, signals: str | None = None, others: Mapping[str, Result] | None = None,
             label: str = "this run") -> Any:
        """A matplotlib figure of `signals` ('a,b': a panel each, a vector port for its
        elements, 'a+b' in one panel; default every recorded port) over time, with the runs in
        `others` ({label: Result}) drawn in the same panels, the ports' limits dashed and this
        run's events marked. KeyError naming a signal no run has."""
        from twmr.plots import event_marks, group_ports, overlay_figure, panels_of

        runs = [(label, self), *(others or {}).items()]
        columns = sorted({c for _, r in runs for c in r.columns if c != "time"})
        spec = signals or ",".join(group_ports(self.columns))
        return overlay_figure(runs, panels_of(spec, columns), event_marks(self.summary))

    def _repr_html_(self) -> str:
        """A notebook's view: the status, the span and one row per signal with its unit and its
        first, last, minimum and maximum values."""
        from html import escape

        rows = []
        for j, column in enumerate(self.columns[1:], start=1):
            v = self.values[:, j]
            cells = [f"{x:.6g}" for x in (v[0], v[-1], np.nanmin(v), np.nanmax(v))] \
                if len(v) and not np.isnan(v).all() else ["", "", "", ""]
            rows.append(f"<tr><td>{escape(column)}</td><td>{escape(self.units.get(column, ''))}"
                        f"</td>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>")
        head = "".join(f"<th>{h}</th>" for h in ("signal", "unit", "first", "last", "min",
                                                 "max"))
        return (f"<p>{escape(repr(self))}</p><table><thead><tr>{head}</tr></thead><tbody>"
                f"{''.join(rows)}</tbody></table>")

    def to_pandas(self) -> Any:
        """A pandas DataFrame: column `time` [s] and one column per recorded scalar, named like
        `plant.pose[1]`; `df.attrs['units']` maps each column to its unit. A recorded Binary
        port is a column of `bytes` where it ticked and None elsewhere: in the recorded row of
        the tick's instant (`twmr.observers.ticks.instant`), else in a row of its own (the
        numbers NaN) at the tick's time."""
        import pandas as pd

        df = pd.DataFrame(self.values, columns=self.columns)
        units = dict(self.units)
        if self.binary:
            times = self.ticks.time
            at = np.searchsorted(self.time, times - [instant(t) for t in times])
            hit = at < len(self)
            hit[hit] = np.abs(self.time[at[hit]] - times[hit]) <= [instant(t)
                                                                  for t in times[hit]]
            ticks = self.ticks.to_pandas()
            for name in self.binary:
                column = np.full(len(df), None, dtype=object)
                column[at[hit]] = ticks[name].to_numpy()[hit]
                df[name] = column
                units[name] = ""
            df = pd.concat([df, ticks[~hit]], ignore_index=True) \
                .sort_values("time", kind="stable", ignore_index=True)
        df.attrs["units"] = units
        return df


def read_result(path: str | Path) -> Result:
    """The result in a run's folder (`result.arrows`, also after a crash), or in one of its
    exports (a file of a registered result format that can be read: .csv with `units.json`
    beside it, .mat, .parquet; units it lacks come from the run's summary); the recorded Binary
    ports from `ticks.arrows` in the same folder."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    summary = _summary(folder)
    try:
        if path.is_dir():
            if not (path / STORE).is_file():
                raise CosimError(f"{path}: no {STORE} in this folder{_siblings(path)}. Fix: give "
                                 f"the folder `twmr run` wrote (results/<scenario>).")
            path = path / STORE
        if not path.is_file():
            raise CosimError(f"{path}: no such result{_siblings(path)}. Fix: give the folder "
                             f"`twmr run` wrote or one of its result files.")
        ticks, ticks_intact = _ticks(folder)
        if path.suffix.lower() == ".arrows":
            columns, units, values, intact = read_store(path)
            return Result(columns, units, values, summary, folder, intact and ticks_intact,
                          ticks)
        fmt = format_of_suffix(path.suffix)
        if fmt is not None:
            columns, units, values = fmt.read(path)
            unit_of = summary.get("units", {})
            units = [u or unit_of.get(c, "") for c, u in zip(columns, units, strict=True)]
            return Result(columns, units, values.reshape(-1, len(columns)), summary, folder,
                          ticks_intact, ticks)
    except CosimError:
        raise
    except Exception as exc:  # noqa: BLE001 - any unreadable file is reported plainly
        raise CosimError(f"{path}: cannot read this result ({type(exc).__name__}: {exc}). Fix: "
                         f"give a result written by twmr (result.arrows or an export: "
                         f"{_readable()}).") from None
    raise CosimError(f"{path}: unknown result format '{path.suffix}'. Fix: give a folder, or a "
                     f"result.arrows or export file ({_readable()}).")


def _ticks(folder: Path) -> tuple[TickTable | None, bool]:
    """The recorded Binary ports in `folder/ticks.arrows` (None: there is none), and whether
    its last batch is whole."""
    if not (folder / TICKS).is_file():
        return None, True
    names, events, intact = read_ticks(folder / TICKS)
    return TickTable.of(names, events), intact


def _readable() -> str:
    """The suffixes of the registered result formats, e.g. '.csv, .mat, .parquet'."""
    return ", ".join(f.suffix for f in result_formats(plugins(FORMATS)).values())


def _siblings(path: Path) -> str:
    """' (partial results of runs that did not complete: ...)' when there are some beside."""
    found = sorted(path.parent.glob(f"{path.name}.partial-*")) + \
        sorted(path.parent.glob(f"{path.name}.incomplete"))
    return f" (results of runs that did not complete: {', '.join(map(str, found))})" \
        if found else ""


def _summary(folder: Path) -> dict[str, Any]:
    try:
        return revive(json.loads((folder / SUMMARY).read_text()))
    except (OSError, ValueError):
        return {}
