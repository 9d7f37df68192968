"""Exports of a recorded result: CSV (read by `pandas.read_csv` as is; units in `units.json`
beside it), MATLAB `.mat` and Parquet (units as field metadata). All are made from the
crash-consistent store after the run, so a failed export never costs the recorded rows."""
from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

FORMATS = ("csv", "mat", "parquet")
UNITS_FILE = "units.json"


def save_csv(columns: list[str], values: np.ndarray, path: Path) -> Path:
    """One header row of column names, then one row per sample (17 significant digits)."""
    header = ",".join(_csv_field(c) for c in columns)
    np.savetxt(path, values, delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def _csv_field(name: str) -> str:
    return f'"{name}"' if any(ch in name for ch in ',"\n') else name


def save_units(columns: list[str], units: list[str], folder: Path) -> Path:
    path = folder / UNITS_FILE
    path.write_text(json.dumps(dict(zip(columns, units, strict=False)), indent=1) + "\n")
    return path


def mat_name(column: str) -> str:
    """A MATLAB identifier for a column: 'plant.pose[2]' -> 'plant_pose_2'."""
    name = re.sub(r"[^0-9A-Za-z_]", "_", column).strip("_")
    name = re.sub(r"_+", "_", name)
    return name if name[:1].isalpha() else f"x_{name}"


def save_mat(columns: list[str], units: list[str], values: np.ndarray, path: Path) -> Path:
    """One variable per column (identifier-safe names), plus `columns` (the original names),
    `variables` and `units`."""
    import scipy.io

    content: dict[str, Any] = {mat_name(n): values[:, j] for j, n in enumerate(columns)}
    content["columns"] = np.array(columns, dtype=object)
    content["variables"] = np.array([mat_name(n) for n in columns], dtype=object)
    content["units"] = np.array(units, dtype=object)
    scipy.io.savemat(path, content, do_compression=True, long_field_names=True)
    return path


def save_parquet(columns: list[str], units: list[str], values: np.ndarray, path: Path) -> Path:
    import pyarrow as pa
    import pyarrow.parquet as pq

    fields = [pa.field(c, pa.float64(), metadata={"unit": u})
              for c, u in zip(columns, units, strict=True)]
    n = len(values)
    arrays = [pa.Array.from_buffers(pa.float64(), n, [None, pa.py_buffer(
        np.ascontiguousarray(values[:, j], dtype="<f8"))]) for j in range(len(columns))]
    table = pa.Table.from_arrays(arrays, schema=pa.schema(fields))
    pq.write_table(table, path)
    return path


def export(columns: list[str], units: list[str], values: np.ndarray, folder: Path,
           formats: tuple[str, ...]) -> list[Path]:
    """Write the asked formats into `folder` as result.<ext>; the paths written. Each file is
    written under a temporary name and renamed when complete, so an export cut short (Ctrl-C,
    full disk) never leaves a truncated file under the real name."""
    written = []

    def whole(save: Any, name: str, *args: Any) -> None:
        tmp = folder / f".partial-{name}"  # same suffix: savemat appends .mat otherwise
        try:
            save(*args, tmp)
            os.replace(tmp, folder / name)
        finally:
            tmp.unlink(missing_ok=True)
        written.append(folder / name)

    if "csv" in formats:
        whole(save_csv, "result.csv", columns, values)
        written.append(save_units(columns, units, folder))
    if "mat" in formats:
        whole(save_mat, "result.mat", columns, units, values)
    if "parquet" in formats:
        whole(save_parquet, "result.parquet", columns, units, values)
    return written
