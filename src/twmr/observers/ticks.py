"""The ticks of recorded Binary ports (`twmr.master.ticks`): `ticks.arrows` beside
`result.arrows`, and `TickTable`, what `twmr.Result` reads from it.

`ticks.arrows` is an Arrow IPC stream as `result.arrows` is (each batch whole on disk once
written, a torn last one dropped when read): column `time` (float64 [s]) and one large_binary
column per recorded Binary port, a row per event in the order taken, null in the other ports'
columns. `TickTable` is the table of those events by time: one row per instant at which some port
ticked (sorted; times closer than `instant(t)` are one), a port's bytes where it ticked there
(two ticks of one port at one instant back to back), None where it did not.
"""
from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

FILENAME = "ticks.arrows"
#: (time [s], index of the port, bytes)
Event = tuple[float, int, bytes]


def instant(t: float) -> float:
    """Times closer than this [s] to t are one instant (as for an FMU's events)."""
    return 1e-9 * max(1.0, abs(t))


class TickStream:
    """Appends events to `folder/ticks.arrows`; `sync_seconds` as `ResultStore`'s."""

    def __init__(self, folder: Path, names: Sequence[str], sync_seconds: float):
        import pyarrow as pa

        self.names = list(names)
        self.path = folder / FILENAME
        self._schema = pa.schema([pa.field("time", pa.float64(), metadata={"unit": "s"})] +
                                 [pa.field(n, pa.large_binary()) for n in self.names])
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        self._writer = pa.ipc.new_stream(self._file, self._schema)
        self.sync_seconds = sync_seconds
        self._synced = time.monotonic()

    def write(self, events: Sequence[Event]) -> None:
        import pyarrow as pa

        columns: list[list[bytes | None]] = [[None] * len(events) for _ in self.names]
        for row, (_, k, data) in enumerate(events):
            columns[k][row] = data
        arrays = [pa.array([t for t, _, _ in events], pa.float64())] + \
            [pa.array(c, pa.large_binary()) for c in columns]
        self._writer.write_batch(pa.RecordBatch.from_arrays(arrays, schema=self._schema))
        self._file.flush()  # the whole batch to the operating system: a killed run keeps it
        if time.monotonic() - self._synced >= self.sync_seconds:
            os.fsync(self._file.fileno())
            self._synced = time.monotonic()

    def close(self) -> None:
        try:
            self._writer.close()
            self._file.flush()
            os.fsync(self._file.fileno())
        finally:
            self._file.close()


def read_ticks(path: str | Path) -> tuple[list[str], list[Event], bool]:
    """(port names, events, complete) of a `ticks.arrows` file; `complete` False when it ends
    in a torn batch (every whole batch before it is returned)."""
    import pyarrow as pa

    events: list[Event] = []
    complete = True
    with pa.OSFile(str(path)) as source:
        reader = pa.ipc.open_stream(source)
        names = list(reader.schema.names[1:])
        while True:
            try:
                batch = reader.read_next_batch()
            except StopIteration:
                break
            except (OSError, pa.ArrowInvalid):
                complete = False
                break
            times = batch.column(0).to_pylist()
            for k in range(len(names)):
                events += [(times[row], k, data) for row, data in
                           enumerate(batch.column(k + 1).to_pylist()) if data is not None]
    events.sort(key=lambda e: e[0])  # stable: the order taken within one time
    return names, events, complete


@dataclass
class TickTable:
    """Recorded Binary ports by time (see the module docstring): `time` [s] (sorted, one per
    row) and, per port, its bytes at each row (None: it did not tick then)."""

    names: list[str] = field(default_factory=list)
    time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    values: dict[str, list[bytes | None]] = field(default_factory=dict)

    @classmethod
    def of(cls, names: Sequence[str], events: Sequence[Event]) -> TickTable:
        """The table of `events` (any order; those of one instant and port joined in order,
        at the instant's first time)."""
        at: dict[float, dict[int, bytes]] = {}
        first = -np.inf
        for t, k, data in sorted(events, key=lambda e: e[0]):
            if t - first > instant(t):
                first = t
            row = at.setdefault(first, {})
            row[k] = row.get(k, b"") + data
        times = list(at)
        return cls(list(names), np.array(times, dtype=float),
                   {n: [at[t].get(k) for t in times] for k, n in enumerate(names)})

    def __len__(self) -> int:
        return len(self.time)

    def ticks(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(times [s], bytes as an object array) of the ticks of port `name`."""
        rows = [i for i, v in enumerate(self.values[name]) if v is not None]
        data = np.empty(len(rows), dtype=object)
        data[:] = [self.values[name][i] for i in rows]
        return self.time[rows], data

    def to_pandas(self) -> Any:
        """A DataFrame: `time` and one column of bytes (or None) per port."""
        import pandas as pd

        return pd.DataFrame({"time": self.time, **{n: pd.Series(v, dtype=object)
                                                   for n, v in self.values.items()}})
