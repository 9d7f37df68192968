"""The paper scenarios written with the robot as one block (scenarios/nested/*.yaml including
scenarios/robot.yaml) give bit-identical results to the flat files, in the Python loop and the
compiled one; a value of a block inside the robot set from outside (`--set`, a sweep) reaches it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
PAIRS = ["paper_trajectory1_asmc", "paper_trajectory1_smc", "paper_circle_asmc"]
SHORT = ["experiment.stop=1.5"]


def columns(path: Path, overrides: list[str]) -> dict[str, np.ndarray]:
    """Every recorded column of a run, named as in the flat file ('robot.plant.x' -> 'plant.x')."""
    data = twmr.simulate(twmr.load(path, [*SHORT, *overrides])).data
    names = data.dtype.names or ()
    return {n.removeprefix("robot."): np.asarray(data[n]) for n in names}


def assert_identical(flat: dict[str, np.ndarray], nested: dict[str, np.ndarray]) -> None:
    assert list(flat) == list(nested)
    assert len(flat["time"]) == 151
    for name, values in flat.items():
        assert np.array_equal(values, nested[name]), name


@pytest.mark.parametrize("compiled", ["off", "on"])
@pytest.mark.parametrize("name", PAIRS)
def test_nested_paper_scenario_is_bit_identical_to_the_flat_one(
        name: str, compiled: str, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TWMR_COMPILED", compiled)
    flat = columns(SCENARIOS / f"{name}.yaml", [])
    nested = columns(SCENARIOS / "nested" / f"{name}.yaml", [])
    assert_identical(flat, nested)
    assert any(k.startswith("plant.pose") for k in flat)


def test_a_plant_value_set_from_outside_the_robot_reaches_it() -> None:
    flat = columns(SCENARIOS / "paper_trajectory1_asmc.yaml",
                   ["plant.scale=1.0", "slip.profile=none"])
    nested = columns(SCENARIOS / "nested" / "paper_trajectory1_asmc.yaml",
                     ["robot.plant.scale=1.0", "robot.slip.profile=none"])
    assert_identical(flat, nested)
    default = columns(SCENARIOS / "nested" / "paper_trajectory1_asmc.yaml", [])
    assert not np.array_equal(default["plant.pose[1]"], nested["plant.pose[1]"])


def test_the_robot_runs_on_its_own_with_its_input_open() -> None:
    result = twmr.simulate(twmr.load(SCENARIOS / "robot.yaml", ["experiment.stop=0.2"]))
    speed = np.asarray(result.data["plant.wheel_speed[1]"])
    assert len(speed) == 201 and np.all(np.isfinite(speed))
    assert np.all(np.asarray(result.data["motor.torque[1]"]) == 0.0)  # torque_command open: 0


def test_a_sweep_varies_a_block_inside_the_robot(tmp_path: Path) -> None:
    nested = SCENARIOS / "nested" / "paper_trajectory1_asmc.yaml"
    outcome = twmr.sweep(nested, ["robot.plant.scale=values:1.0,1.25"], method="grid",
                         out=tmp_path / "s", workers=1, metrics=["tracking"],
                         overrides=["experiment.stop=1.0"])
    table = outcome.frame().sort_values("robot.plant.scale")
    assert list(table["status"]) == ["ok", "ok"]
    for _, row in table.iterrows():
        flat = twmr.simulate(twmr.load(SCENARIOS / "paper_trajectory1_asmc.yaml",
                                       ["experiment.stop=1.0",
                                        f"plant.scale={row['robot.plant.scale']!r}"]),
                             metrics=["tracking"])
        for key, value in flat.summary["metrics"].items():
            assert row[key] == value, key
