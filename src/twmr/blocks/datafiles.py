"""Measured samples for the `data` block: a column table read from a file — CSV (units from
`name [unit]` headers or a `units.json` beside it), Parquet, MATLAB .mat, MCAP, a twmr result
folder or its `result.arrows` (`twmr.read_result` reads them all), or a CAN frame log decoded
with a database (the `can` reader of `twmr.sample_readers`) — checked as samples must be: every
column asked for present, a time column that never decreases, no NaN, one unit per port. Each
problem names the file, the column and the row."""
from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twmr.core.errors import CosimError

#: a header 'x [m]' (a space before the bracket; 'plant.pose[1]' is a name): name and unit
_UNIT_HEADER = re.compile(r"^(?P<name>\S.*?)\s+\[(?P<unit>[^\[\]]*)\]$")


@dataclass(frozen=True)
class Samples:
    """`times` [s] (m), `values` (m x n: one column per name asked for) and their `unit`."""

    times: np.ndarray
    values: np.ndarray
    unit: str


def _ros2_bag(path: Path) -> bool:
    """Whether `path` is a ROS 2 bag (checked only when the ROS 2 extra is installed)."""
    try:
        from twmr.ros2.bag_samples import is_bag
    except ImportError:
        return False
    return is_bag(path)


def read_samples(path: Path, columns: tuple[str, ...], time_column: str = "time",
                 database: Path | None = None, protocol: str = "") -> Samples:
    """The samples of `columns` over `time_column` in the file (or run folder) `path`, or, with
    a CAN `database`, of the frame log `path` decoded by the `can` sample reader (its columns
    'Message.Signal'), with a drive `protocol`, decoded by the `drive` one (its columns
    '<node>.<signal>'); CosimError naming file, column and row for what cannot be played."""
    from twmr.registry import SAMPLE_READERS, plugin, suggest
    from twmr.result import read_result

    if not path.exists():
        raise CosimError(f"{path}: no such data file. Fix: give the path of a CSV, Parquet or "
                         f".mat file or of a run's folder (or, with a database, of a CAN frame "
                         f"log), relative to the scenario's folder.")
    if database is not None:
        time_column = "time"
        names, units, table = plugin(SAMPLE_READERS, "can", "sample reader")(path, database,
                                                                              columns)
    elif protocol:
        time_column = "time"
        names, units, table = plugin(SAMPLE_READERS, "drive", "sample reader")(path, protocol,
                                                                                columns)
    elif _ros2_bag(path):
        time_column = "time"
        names, units, table = plugin(SAMPLE_READERS, "ros2", "sample reader")(path, columns)
    else:
        result = read_result(path)
        names, units = split_units(result.columns, result.units)
        table = result.values
    where = {name: j for j, name in enumerate(names)}
    for name in (time_column, *columns):
        if name not in where:
            raise CosimError(f"{path}: no column '{name}'{suggest(name, names)} (columns: "
                             f"{', '.join(names[:12])}{', ...' if len(names) > 12 else ''}). "
                             f"Fix: name columns of the file in `columns` (and `time_column`).")
    if len(table) < 2:
        raise CosimError(f"{path}: {len(table)} row(s) of samples; at least two are needed. "
                         f"Fix: give a file with the samples over time.")
    times = np.ascontiguousarray(table[:, where[time_column]], dtype=float)
    picked = np.ascontiguousarray(table[:, [where[c] for c in columns]], dtype=float)
    for name, col in ((time_column, times[:, None]), *((c, picked[:, [j]])
                                                       for j, c in enumerate(columns))):
        bad = np.flatnonzero(~np.isfinite(col[:, 0]))
        if bad.size:
            value = float(col[bad[0], 0])
            what = "no number (empty, or text)" if value != value else str(value)
            raise CosimError(f"{path}: column '{name}' has {what} at "
                             f"{_row(path, int(bad[0]))} ({bad.size} such row(s)). Fix: fill or "
                             f"drop the rows without a value before playing the file.")
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        k = back[0] + 1
        raise CosimError(f"{path}: time column '{time_column}' goes back from "
                         f"{float(times[k - 1])!r} to {float(times[k])!r} at "
                         f"{_row(path, int(k))}. Fix: sort the rows by time (a repeated time "
                         f"is a jump and is allowed).")
    found = {units[where[c]] for c in columns}
    if len(found) > 1:
        listed = ", ".join(f"{c} [{units[where[c]] or 'no unit'}]" for c in columns)
        raise CosimError(f"{path}: the columns played as one port have different units "
                         f"({listed}). Fix: play columns of one unit per data block (one block "
                         f"per unit).")
    time_unit = units[where[time_column]]
    if time_unit not in ("", "s"):
        raise CosimError(f"{path}: time column '{time_column}' is in '{time_unit}', not s. "
                         f"Fix: give times in seconds (or use time_offset and a converted file).")
    return Samples(times, picked, found.pop() if found else "")


def split_units(columns: list[str], units: dict[str, str]) -> tuple[list[str], list[str]]:
    """The column names with any 'name [unit]' header split, and each one's unit."""
    names, found = [], []
    for column in columns:
        unit = units.get(column, "")
        match = _UNIT_HEADER.match(column)
        if match:
            names.append(match["name"])
            found.append(unit or match["unit"].strip())
        else:
            names.append(column)
            found.append(unit)
    return names, found


def _row(path: Path, k: int) -> str:
    """Row k of the samples as a user finds it: the line of a CSV file (after its header),
    else the row counted from 0."""
    if path.suffix.lower() != ".csv":
        return f"row {k} (counted from 0)"
    from twmr.observers.writers import csv_first_row_line

    return f"line {k + csv_first_row_line(path)}"
