"""Scenarios run natively and with blocks swapped for their standalone C FMUs (shared by the C
export tests and benchmarks/c_fmu_export.py)."""
from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from twmr.fmi.cexport import export_c_fmu
from twmr.master import simulate
from twmr.scenario import loads

PAPER = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"


def paper() -> dict[str, Any]:
    """The paper scenario (trajectory 1, ASMC, slip, 30 s at 1 ms) as data."""
    return yaml.safe_load(PAPER.read_text())


def export_blocks(data: dict[str, Any], folder: Path, fmi: int = 2) -> dict[str, Path]:
    """Every block of scenario `data` exported with its parameters as `folder/<name>.fmu`."""
    folder.mkdir(parents=True, exist_ok=True)
    return {name: export_c_fmu(block["kind"], folder / f"{name}.fmu",
                               block.get("parameters") or {}, fmi=fmi)
            for name, block in data["components"].items()}


def swapped(data: dict[str, Any], fmus: dict[str, Path]) -> dict[str, Any]:
    """`data` with each block named in `fmus` of kind `fmu` (the FMU holds its parameters as
    start values). The plant's optional slip_model input, when unwired, goes under `open:`."""
    data = copy.deepcopy(data)
    wired = " ".join(data["connections"])
    for name, path in fmus.items():
        block = data["components"][name]
        if block["kind"] == "twmr_plant" and f"{name}.slip_model" not in wired:
            data["open"] = [*(data.get("open") or []), f"{name}.slip_model"]
        block["kind"] = "fmu"
        block["parameters"] = {"path": str(path)}
    return data


def run(data: dict[str, Any]) -> np.ndarray:
    """The recorded signals of scenario `data` (a structured array)."""
    return np.array(simulate(loads(yaml.safe_dump(data, sort_keys=False), source="c_fmu.yaml")))
