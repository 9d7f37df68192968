"""`Recorder`: the observer that streams recorded signals to a `.npy` file while the system runs.

The result is a numpy structured array with a float64 field `time` [s] and one float64 field per
recorded scalar, vector ports as `inst.port[1]..inst.port[n]` (1-based, as Modelica tools name
them). Rows are buffered in a short list and appended to the file every `chunk` rows, so memory does
not grow with the length of the run; the file header is rewritten with the final row count on
`close()`, also after an error, so what was computed is on disk and loadable with `np.load`.
"""
from __future__ import annotations

import os
import struct
import tempfile
from pathlib import Path

import numpy as np

from twmr.scenario.system import System

_MAGIC = b"\x93NUMPY\x02\x00"
_SHAPE_ROOM = 24  # spaces kept in the header so any row count fits when it is rewritten


def columns_of(system: System, signals: list[tuple[str, str]]) -> tuple[list[str], list[str]]:
    """Column names and units of the recorded signals, time first."""
    names, units = ["time"], ["s"]
    for inst, port in signals:
        var = system.components[inst].variables[port]
        if var.size is None:
            names.append(f"{inst}.{port}")
            units.append(var.element_unit(0))
        else:
            for i in range(var.width):
                names.append(f"{inst}.{port}[{i + 1}]")
                units.append(var.element_unit(i))
    return names, units


class Recorder:
    """Collects rows (t, values...) appended by the master and streams them to `path`."""

    def __init__(self, system: System, path: str | Path | None = None, chunk: int = 4096):
        self.signals = list(system.record.signals)
        self.decimation = system.record.decimation
        self.columns, self.units_list = columns_of(system, self.signals)
        self.units = dict(zip(self.columns, self.units_list))
        self.dtype = np.dtype([(c, "<f8") for c in self.columns])
        self.temporary = path is None
        if path is None:
            fd, tmp = tempfile.mkstemp(prefix="twmr-", suffix=".npy")
            os.close(fd)
            path = tmp
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.chunk = chunk
        self.rows: list[tuple[float, ...]] = []
        self.count = 0
        self._file = open(self.path, "wb")  # noqa: SIM115 - closed in close()
        self._header_len = self._write_header(0)

    def _header_bytes(self, n: int, pad_to: int = 0) -> bytes:
        text = repr({"descr": np.lib.format.dtype_to_descr(self.dtype), "fortran_order": False,
                     "shape": (n,)})
        body_len = len(text) + 1 + (0 if pad_to else _SHAPE_ROOM)
        total = pad_to or -(-(len(_MAGIC) + 4 + body_len) // 64) * 64
        text = text.ljust(total - len(_MAGIC) - 4 - 1) + "\n"
        return _MAGIC + struct.pack("<I", len(text)) + text.encode("latin1")

    def _write_header(self, n: int) -> int:
        head = self._header_bytes(n, getattr(self, "_header_len", 0))
        self._file.seek(0)
        self._file.write(head)
        self._file.seek(0, os.SEEK_END)
        return len(head)

    def flush(self) -> None:
        """Append the buffered rows to the file."""
        if self.rows:
            block = np.asarray(self.rows, dtype="<f8")
            self._file.write(block.tobytes())
            self.count += len(self.rows)
            self.rows.clear()

    def close(self) -> None:
        """Flush, write the final row count into the header and close the file (idempotent)."""
        if self._file.closed:
            return
        self.flush()
        self._write_header(self.count)
        self._file.close()

    def result(self) -> np.ndarray:
        """The recorded structured array: memory-mapped from the file (read-only), or loaded and
        the file deleted when no path was given."""
        self.close()
        if self.count == 0:
            return np.zeros(0, dtype=self.dtype)
        if self.temporary:
            data = np.load(self.path)
            self.path.unlink(missing_ok=True)
            return data
        return np.load(self.path, mmap_mode="r")
