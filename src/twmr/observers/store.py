"""`ResultStore`: the observer that appends the recorded rows to an Arrow IPC stream
(`result.arrows`) as they come, one record batch per chunk.

A stream has no header to fix up at the end: every batch is complete on disk once written, so the
file stays readable after SIGKILL, a crash inside an FMU or a full disk — `read_store` keeps every
whole batch and drops a torn last one. Each batch is handed to the operating system when written
(a killed process loses nothing written); it is forced to the disk (fsync) at most every
`sync_seconds`, so a power loss costs at most that much. One float64 column per recorded scalar,
time first; each field carries its unit as metadata. Any number of columns. Recorded Binary
ports go to `ticks.arrows` beside it, in the same way (`twmr.observers.ticks`).
"""
from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import numpy as np

from twmr.observers.base import Observer, Outcome, RunStart
from twmr.observers.ticks import Event, TickStream, TickTable

FILENAME = "result.arrows"


class ResultStore(Observer):
    """Appends rows to `folder/result.arrows`; keeps them in memory when the run has no folder."""

    def __init__(self, sync_seconds: float = 1.0):
        self.sync_seconds = sync_seconds
        self.blocks: list[np.ndarray] = []
        #: the ticks of recorded Binary ports kept in memory (no folder)
        self.events: list[Event] = []
        self.binary: tuple[str, ...] = ()
        self._ticks: TickStream | None = None
        self.columns: tuple[str, ...] = ()
        self.units: tuple[str, ...] = ()
        self.path: Path | None = None
        self._file: Any = None
        self._writer: Any = None
        self._schema: Any = None
        self._synced = 0.0

    def started(self, run: RunStart) -> None:
        self.columns, self.units, self.binary = run.columns, run.units, run.binary
        if run.folder is None:
            return
        if run.binary:
            self._ticks = TickStream(run.folder, run.binary, self.sync_seconds)
        import pyarrow as pa

        fields = [pa.field(c, pa.float64(), metadata={"unit": u})
                  for c, u in zip(run.columns, run.units, strict=False)]
        meta = {"twmr": json.dumps({"scenario": run.scenario, "step": run.step,
                                    "n_steps": run.n_steps, **run.metadata})}
        self._schema = pa.schema(fields, metadata=meta)
        self.path = run.folder / FILENAME
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed in finished()
        self._writer = pa.ipc.new_stream(self._file, self._schema)
        self._synced = time.monotonic()

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        if not len(block):
            return  # a chunk that recorded nothing (decimation, or no signals) adds no batch
        if self._writer is None:
            self.blocks.append(block)
            return
        import pyarrow as pa

        columns = np.ascontiguousarray(block.T, dtype="<f8")
        n = len(block)
        # from the buffers: pa.array(ndarray) would import pandas (~0.15 s) on its first call
        arrays = [pa.Array.from_buffers(pa.float64(), n, [None, pa.py_buffer(col)])
                  for col in columns]
        self._writer.write_batch(pa.RecordBatch.from_arrays(arrays, schema=self._schema))
        self._file.flush()  # the whole batch to the operating system: a killed run keeps it
        if time.monotonic() - self._synced >= self.sync_seconds:
            os.fsync(self._file.fileno())
            self._synced = time.monotonic()

    def ticks(self, events: list[Event], steps_done: int) -> None:
        if self._ticks is None:
            self.events += events
        else:
            self._ticks.write(events)

    def finished(self, outcome: Outcome) -> None:
        ticks, self._ticks = self._ticks, None
        try:
            if self._writer is not None:
                self._writer.close()
                self._file.flush()
                os.fsync(self._file.fileno())
        finally:
            if self._writer is not None:
                self._file.close()
                self._writer = None
            if ticks is not None:
                ticks.close()

    def data(self) -> np.ndarray:
        """The rows kept in memory as one (rows x columns) float64 array."""
        if not self.blocks:
            return np.zeros((0, len(self.columns)))
        if len(self.blocks) == 1:
            return self.blocks[0]
        joined = _joined(self.blocks)
        return joined if joined is not None else np.concatenate(self.blocks)

    def tick_table(self) -> TickTable:
        """The ticks kept in memory, by time."""
        return TickTable.of(self.binary, self.events)


def _joined(blocks: list[np.ndarray]) -> np.ndarray | None:
    """The rows of `blocks` as one array without a copy, when they are consecutive rows of one
    C-contiguous 2-D array (`CompiledStep` records a run into one buffer), else None."""
    blocks = [b for b in blocks if len(b)]
    if not blocks:
        return None
    first = blocks[0]
    base = first.base
    if not isinstance(base, np.ndarray) or base.ndim != 2 or not base.flags.c_contiguous or \
            base.dtype != first.dtype or base.shape[1:] != first.shape[1:]:
        return None
    at = first.__array_interface__["data"][0]
    row = base.strides[0]
    start, extra = divmod(at - base.__array_interface__["data"][0], row)
    for b in blocks:
        if b.base is not base or not b.flags.c_contiguous or b.shape[1:] != base.shape[1:] or \
                b.__array_interface__["data"][0] != at:
            return None
        at += len(b) * row
    n = sum(len(b) for b in blocks)
    return base[start:start + n] if not extra and start >= 0 and start + n <= len(base) \
        else None


def read_store(path: str | Path) -> tuple[list[str], list[str], np.ndarray, bool]:
    """(columns, units, rows x columns float64 array, complete) of a `result.arrows` file.

    `complete` is False when the stream ends in a torn batch (the writer died while writing it);
    every whole batch before it is returned. The file is read twice: mapped, for the batches'
    sizes (their data untouched), then batch by batch into the array, so the rows are in memory
    once (not as batches and array at the same time)."""
    import pyarrow as pa

    with pa.memory_map(str(path)) as source:
        reader = pa.ipc.open_stream(source)
        schema = reader.schema
        sizes, complete = [], True
        while True:
            try:
                sizes.append(reader.read_next_batch().num_rows)
            except StopIteration:
                break
            except (OSError, pa.ArrowInvalid):
                complete = False
                break
    columns = list(schema.names)
    units = [(f.metadata or {}).get(b"unit", b"").decode() for f in schema]
    data = np.zeros((sum(sizes), len(columns)))  # its pages taken as the rows are written
    row = 0
    with pa.OSFile(str(path)) as source:
        reader = pa.ipc.open_stream(source)
        for n in sizes:
            try:
                b = reader.read_next_batch()
            except (StopIteration, OSError, pa.ArrowInvalid):  # cut short since it was mapped
                return columns, units, data[:row], False
            for j in range(len(columns)):  # from the buffers: to_numpy() would import pandas
                col = b.column(j)
                data[row:row + n, j] = np.frombuffer(
                    col.buffers()[1], dtype="<f8", count=len(col), offset=8 * col.offset)
            row += n
    return columns, units, data, complete
