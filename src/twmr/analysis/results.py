"""Result files: the recorded structured array as CSV and MATLAB `.mat`, with units, and a JSON
summary. `load_result` reads any of `.npy`, `.csv`, `.mat` back into a structured array."""
from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from typing import Any

import numpy as np
import scipy.io


def save_csv(data: np.ndarray, units: dict[str, str], path: str | Path) -> Path:
    """CSV with a header row of column names and a second row of units (as Modelica tools)."""
    path = Path(path)
    names = list(data.dtype.names or ())
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        w.writerow([f"[{units.get(n, '')}]" for n in names])
        for row in data:
            w.writerow([repr(float(v)) for v in row])
    return path


def _mat_name(column: str) -> str:
    """A MATLAB identifier for a column: 'plant.pose[2]' -> 'plant_pose_2'."""
    name = re.sub(r"[^0-9A-Za-z_]", "_", column).strip("_")
    name = re.sub(r"_+", "_", name)
    return name if name[:1].isalpha() else f"x_{name}"


def save_mat(data: np.ndarray, units: dict[str, str], path: str | Path) -> Path:
    """MATLAB file: one variable per column (identifier-safe names), plus `names`, `units` and
    `columns` (the original names) so every variable's unit is recorded."""
    path = Path(path)
    names = list(data.dtype.names or ())
    content: dict[str, Any] = {_mat_name(n): np.asarray(data[n], dtype=float) for n in names}
    content["columns"] = np.array(names, dtype=object)
    content["variables"] = np.array([_mat_name(n) for n in names], dtype=object)
    content["units"] = np.array([units.get(n, "") for n in names], dtype=object)
    scipy.io.savemat(path, content, do_compression=True)
    return path


def summary(data: np.ndarray, units: dict[str, str]) -> dict[str, Any]:
    """Per column: unit, first, last, min, max, RMS (NaN-safe)."""
    out: dict[str, Any] = {}
    for n in data.dtype.names or ():
        if n == "time" or len(data) == 0:
            continue
        col = np.asarray(data[n], dtype=float)
        out[n] = {"unit": units.get(n, ""), "first": float(col[0]), "last": float(col[-1]),
                  "min": float(np.nanmin(col)), "max": float(np.nanmax(col)),
                  "rms": float(np.sqrt(np.nanmean(col * col)))}
    return out


def save_summary(info: dict[str, Any], path: str | Path) -> Path:
    path = Path(path)
    path.write_text(json.dumps(info, indent=2, default=float) + "\n")
    return path


def load_result(path: str | Path) -> tuple[np.ndarray, dict[str, str]]:
    """A result file (.npy, .csv or .mat) as (structured array, units by column)."""
    path = Path(path)
    if path.is_dir():
        path = path / "result.npy"
    units: dict[str, str] = {}
    if path.suffix == ".npy":
        data = np.load(path)
        meta = path.with_name("summary.json")
        if meta.exists():
            units = json.loads(meta.read_text()).get("units", {})
        return data, units
    if path.suffix == ".csv":
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
        names, unit_row, body = rows[0], rows[1], rows[2:]
        units = {n: u.strip("[]") for n, u in zip(names, unit_row)}
        arr = np.array([[float(v) for v in r] for r in body], dtype=float).reshape(-1, len(names))
        data = np.zeros(len(arr), dtype=[(n, "<f8") for n in names])
        for i, n in enumerate(names):
            data[n] = arr[:, i]
        return data, units
    if path.suffix == ".mat":
        m = scipy.io.loadmat(path)
        names = [str(np.ravel(c)[0]) for c in np.ravel(m["columns"])]
        vars_ = [str(np.ravel(c)[0]) for c in np.ravel(m["variables"])]
        us = [str(np.ravel(c)[0]) if np.size(c) else "" for c in np.ravel(m["units"])]
        data = np.zeros(np.ravel(m[vars_[0]]).size, dtype=[(n, "<f8") for n in names])
        for n, v, u in zip(names, vars_, us):
            data[n] = np.ravel(m[v])
            units[n] = u
        return data, units
    raise ValueError(f"{path}: unknown result format (use .npy, .csv or .mat)")
