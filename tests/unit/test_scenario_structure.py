"""The typed system structure between the loaders and the builder: every value with where it was
given (YAML file:line and key path, a dict's key path, the `--set` text); the builder reads only
the structure, so a structure made by any loader (or by hand) builds the same System."""
from __future__ import annotations

import copy
import time
from pathlib import Path

import numpy as np
import pytest
import yaml

import twmr
from twmr.cli import main
from twmr.core import ScenarioError, WiringError
from twmr.core.errors import Location
from twmr.scenario import (
    ComponentSpec,
    Given,
    ScenarioSpec,
    build_system,
    read_structure,
)
from twmr.scenario.overrides import apply_overrides
from twmr.scenario.structure import ExperimentSpec, RecordingSpec

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"
GOOD = FIXTURE.read_text()


def test_yaml_values_carry_file_line_and_key_path() -> None:
    spec = read_structure(GOOD, "s.yaml")
    assert spec.components["ctrl"].parameters["k"] == Given(
        2.0, Location("s.yaml", 5, "components.ctrl.parameters.k"))
    assert spec.components["plant"].kind == Given(
        "integrator", Location("s.yaml", 6, "components.plant.kind"))
    assert spec.components["plant"].step_multiple == Given(  # the default, at its component
        1, Location("s.yaml", 6, "components.plant.step_multiple"))
    assert [(c.value, c.where.line) for c in spec.connections] == [
        ("ref.y -> err.u1", 8), ("plant.y -> err.u2", 9), ("err.y -> ctrl.u", 10),
        ("ctrl.y -> plant.u", 11)]
    assert spec.connections[2].where.path == "connections[3]"
    assert spec.experiment.stop == Given(1.0, Location("s.yaml", 12, "experiment.stop"))
    assert spec.experiment.algorithm.value == "gauss_seidel"
    assert spec.record.decimation == Given(2, Location("s.yaml", 13, "record.decimation"))
    assert [s.value for s in spec.record.signals or ()] == ["plant.*", "ctrl.y"]
    assert list(spec.components) == ["ref", "err", "ctrl", "plant"]  # the order written
    assert spec.at("connections") == Location("s.yaml", 7, "connections")


def test_a_dict_is_located_by_key_paths_in_the_structure_and_in_errors() -> None:
    data = yaml.safe_load(GOOD)
    spec = read_structure(data, "<dict>")
    assert spec.components["ctrl"].parameters["k"].where == Location(
        "<dict>", 0, "components.ctrl.parameters.k")
    data["components"]["ctrl"]["parameters"]["k"] = "fast"
    with pytest.raises(ScenarioError) as err:
        twmr.load(data)
    assert str(err.value).startswith("<dict> (components.ctrl.parameters.k): component 'ctrl', "
                                     "parameter 'k' = 'fast'")
    data["connections"][1] = "plant.y -> err.uu"
    data["components"]["ctrl"]["parameters"]["k"] = 2.0
    with pytest.raises(WiringError, match=r"^<dict> \(connections\[2\]\): component 'err'"):
        twmr.load(data)


def test_overrides_replace_values_with_their_set_text_and_leave_the_spec_as_it_was() -> None:
    spec = read_structure(GOOD, "s.yaml")
    before = copy.deepcopy(spec)
    changed = apply_overrides(spec, ["ctrl.k=5", "err.u1=0.5", "experiment.stop=0.5",
                                     "plant.step_multiple=2"])
    assert spec == before
    assert changed.components["ctrl"].parameters["k"] == Given(5, Location("--set", 0,
                                                                           "ctrl.k=5"))
    assert changed.components["err"].initial["u1"].value == 0.5  # an input: its start value
    assert changed.experiment.stop == Given(0.5, Location("--set", 0, "experiment.stop=0.5"))
    assert changed.components["plant"].step_multiple.value == 2
    system = build_system(changed)
    assert system.components["ctrl"].k == 5.0 and system.experiment.n_steps == 50
    assert system.multiple("plant") == 2


def test_the_builder_reads_only_the_structure_a_hand_made_one_runs_like_the_yaml() -> None:
    def at(path: str) -> Location:
        return Location("my-tool", 42, path)

    def comp(name: str, kind: str, **params: float) -> ComponentSpec:
        return ComponentSpec(name, Given(kind, at(f"{name} kind")),
                             {k: Given(v, at(f"{name} {k}")) for k, v in params.items()},
                             {}, Given(1, at(name)), at(name))

    comps = [comp("ref", "step", height=1.0, time=0.1), comp("err", "sum", k2=-1.0),
             comp("ctrl", "gain", k=2.0), comp("plant", "integrator")]
    wires = ["ref.y -> err.u1", "plant.y -> err.u2", "err.y -> ctrl.u", "ctrl.y -> plant.u"]
    spec = ScenarioSpec(
        "my-tool", FIXTURE.parent, {c.name: c for c in comps},
        tuple(Given(w, at(f"wire {i}")) for i, w in enumerate(wires)), (),
        ExperimentSpec(Given(0.0, at("t0")), Given(1.0, at("t1")), Given(0.01, at("h")),
                       Given("gauss_seidel", at("algorithm")), Given(None, at("pacing")),
                       at("experiment")),
        RecordingSpec((Given("plant.*", at("rec")), Given("ctrl.y", at("rec"))),
                      Given(2, at("decimation")), at("record")))
    by_hand = twmr.simulate(twmr.load(spec))
    from_yaml = twmr.simulate(FIXTURE)
    assert by_hand.columns == from_yaml.columns
    assert np.array_equal(by_hand.values, from_yaml.values) and len(by_hand) == 51
    broken = ScenarioSpec(spec.source, spec.base_dir,
                          {**spec.components, "ctrl": comp("ctrl", "gain", k=float("nan"))},
                          spec.connections, spec.open, spec.experiment, spec.record)
    with pytest.raises(ScenarioError, match=r"^my-tool:42 \(ctrl k\): component 'ctrl', "
                                            r"parameter 'k' = nan: NaN"):
        build_system(broken)


def test_a_set_value_that_is_not_yaml_is_one_paragraph(capsys) -> None:
    assert main(["check", str(FIXTURE), "--set", "ctrl.k=[1"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("error: --set (ctrl.k=[1): cannot read the value '[1' of 'ctrl.k=[1': "
                          "it is not a YAML value (expected ',' or ']', but got the end).")
    assert "Fix: give a number (ctrl.k=2.5)" in err
    with pytest.raises(ScenarioError, match=r"^--set \(experiment.stop=\{\): cannot read"):
        twmr.load(FIXTURE, ["experiment.stop={"])


def test_a_huge_element_selection_is_refused_at_once(tmp_path: Path, capsys) -> None:
    scenario = tmp_path / "s.yaml"
    scenario.write_text(GOOD.replace("- ref.y -> err.u1", "- ref.y[1:100000000] -> err.u1"))
    t0 = time.perf_counter()
    assert main(["check", str(scenario)]) == 1
    assert time.perf_counter() - t0 < 5.0  # not 4.7 GB and a minute of building a list
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err  # one problem: err.u1 not repeated
    assert f"{scenario}:8 (connections[1])" in err
    assert "names 100,000,000 elements, more than the 1,000,000 one wire may select" in err
