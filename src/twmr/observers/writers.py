"""Exports of a recorded result, by registry: a `ResultFormat` registered in the `twmr.formats`
entry-point group under its `--format` name. Built in: CSV (read by `pandas.read_csv` as is;
units in `units.json` beside it), MATLAB `.mat` and Parquet (units as field metadata). All are made
from the crash-consistent store after the run, so a failed export never costs the recorded rows.
Recorded Binary ports (`twmr.observers.ticks`) go to a file of their own where the format holds
them (`ticks.csv`, hex; `ticks.parquet`, binary columns); the others leave them out with a note
(they stay in `ticks.arrows`).
"""
from __future__ import annotations

import json
import logging
import os
import re
import struct
import warnings
import zlib
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from io import BytesIO
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from twmr.core.errors import CosimError
from twmr.observers.ticks import FILENAME as TICKS
from twmr.observers.ticks import TickTable
from twmr.observers.timecolumn import time_column
from twmr.registry import FORMATS, plugin, plugins

UNITS_FILE = "units.json"
#: rows of a CSV export formatted per task (about 20 MB of text for 10 columns)
CSV_ROWS = 100_000
#: zlib level of the MAT export's variables (1: a few % larger than MATLAB's default, 2x faster)
MAT_ZLIB_LEVEL = 1
#: a MAT variable is stored compressed when samples of it shrink below this fraction (a smooth
#: float signal hardly shrinks, at many times the cost of writing it raw)
MAT_COMPRESS_BELOW = 0.8
#: bytes of each of the three samples (start, middle, end) that decide it
MAT_SAMPLE = 1 << 16
log = logging.getLogger("twmr.run")


class ResultFormat:
    """A result export. `write` makes one file from the recorded columns; `read` (optional)
    reads such a file back, so `twmr.read_result` and `twmr plot` take it. Registered in the
    `twmr.formats` group as `NAME = "module:Class"`; `twmr run --format NAME` writes
    `result<suffix>` into the run's folder."""

    #: the file's suffix, with its dot (e.g. '.csv'); the export is `result<suffix>`
    suffix: ClassVar[str] = ""
    #: the file `write_ticks` makes beside it ('': the format leaves Binary ports out)
    ticks_file: ClassVar[str] = ""

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        """Write the export to `path` (a temporary name with `suffix`, in the run's folder,
        renamed to `result<suffix>` once this returns): `columns` ('time' first, then names like
        'plant.pose[1]'), their `units` and `values` (float64, one row per sample). Return the
        other files written beside it (in `path.parent`), if any."""
        raise NotImplementedError

    def read(self, path: Path) -> tuple[list[str], list[str], np.ndarray]:
        """(columns, units ('' where unknown), values) of a file this format wrote."""
        raise NotImplementedError(f"the result format of '{path.suffix}' files cannot be read")

    def write_ticks(self, path: Path, ticks: TickTable) -> None:
        """Write the recorded Binary ports to `path` (a temporary name, renamed to
        `ticks_file`), when the format has a `ticks_file`."""
        raise NotImplementedError


def result_formats(names: Iterable[str]) -> dict[str, ResultFormat]:
    """The registered formats `names`, in that order; `CosimError` (with a suggestion) for a
    name that is not registered."""
    found = {}
    for name in names:
        cls = plugin(FORMATS, name, "result format")
        found[name] = cls() if isinstance(cls, type) else cls
        if not isinstance(found[name], ResultFormat):
            raise CosimError(f"the result format '{name}' ({plugins(FORMATS)[name]}) is not a "
                             f"ResultFormat. Fix: register a subclass of "
                             f"twmr.observers.writers.ResultFormat.")
    return found


def format_of_suffix(suffix: str) -> ResultFormat | None:
    """The registered format writing files with `suffix` (e.g. '.mat'), if any."""
    for name in plugins(FORMATS):
        fmt = result_formats([name])[name]
        if fmt.suffix.lower() == suffix.lower():
            return fmt
    return None


