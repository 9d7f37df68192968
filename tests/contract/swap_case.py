"""Run the paper scenario with some blocks swapped for their exported FMUs; save the result.

Usage: python swap_case.py FMU_DIR OUT.npy [BLOCK ...]. Run in its own process by the contract
test: pythonfmu 0.7 FMUs execute inside the running interpreter and several of them in one process
crash at teardown, so each case gets a fresh interpreter.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import yaml

from twmr.master import simulate
from twmr.scenario import loads

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
BLOCKS = ("ref", "ctrl", "motor", "plant", "slip")
STOP = 3.0


def swapped(names: tuple[str, ...], fmu_dir: Path) -> str:
    """The scenario text with each named block's `kind:` turned into `fmu` + `path:`."""
    text = SCENARIO.read_text().replace("stop: 30.0", f"stop: {STOP}")
    # exported FMUs have no optional inputs: every case (native too) holds the slip over a step
    text = text.replace("  - slip.model -> plant.slip_model\n", "")
    for name in names:
        kind = yaml.safe_load(text)["components"][name]["kind"]
        block = re.search(rf"(?ms)^  {name}:\n(    .*?\n)+?(?=  \w|connections)", text).group(0)
        path = fmu_dir / f"{name}.fmu"
        new = block.replace(f"kind: {kind}", "kind: fmu")
        if "parameters: {" in new:
            new = new.replace("parameters: {", f"parameters: {{path: {path}, ")
        else:
            new = new.replace("kind: fmu\n", f"kind: fmu\n    parameters: {{path: {path}}}\n")
        text = text.replace(block, new)
    return text


if __name__ == "__main__":
    import gc

    # pythonfmu 0.7 slaves mishandle Python references: a garbage collection while they live
    # crashes this interpreter now and then (open issue: standalone C FMUs replace them); the
    # cyclic collector is off so the comparison of trajectories is what this case tests
    gc.disable()
    fmu_dir, out, names = Path(sys.argv[1]), Path(sys.argv[2]), tuple(sys.argv[3:])
    np.save(out, np.array(simulate(loads(swapped(names, fmu_dir), source="swapped.yaml"))))
    sys.stdout.flush()
    import os

    os._exit(0)  # skip interpreter teardown: pythonfmu instances are left to the OS
