"""A built system run again (`twmr.build(...).run(values)`, and a sweep worker's kept system)
gives the rows of a fresh `twmr.load` + `simulate` with the same overrides: on the paper
scenarios (flat and nested), with parameters, initial values and vector elements changed, back
to the scenario's own values, after a run that failed, and when the values change the shape
(the experiment), which builds anew."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import ScenarioError
from twmr.sweeps.run import RunTask, built_for, execute

ROOT = Path(__file__).resolve().parents[2]
SHORT = ["experiment.stop=2.0"]
CASES = {
    "paper_trajectory1_asmc.yaml": [["ctrl.k=20"], ["plant.scale=1.1", "plant.pose[2]=0.01"],
                                    [], ["slip.phase=1.5", "ctrl.eta=0.5"]],
    "paper_trajectory1_smc.yaml": [["plant.scale=1.2"], []],
    "paper_trajectory1_asmc_sensors.yaml": [["plant.scale=1.2"], []],
    "nested/paper_trajectory1_asmc.yaml": [["robot.plant.scale=1.0"], []],
}


def fresh(path: Path, overrides: list[str]) -> np.ndarray:
    return twmr.simulate(twmr.load(path, [*SHORT, *overrides])).values


@pytest.mark.parametrize("name", list(CASES))
def test_runs_of_a_built_system_equal_fresh_builds(name: str) -> None:
    path = ROOT / "scenarios" / name
    built = twmr.build(path, SHORT)
    first = built.run()
    assert np.array_equal(first.values, fresh(path, []))
    for overrides in CASES[name]:
        again = built.run(overrides)
        assert np.array_equal(again.values, fresh(path, overrides)), overrides
    assert built.rebuilt == 0  # every run above set the built components' values


def test_values_as_a_mapping_a_failed_run_and_a_new_shape() -> None:
    path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    built = twmr.build(path, SHORT)
    changed = built.run({"ctrl.k": 20, "plant.pose": [0.5, 0.01, -0.78]})
    assert np.array_equal(changed.values, fresh(path, ["ctrl.k=20",
                                                       "plant.pose=[0.5, 0.01, -0.78]"]))
    with pytest.raises(ScenarioError, match="ctrl"):
        built.run(["ctrl.k=-1"])  # refused by the controller's check, as a fresh build does
    with pytest.raises(ScenarioError):
        fresh(path, ["ctrl.k=-1"])
    assert np.array_equal(built.run().values, fresh(path, []))
    longer = built.run(["experiment.stop=2.5"])
    assert built.rebuilt == 1
    assert np.array_equal(longer.values, fresh(path, ["experiment.stop=2.5"]))


def test_a_worker_reruns_its_built_system_with_the_runs_values() -> None:
    path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    content = path.read_text()

    def task(i: int, scale: float) -> RunTask:
        return RunTask(f"r{i}", i, {"plant.scale": scale}, [f"plant.scale={scale}"], str(path),
                       content, str(path.parent), ["tracking"], built_with=SHORT)

    rows = [execute(task(i, s)) for i, s in enumerate((1.0, 1.25, 1.1, 1.0))]
    assert all(r["status"] == "ok" for r in rows), rows
    kept = built_for(task(9, 1.0))
    assert kept.rebuilt == 0
    assert built_for(task(10, 1.3)) is kept  # one built system for the scenario
    edited = dataclasses.replace(task(11, 1.0), content=content + "\n# edited\n")
    other = built_for(edited)
    assert other is not kept and other.scenario.content == edited.content
    assert built_for(dataclasses.replace(task(12, 1.0), built_with=[])) not in (kept, other)
    assert built_for(task(13, 1.0)) is kept
    for row in rows:
        alone = twmr.simulate(twmr.load(path, [*SHORT, f"plant.scale={row['plant.scale']}"]),
                              metrics=["tracking"])
        for key, value in alone.summary["metrics"].items():
            assert row[key] == value, key
    assert rows[0]["mse_x"] == rows[3]["mse_x"] != rows[1]["mse_x"]


def test_a_built_system_run_compiled_keeps_its_plan_and_layout(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Runs with other values reuse the plan and the driver's layout of the first run (only the
    value vectors are new) and still give a fresh build's rows."""
    monkeypatch.setenv("TWMR_COMPILED", "on")
    path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    built = twmr.build(path, SHORT)
    built.run()
    held = built.system.__dict__
    plan, layout = held["_held_plan"][2], held["_held_layout"][2]
    for overrides in (["ctrl.k=20"], ["plant.pose[2]=0.01", "ctrl.eta=0.5"], []):
        again = built.run(overrides)
        assert np.array_equal(again.values, fresh(path, overrides)), overrides
        assert held["_held_plan"][2] is plan and held["_held_layout"][0] is plan
        now = held["_held_layout"][2]
        assert now.ops is layout.ops and now.blocks is layout.blocks
        assert now.S is not layout.S and now.P is not layout.P
    assert built.rebuilt == 0


@pytest.mark.parametrize("override", ["plant.scale=1.2", "ctrl.step_multiple=2",
                                      "experiment.stop=1.5", "experiment.step=0.002"])
def test_the_shape_taken_from_the_built_structure_is_the_shape_taken_anew(override: str) -> None:
    from twmr.built import _shape
    from twmr.scenario.build import scenario_spec

    built = twmr.build(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml", SHORT)
    spec = scenario_spec(built.spec, overrides=[override])
    shape = _shape(spec, built.system, built._flat, built._shape)
    assert shape == _shape(spec, built.system)
    assert (shape == built._shape) is override.startswith("plant.")
