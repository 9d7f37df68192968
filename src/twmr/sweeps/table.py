"""The rows of a sweep as an Arrow table for `runs.parquet`, built from the values' buffers: any
conversion of Python objects by pyarrow (`pa.array`, `pa.table`) imports pandas, ~0.3 s, more
than a short sweep's writing. Columns of numbers (int64 when every row has an int, else float64),
booleans, strings and lists of strings are built so; the columns are those pandas gives the same
rows (a missing value or a NaN is null). Other values: None (the caller lets pandas do it)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np


def arrow_table(rows: list[dict[str, Any]], keys: list[str]) -> Any:
    """A `pyarrow.Table` of `rows` with the columns `keys`, or None when a column holds values
    of other types or mixes them."""
    import pyarrow as pa

    columns = {}
    for key in keys:
        column = _column(pa, [row.get(key) for row in rows])
        if column is None:
            return None
        columns[key] = column
    return pa.Table.from_arrays(list(columns.values()), names=list(columns))


def _column(pa: Any, values: list[Any]) -> Any:
    given = [v for v in values if v is not None]
    if not given:
        return pa.nulls(len(values))
    if all(isinstance(v, bool | np.bool_) for v in given):
        return _bools(pa, values)
    if all(isinstance(v, int | float | np.integer | np.floating) and not isinstance(
            v, bool | np.bool_) for v in given):
        return _numbers(pa, values)
    if all(isinstance(v, str) for v in given):
        return _strings(pa, values)
    if all(isinstance(v, list | tuple) and all(isinstance(s, str) for s in v) for v in given):
        return _lists(pa, values)
    return None


def _valid(pa: Any, present: list[bool]) -> Any:
    """The validity bitmap of `present` (None: every value is there)."""
    if all(present):
        return None
    return pa.py_buffer(np.packbits(np.array(present, dtype=bool), bitorder="little"))


def _numbers(pa: Any, values: list[Any]) -> Any:
    whole = all(isinstance(v, int | np.integer) for v in values)
    if whole:
        return pa.Array.from_buffers(pa.int64(), len(values),
                                     [None, pa.py_buffer(np.array(values, dtype=np.int64))])
    present = [v is not None and not math.isnan(v) for v in values]
    data = np.array([float(v) if ok else 0.0 for v, ok in zip(values, present, strict=True)],
                    dtype=np.float64)
    return pa.Array.from_buffers(pa.float64(), len(values),
                                 [_valid(pa, present), pa.py_buffer(data)])


def _bools(pa: Any, values: list[Any]) -> Any:
    present = [v is not None for v in values]
    bits = np.packbits(np.array([bool(v) for v in values], dtype=bool), bitorder="little")
    return pa.Array.from_buffers(pa.bool_(), len(values),
                                 [_valid(pa, present), pa.py_buffer(bits)])


def _offsets(lengths: list[int]) -> Any:
    return np.concatenate([[0], np.cumsum(lengths, dtype=np.int64)]).astype(np.int32)


def _strings(pa: Any, values: list[Any]) -> Any:
    present = [v is not None for v in values]
    encoded = [v.encode() if v is not None else b"" for v in values]
    return pa.Array.from_buffers(pa.string(), len(values), [
        _valid(pa, present), pa.py_buffer(_offsets([len(e) for e in encoded])),
        pa.py_buffer(b"".join(encoded))])


def _lists(pa: Any, values: list[Any]) -> Any:
    present = [v is not None for v in values]
    items = [list(v) if v is not None else [] for v in values]
    inner = _strings(pa, [s for item in items for s in item])
    return pa.Array.from_buffers(pa.list_(pa.string()), len(values), [
        _valid(pa, present), pa.py_buffer(_offsets([len(i) for i in items]))], children=[inner])