def export(columns: list[str], units: list[str], values: np.ndarray, folder: Path,
           formats: Iterable[str], ticks: TickTable | None = None) -> list[Path]:
    """Write the named formats into `folder` as result<suffix>, and the recorded Binary ports
    `ticks` as each format's `ticks_file` (a note for a format without one); the paths
    written. Each file is written under a temporary name and renamed when complete, so an
    export cut short (Ctrl-C, full disk) never leaves a truncated file under the real name."""
    written = []
    chosen = result_formats(formats)
    if len(chosen) > 1:  # one transposed copy for all: the writers take the columns
        values = np.asfortranarray(values)
    for fmt in chosen.values():
        name = f"result{fmt.suffix}"
        written += [folder / name, *_replaced(folder / name, lambda tmp, f=fmt: f.write(
            tmp, columns, units, values))]
        if not ticks or not ticks.names:
            continue
        if not fmt.ticks_file:
            log.warning("note: %s leaves out the recorded Binary ports (%s); they are in %s "
                        "(twmr.read_result reads them).", name, ", ".join(ticks.names), TICKS)
            continue
        _replaced(folder / fmt.ticks_file, lambda tmp, f=fmt: f.write_ticks(tmp, ticks))
        written.append(folder / fmt.ticks_file)
    return written


def _replaced(path: Path, write: Any) -> list[Path]:
    """`write(tmp)` of a temporary name beside `path` (the same suffix: savemat appends .mat
    otherwise), renamed to `path` when it returns; what it returns (other files written)."""
    tmp = path.with_name(f".partial-{path.name}")
    try:
        extra = write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return list(extra or [])


class Csv(ResultFormat):
    """One header row of column names, then one row per sample (each number in the shortest
    form that reads back to the same double: Arrow's CSV writer); the units in `units.json`
    beside it. Binary ports: `ticks.csv`, a column of hex per port (empty where it did not
    tick)."""

    suffix = ".csv"
    ticks_file = "ticks.csv"

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        import pyarrow as pa
        import pyarrow.csv as pa_csv

        table = pa.Table.from_arrays(_arrow_columns(values),
                                     names=[f"c{j}" for j in range(len(columns))])
        options = pa_csv.WriteOptions(include_header=False)

        def text(first: int) -> Any:
            sink = pa.BufferOutputStream()
            pa_csv.write_csv(table.slice(first, CSV_ROWS), sink, options)
            return sink.getvalue()

        with open(path, "wb") as f:
            f.write((",".join(_csv_field(c) for c in columns) + "\n").encode())
            for chunk in in_threads(text, range(0, len(values), CSV_ROWS)):
                f.write(chunk)
        unit_file = path.parent / UNITS_FILE
        unit_file.write_text(json.dumps(dict(zip(columns, units, strict=False)), indent=1) + "\n")
        return [unit_file]

    def write_ticks(self, path: Path, ticks: TickTable) -> None:
        import csv

        with open(path, "w", newline="") as f:
            out = csv.writer(f, lineterminator="\n")
            out.writerow(["time", *ticks.names])
            for i, t in enumerate(ticks.time):
                row = [ticks.values[n][i] for n in ticks.names]
                out.writerow([f"{t:.17g}", *("" if v is None else v.hex() for v in row)])

    def read(self, path: Path) -> tuple[list[str], list[str], np.ndarray]:
        columns, units, values = read_csv_table(path)
        try:
            unit_of = json.loads((path.parent / UNITS_FILE).read_text())
        except (OSError, ValueError):
            unit_of = {}
        units = [u or unit_of.get(c, "") for c, u in zip(columns, units, strict=True)]
        return columns, units, values.reshape(-1, len(columns))


#: the separators a CSV may use, as the header shows: ',' and, from spreadsheets set for a
#: decimal comma, ';' (then '0,5' is 0.5) or a tab
CSV_SEPARATORS = (",", ";", "\t")


