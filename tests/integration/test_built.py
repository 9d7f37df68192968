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
from twmr.observers.base import Observer, Outcome
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


def test_a_built_system_run_by_its_generated_loop_keeps_the_loop_compiled(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The loop generated for a system (what FMUs run in) is generated, loaded and compiled
    once: runs with other values call the same machine code and give a fresh build's rows."""
    from twmr.master import compiled

    monkeypatch.setenv("TWMR_COMPILED", "on")
    monkeypatch.setattr(compiled.CompiledStep.__init__, "__defaults__",
                        ("gauss_seidel", "auto", False))  # the loop even where the driver runs
    path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    built = twmr.build(path, SHORT)
    built.run()
    loop = built.system.__dict__["_twmr_held_loop"]
    run, finish = loop.functions()
    assert loop.typed and "_held_layout" not in built.system.__dict__

    def no_compile(*args: object) -> None:
        raise AssertionError("the loop was compiled again")

    cases = (["ctrl.k=20"], ["plant.pose[2]=0.01", "ctrl.eta=0.5"], [])
    expected = [fresh(path, overrides) for overrides in cases]
    monkeypatch.setattr(run, "compile", no_compile)
    for overrides, rows in zip(cases, expected, strict=True):
        again = built.run(overrides)
        assert np.array_equal(again.values, rows), overrides
        assert built.system.__dict__["_twmr_held_loop"] is loop
        assert loop.functions() == (run, finish) and len(run.signatures) == 1


def test_a_system_takes_its_own_loop_once_its_runs_repay_compiling_it(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """The driver runs a system until its budget (`System.own_loop_budget_s`) covers loading
    the loop generated for it from numba's cache, when the cache holds it, or compiling it;
    then that loop runs it, with the driver's rows. A built system raises the budget as its
    runs step."""
    from twmr.master import compiled, scenario_loop
    from twmr.master.execution import Execution
    from twmr.observers.store import ResultStore
    from twmr.scenario import load

    monkeypatch.setenv("TWMR_COMPILED", "on")
    monkeypatch.setattr(scenario_loop, "cache_dir", lambda: tmp_path)  # no loop cached yet
    path = ROOT / "scenarios" / "paper_trajectory1_smc.yaml"  # whose loop no other test makes

    def run(budget: float) -> tuple[np.ndarray, bool]:
        system = load(path, SHORT)
        system.own_loop_budget_s = budget
        algorithm, store = compiled.CompiledStep("gauss_seidel", "on"), ResultStore()
        assert Execution(system, [store], algorithm=algorithm).run().status == "completed"
        return store.data(), algorithm._driver is not None

    rows, by_driver = run(0.0)
    assert by_driver
    assert run(scenario_loop.OWN_LOOP_LOAD_S)[1]  # enough to load the loop, which is not cached
    # compiled, then cached
    for budget in (scenario_loop.OWN_LOOP_COMPILE_S, scenario_loop.OWN_LOOP_LOAD_S):
        own, by_driver = run(budget)
        assert not by_driver and np.array_equal(own, rows), budget

    monkeypatch.setattr(scenario_loop, "OWN_LOOP_SAVING", 1e9)  # the first run repays the compile
    built = twmr.build(path, SHORT)
    built.run()
    assert built.system.own_loop_budget_s >= scenario_loop.OWN_LOOP_COMPILE_S
    assert np.array_equal(built.run().values, fresh(path, []))
    assert built.system.__dict__["_twmr_held_loop"].typed

    class Extra(Observer):
        def finished(self, outcome: Outcome) -> None:
            self.extra = outcome.extra

    monkeypatch.setenv("TWMR_COMPILED", "auto")  # compiled from the first step by that loop
    seen = Extra()
    assert np.array_equal(built.run(observers=[seen]).values, fresh(path, []))
    assert seen.extra["algorithm.compiled"] is True and seen.extra["algorithm.driver"] is False


def test_a_built_system_expecting_runs_takes_its_loop_when_they_repay_it() -> None:
    """`Built.expect`: the runs still to come count in the budget, at the mean stepping time of
    those made, so a sweep worker's system takes its loop after its first run when its share
    of the sweep repays compiling it, and not when it does not."""
    from twmr.master import scenario_loop

    path = ROOT / "scenarios" / "paper_trajectory1_smc.yaml"
    few, many = twmr.build(path, SHORT), twmr.build(path, SHORT)
    few.expect(2)
    for built in (few, many):
        built.run()
    per_run = many._stepped_s  # a later run may step several times faster on a busy machine
    many.expect(100 * int(scenario_loop.OWN_LOOP_COMPILE_S /
                          (per_run * scenario_loop.OWN_LOOP_SAVING)))
    many.run()
    assert few.system.own_loop_budget_s < scenario_loop.OWN_LOOP_COMPILE_S
    assert many.system.own_loop_budget_s >= scenario_loop.OWN_LOOP_COMPILE_S
    task = RunTask("r", 0, {}, [], str(path), path.read_text(), str(path.parent), share=7,
                   built_with=SHORT)
    assert built_for(task)._expected == 7  # a sweep tells its workers their share


def test_one_process_compiles_a_loop_and_the_others_load_it_when_it_is_there(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """A system whose budget covers compiling its loop runs by the driver while another
    process holds the lock on compiling that loop, and one that did not find the loop in
    numba's cache asks again after `RECHECK_S`: once another process has compiled it, the
    system takes it, with the driver's rows. A lock a run took is let go by the next run."""
    from twmr.master import compiled, scenario_loop, schedule_cache
    from twmr.master.execution import Execution
    from twmr.observers.store import ResultStore
    from twmr.scenario import load

    class Extra(Observer):
        def finished(self, outcome: Outcome) -> None:
            self.extra = outcome.extra

    def by_driver() -> tuple[bool, np.ndarray]:
        seen = Extra()
        result = built.run(observers=[seen])
        return seen.extra["algorithm.driver"], result.values

    monkeypatch.setenv("TWMR_COMPILED", "on")
    monkeypatch.setattr(scenario_loop, "cache_dir", lambda: tmp_path)  # no loop cached yet
    monkeypatch.setattr(scenario_loop, "OWN_LOOP_SAVING", 1e9)  # every budget covers compiling
    monkeypatch.setattr(scenario_loop, "RECHECK_S", 1e9)
    # a loop of its own (its recorded signals), which no other test's process has compiled
    given = ROOT / "scenarios" / "paper_trajectory1_smc.yaml"
    text = given.read_text(encoding="utf-8")
    assert ", ctrl.error]" in text
    path = tmp_path / "own_loop.yaml"
    path.write_text(text.replace(", ctrl.error]", "]"), encoding="utf-8")
    built = twmr.build(path, SHORT)
    built.run()
    held = scenario_loop.OWN_LOOP_COMPILE_S
    monkeypatch.setattr(scenario_loop, "OWN_LOOP_COMPILE_S", 1e12)  # asks the cache only
    assert by_driver()[0]
    loop = built.system.__dict__["_twmr_held_loop"]
    other = schedule_cache.claim(loop.source, loop.names, tmp_path)  # another process compiles
    assert other is not None
    monkeypatch.setattr(scenario_loop, "OWN_LOOP_COMPILE_S", held)
    assert by_driver()[0]
    other.close()
    monkeypatch.setattr(scenario_loop, "OWN_LOOP_COMPILE_S", 1e12)
    # that process puts the loop in the cache
    algorithm = compiled.CompiledStep("gauss_seidel", "on", use_driver=False)
    assert Execution(load(path, SHORT), [ResultStore()], algorithm=algorithm).run().status == \
        "completed"
    rows = by_driver()
    assert rows[0]  # the answer "not in the cache" held until RECHECK_S
    monkeypatch.setattr(scenario_loop, "RECHECK_S", 0.0)
    own = by_driver()
    assert not own[0] and np.array_equal(own[1], rows[1])
    assert loop.claim()  # as a run that took the lock and then did not compile
    built.system.own_loop_budget_s = 0.0
    assert by_driver()[0]  # the next run lets it go, whichever way it runs
    other = schedule_cache.claim(loop.source, loop.names, tmp_path)
    assert other is not None
    other.close()


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
