"""Columns of a MATLAB `.mat` file that twmr did not write: what a logger or a script saved with
`save(...)` — vectors of one length (a variable `time`, `t` or `Time`, else a struct's field of
that name, goes first), a matrix of that many rows as columns `name[1]`, `name[2]`, ..., a
struct's fields as `struct.field`; scalars, text and cell arrays are left out.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.observers.timecolumn import time_column


def plain_columns(path: Path, content: dict[str, Any]) -> tuple[list[str], np.ndarray]:
    """(column names, float64 rows) of the variables `content` (scipy.io.loadmat of `path`,
    squeeze_me=False); CosimError when no numeric vector is there or the vectors' lengths
    differ."""
    found: dict[str, np.ndarray] = {}
    for name, value in content.items():
        if not name.startswith("__"):
            _collect(name, value, found)
    if not found:
        raise CosimError(f"{path}: no numeric vector in this MAT file. Fix: save the signals as "
                         f"vectors of one length (save('log.mat', 'time', 'x', '-v7')).")
    lengths = {name: len(v) for name, v in found.items()}
    if len(set(lengths.values())) > 1:
        listed = ", ".join(f"{n} ({k})" for n, k in lengths.items())
        raise CosimError(f"{path}: its vectors differ in length: {listed}. Fix: save only "
                         f"signals sampled together, one value per sample time.")
    time = time_column(found)
    names = ([time] if time else []) + [n for n in found if n != time]
    return names, np.column_stack([found[n] for n in names])


def _collect(name: str, value: Any, found: dict[str, np.ndarray]) -> None:
    """The columns of one variable into `found`: a struct's fields recursively, a vector as
    itself, a matrix of more than one column as name[1], name[2], ..."""
    if not isinstance(value, np.ndarray):
        return
    if value.dtype.names:  # a struct (1 x 1): its fields
        if value.size == 1:
            for field in value.dtype.names:
                _collect(f"{name}.{field}", value[field].flat[0], found)
        return
    if value.dtype.kind not in "biuf" or value.ndim != 2 or value.size <= 1:
        return  # text, cells, complex, scalars, n-d arrays
    rows, cols = value.shape
    if 1 in (rows, cols):
        found[name] = np.ravel(value).astype(float)
        return
    for j in range(cols):
        found[f"{name}[{j + 1}]"] = value[:, j].astype(float)