def read_csv_table(path: Path) -> tuple[list[str], list[str], np.ndarray]:
    """(column names, their units ('' where none), float64 rows) of a CSV: a header row of
    names (after any lines starting with '#'), a row of units if the next row holds only text
    (a logger's 's,m,rad' or '[s],[m]'), then rows of numbers (an empty or text cell reads as
    NaN). The header may start with a byte-order mark and be in UTF-8 or Latin-1; the separator
    is the one of `CSV_SEPARATORS` the header uses most. CosimError for an empty file and for
    rows whose length differs from the header's."""
    columns, units, sep, above = _csv_head(path)
    source: Any = path
    if sep == ";":  # a decimal comma
        with open(path, "rb") as f:
            for _ in range(above):
                f.readline()
            source = BytesIO(f.read().replace(b",", b"."))
    with warnings.catch_warnings():  # a header without rows: no samples, said by the caller
        warnings.filterwarnings("ignore", "loadtxt: input contained no data")
        warnings.filterwarnings("ignore", "genfromtxt: Empty input file")
        skip = 0 if sep == ";" else above
        try:
            values = np.loadtxt(source, delimiter=sep, skiprows=skip, ndmin=2,
                                encoding="latin-1")  # numbers: any byte decodes
        except ValueError:  # a column of text, an empty cell: NaN there, the numbers kept
            if isinstance(source, BytesIO):
                source.seek(0)
            try:
                values = np.genfromtxt(source, delimiter=sep, skip_header=skip, dtype=float,
                                       ndmin=2, encoding="latin-1")
            except ValueError as err:
                raise CosimError(f"{path}: {_ragged(str(err), above - skip)}. Fix: give every row "
                                 f"one value per column of the header ({len(columns)}), an "
                                 f"empty cell where a value is missing.") from None
    if not values.size:
        return columns, units, np.empty((0, len(columns)))
    if values.shape[1] != len(columns):
        raise CosimError(f"{path}: the header names {len(columns)} column(s) but the rows hold "
                         f"{values.shape[1]} value(s). Fix: give every row one value per column "
                         f"of the header, an empty cell where a value is missing.")
    return columns, units, values


def _csv_head(path: Path) -> tuple[list[str], list[str], str, int]:
    """(column names, units ('' each where the file has no units row), separator, number of
    lines up to and with the header and units rows) of a CSV; a logger's lines starting with
    '#' before the header are left out."""
    import csv

    with open(path, "rb") as f:
        raw, lines = f.readline(), 1
        while raw.removeprefix(b"\xef\xbb\xbf").startswith(b"#"):
            raw, lines = f.readline(), lines + 1
        second = f.readline()
    header, below = (_text(line) for line in (raw, second))
    if not header.strip():
        raise CosimError(f"{path}: the file is empty (no header row of column names). Fix: give "
                         f"a CSV whose first row names the columns, 'time' first.")
    sep = max(CSV_SEPARATORS, key=header.count)
    columns = [c.strip() for c in next(csv.reader([header], delimiter=sep))]
    cells = [c.strip() for c in next(csv.reader([below], delimiter=sep))] if below.strip() \
        else []
    if len(cells) == len(columns) and any(cells) and not any(_number(c) for c in cells if c):
        return columns, [c.removeprefix("[").removesuffix("]") for c in cells], sep, lines + 1
    return columns, [""] * len(columns), sep, lines


def _text(line: bytes) -> str:
    try:
        return line.decode("utf-8-sig")
    except UnicodeDecodeError:
        return line.decode("latin-1")


#: cells a data row leaves without a value (so a row of them is no units row)
MISSING = frozenset({"na", "n/a", "null", "none", "nil", "missing"})


def _number(cell: str) -> bool:
    """Whether a cell is a number or a missing value, not a unit."""
    if cell.lower() in MISSING:
        return True
    try:
        float(cell.replace(",", "."))
    except ValueError:
        return False
    return True


def csv_first_row_line(path: Path) -> int:
    """The line number (from 1) of a CSV's first row of samples, below its header (and units
    row)."""
    return _csv_head(path)[3] + 1


def _ragged(numpy_says: str, lines_before: int) -> str:
    """numpy's report of rows of different lengths, as one sentence (its line numbers count
    from the text it was given: `lines_before` lines of the file precede that)."""
    found = re.search(r"Line #(\d+) \(got (\d+) columns instead of (\d+)\)", numpy_says)
    if not found:
        return f"cannot read the rows as numbers ({numpy_says.strip()})"
    line, got, wanted = found.groups()
    return (f"line {int(line) + lines_before} has {got} values where the rows before it have "
            f"{wanted}")


