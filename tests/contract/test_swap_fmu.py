"""Contract (back-to-back) test: the paper scenario with each block — and with all of them —
replaced by its exported FMU, in YAML only, gives the native run's trajectories bit for bit.

The FMU runs the same Python code through pythonfmu and FMI's double-precision get/set; the master
calls it at the same points, and the exported slave keeps time as start + k h like the master, so
the results are identical, not just close. Each case runs in its own process (see swap_case.py).
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.contract.swap_case import BLOCKS, SCENARIO
from twmr.fmi import export_component

HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory) -> Path:
    spec = yaml.safe_load(SCENARIO.read_text())["components"]
    out = tmp_path_factory.mktemp("exported")
    for name in BLOCKS:
        export_component(spec[name]["kind"], out / f"{name}.fmu")
    return out


def run_case(fmu_dir: Path, names: tuple[str, ...]) -> np.ndarray:
    out = fmu_dir / f"result_{'_'.join(names) or 'native'}.npy"
    subprocess.run([sys.executable, str(HERE / "swap_case.py"), str(fmu_dir), str(out), *names],
                   check=True, cwd=HERE.parents[1], timeout=300)
    return np.load(out)


@pytest.fixture(scope="module")
def native(fmu_dir) -> np.ndarray:
    return run_case(fmu_dir, ())


@pytest.mark.parametrize("names", [(b,) for b in BLOCKS] + [BLOCKS], ids=lambda n: "+".join(n))
def test_fmu_swap_gives_identical_trajectories(names, fmu_dir, native) -> None:
    result = run_case(fmu_dir, names)
    assert result.dtype.names == native.dtype.names
    assert len(result) == len(native) > 100
    for col in native.dtype.names:
        np.testing.assert_array_equal(result[col], native[col], err_msg=col)
