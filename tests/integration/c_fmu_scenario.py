"""The paper scenario with every block swapped for its standalone C FMU (shared by the C export
tests and benchmarks/c_fmu_export.py)."""
from __future__ import annotations

from pathlib import Path

import yaml

from twmr.fmi.cexport import export_c_fmu

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"


def export_blocks(folder: Path, fmi: int = 2, scenario: Path = SCENARIO) -> dict[str, Path]:
    """Each block of `scenario` exported with its parameters as `folder/<name>.fmu`."""
    spec = yaml.safe_load(scenario.read_text())["components"]
    return {name: export_c_fmu(block["kind"], folder / f"{name}.fmu",
                               block.get("parameters") or {}, fmi=fmi)
            for name, block in spec.items()}


def swapped(fmus: dict[str, Path], scenario: Path = SCENARIO, stop: float | None = None) -> str:
    """The scenario's YAML with each block in `fmus` of kind `fmu` (its parameters are the FMU's
    start values); the plant's slip_model input, which the native block may leave unwired, is
    listed under `open:`."""
    data = yaml.safe_load(scenario.read_text())
    for name, path in fmus.items():
        block = data["components"][name]
        block["kind"] = "fmu"
        block["parameters"] = {"path": str(path)}
    if "plant" in fmus:
        data["open"] = [*(data.get("open") or []), "plant.slip_model"]
    if stop is not None:
        data["experiment"]["stop"] = stop
    return yaml.safe_dump(data, sort_keys=False)