def _arrow_columns(values: np.ndarray) -> list[Any]:
    """Each column of `values` as an Arrow float64 array over its own contiguous copy."""
    import pyarrow as pa

    n = len(values)
    return [pa.Array.from_buffers(pa.float64(), n, [None, pa.py_buffer(
        np.ascontiguousarray(values[:, j], dtype="<f8"))]) for j in range(values.shape[1])]


def in_threads(fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
    """fn(item) for each item, in order, computed on one thread per core (for work that
    releases the GIL: Arrow's writers, zlib), at most two per thread ahead of the reader."""
    workers = os.cpu_count() or 1
    with ThreadPoolExecutor(workers) as pool:
        pending: deque[Any] = deque()
        for item in items:
            pending.append(pool.submit(fn, item))
            if len(pending) >= 2 * workers:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()


def _csv_field(name: str) -> str:
    return f'"{name}"' if any(ch in name for ch in ',"\n') else name


def mat_name(column: str) -> str:
    """A MATLAB identifier for a column: 'plant.pose[2]' -> 'plant_pose_2'."""
    name = re.sub(r"[^0-9A-Za-z_]", "_", column).strip("_")
    name = re.sub(r"_+", "_", name)
    return name if name[:1].isalpha() else f"x_{name}"


_MAT_HEADER = 128  # bytes of a MAT 5 file's header
_MI_COMPRESSED = 15  # the MAT 5 data type of a zlib-compressed element


class Mat(ResultFormat):
    """One variable per column (identifier-safe names), plus `columns` (the original names),
    `variables` and `units`; a variable zlib-compressed where samples of it shrink (below
    `MAT_COMPRESS_BELOW`), else raw. Binary ports are left out (a note)."""

    suffix = ".mat"

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        import scipy.io

        content: dict[str, Any] = {mat_name(n): values[:, j] for j, n in enumerate(columns)}
        content["columns"] = np.array(columns, dtype=object)
        content["variables"] = np.array([mat_name(n) for n in columns], dtype=object)
        content["units"] = np.array(units, dtype=object)

        def element(name: str) -> bytes | memoryview:  # the variable's miMATRIX element
            raw = BytesIO()
            scipy.io.savemat(raw, {name: content[name]}, do_compression=False,
                             long_field_names=True)
            body = raw.getbuffer()[_MAT_HEADER:]
            if not _compresses(body):
                return body
            packed = zlib.compress(body, MAT_ZLIB_LEVEL)
            return struct.pack("<II", _MI_COMPRESSED, len(packed)) + packed

        with open(path, "wb") as f:
            scipy.io.savemat(f, {})  # the 128-byte header
            for packed in in_threads(element, content):
                f.write(packed)
        return []

    def read(self, path: Path) -> tuple[list[str], list[str], np.ndarray]:
        import scipy.io

        from twmr.observers.matfiles import plain_columns

        try:
            m = scipy.io.loadmat(path)
        except NotImplementedError:  # scipy's answer to a v7.3 file
            raise CosimError(f"{path}: a MATLAB v7.3 file (HDF5), which this reader does not "
                             f"read. Fix: save it as v7 in MATLAB (save('log.mat', ..., '-v7')) "
                             f"or export the signals as CSV.") from None
        if "columns" not in m:  # saved by MATLAB or a logger, not by twmr
            plain, values = plain_columns(path, m)
            return plain, [""] * len(plain), values
        columns = [str(np.ravel(c)[0]) for c in np.ravel(m["columns"])]
        units = [str(np.ravel(c)[0]) if np.size(c) else "" for c in np.ravel(m["units"])]
        return columns, units, np.column_stack([np.ravel(m[mat_name(c)]) for c in columns])


def _seconds(table: Any) -> Any:
    """`table` with its timestamp and duration columns as float seconds (unit 's'): timestamps
    counted from the earliest of them all, durations as they are; pandas' unnamed time index
    (`__index_level_0__`) named 'time' when the table has none."""
    import pyarrow as pa
    import pyarrow.compute as pc

    def nanoseconds(column: Any) -> Any:
        unit = pa.timestamp("ns") if pa.types.is_timestamp(column.type) else pa.duration("ns")
        return column.cast(unit).cast(pa.int64())

    timed = {f.name: nanoseconds(table[f.name]) for f in table.schema
             if pa.types.is_timestamp(f.type) or pa.types.is_duration(f.type)}
    stamps = [n for n in timed if pa.types.is_timestamp(table.schema.field(n).type)]
    firsts = [pc.min(timed[n]).as_py() for n in stamps]
    origin = min((v for v in firsts if v is not None), default=0)
    for name, ns in timed.items():
        if name in stamps:  # relative first, in integers: float64 holds ns since 1970 to ~0.1 us
            ns = pc.subtract(ns, origin)
        seconds = pc.divide(ns.cast(pa.float64()), 1e9)
        label = "time" if name.startswith("__index_level_") and "time" not in \
            table.column_names else name
        table = table.set_column(table.schema.get_field_index(name),
                                 pa.field(label, pa.float64(), metadata={b"unit": b"s"}),
                                 seconds)
    return table


def _compresses(body: memoryview) -> bool:
    """Whether zlib shrinks samples of `body` (its start, middle and end) below
    `MAT_COMPRESS_BELOW` of their size (a constant or stepped signal does; noise-like float
    bits hardly shrink)."""
    n = len(body)
    if n <= 3 * MAT_SAMPLE:
        sample = bytes(body)
    else:
        mid = (n - MAT_SAMPLE) // 2
        sample = b"".join(bytes(body[a:a + MAT_SAMPLE]) for a in (0, mid, n - MAT_SAMPLE))
    return len(zlib.compress(sample, MAT_ZLIB_LEVEL)) < MAT_COMPRESS_BELOW * len(sample)


class Parquet(ResultFormat):
    """One float64 column per recorded column, its unit as the field's metadata. Binary ports:
    `ticks.parquet`, as `ticks.arrows` holds them but one row per time."""

    suffix = ".parquet"
    ticks_file = "ticks.parquet"

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        import pyarrow as pa
        import pyarrow.parquet as pq

        fields = [pa.field(c, pa.float64(), metadata={"unit": u})
                  for c, u in zip(columns, units, strict=True)]
        # a dictionary only for constant columns: on a varying float column building one
        # costs twice the rest of the write, and the writer drops it anyway
        constant = [c for j, c in enumerate(columns)
                    if len(values) and bool(np.all(values[:, j] == values[0, j]))]
        pq.write_table(pa.Table.from_arrays(_arrow_columns(values), schema=pa.schema(fields)),
                       path, use_dictionary=constant)
        return []

    def write_ticks(self, path: Path, ticks: TickTable) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        columns = {"time": pa.array(ticks.time.tolist(), pa.float64()),
                   **{n: pa.array(ticks.values[n], pa.large_binary()) for n in ticks.names}}
        pq.write_table(pa.table(columns), path)

    def read(self, path: Path) -> tuple[list[str], list[str], np.ndarray]:
        import pyarrow as pa
        import pyarrow.parquet as pq

        table = pq.read_table(path)
        table = _seconds(table)  # a logger's timestamps (pandas' DatetimeIndex) or durations
        numeric = [f.name for f in table.schema if pa.types.is_integer(f.type) or
                   pa.types.is_floating(f.type) or pa.types.is_boolean(f.type)]
        timed = [n for n in numeric if (table.schema.field(n).metadata or {}).get(b"unit") == b"s"]
        first = time_column(numeric) or (timed[0] if timed else None)
        if first is not None:
            numeric = [first, *(n for n in numeric if n != first)]
        table = table.select(numeric)  # a file written by another tool may hold text too
        units = [(f.metadata or {}).get(b"unit", b"").decode() for f in table.schema]
        values = np.column_stack([c.to_numpy().astype(float) for c in table.columns]) \
            if table.num_rows else np.zeros((0, table.num_columns))
        return list(table.column_names), units, values
