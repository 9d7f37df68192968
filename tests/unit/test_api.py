"""The Python API: load from a path, a YAML string or a dict with overrides (including the
experiment and step multiples); simulating the same scenario twice is bit-identical; every error
class survives pickle."""
from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core import errors as E
from twmr.master.execution import ResultWriteError

FIXTURE = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"
PAPER = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"


def test_same_scenario_simulated_twice_is_bit_identical() -> None:
    scenario = twmr.load(PAPER, ["experiment.stop=2.0"])
    first, second = twmr.simulate(scenario), twmr.simulate(scenario)
    assert len(first) == 201
    np.testing.assert_array_equal(first.values, second.values)


def test_path_string_and_dict_give_the_same_result() -> None:
    import yaml

    text = FIXTURE.read_text()
    a = twmr.simulate(str(FIXTURE))
    b = twmr.simulate(twmr.load(text))
    c = twmr.simulate(twmr.load(yaml.safe_load(text)))
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.values, c.values)


def test_overrides_reach_experiment_step_multiple_and_parameters() -> None:
    s = twmr.load(FIXTURE, ["experiment.stop=0.5", "experiment.step=0.005",
                            "experiment.algorithm=jacobi", "ctrl.step_multiple=2", "ctrl.k=7"])
    exp = s.system.experiment
    assert (exp.stop, exp.step, exp.algorithm) == (0.5, 0.005, "jacobi")
    assert s.system.multiple("ctrl") == 2 and s.system.components["ctrl"].k == 7.0


def test_bad_overrides_are_scenario_errors_naming_them() -> None:
    with pytest.raises(E.ScenarioError) as err:
        twmr.load(FIXTURE, ["experiment.step=fast", "nobody.k=1"])
    text = str(err.value)
    assert "--set (experiment.step=fast)" in text and "'fast' is not of type 'number'" in text
    assert "--set (nobody.k=1): no component 'nobody'" in text
    with pytest.raises(E.ScenarioError) as err:
        twmr.load(FIXTURE, ["ctrl.kk=2"])
    assert "--set (ctrl.kk=2): component 'ctrl' (Gain) has no parameter 'kk'" in str(err.value)


def _all_subclasses(cls: type) -> list[type]:
    out = []
    for sub in cls.__subclasses__():
        out += [sub, *_all_subclasses(sub)]
    return out


def test_every_error_class_round_trips_through_pickle() -> None:
    import twmr.fmi.fmu
    import twmr.hw.drive
    import twmr.sweeps  # noqa: F401

    loc = E.Location("s.yaml", 3, "components.a")
    samples = {E.ScenarioError: ([E.Problem(loc, "bad", "fix it")],),
               E.ComponentError: ("plant", 1.5, "boom"), ResultWriteError: ("disk full",),
               E.CosimError: ("plain",), E.UnitError: ("unit",)}
    classes = [E.CosimError, *_all_subclasses(E.CosimError)]
    assert {E.AlgebraicLoopError, E.WiringError, E.FmuError, E.HardwareError,
            ResultWriteError} <= set(classes)
    for cls in classes:
        base = next(b for b in cls.__mro__ if b in samples)
        err = cls(*samples[base])
        back = pickle.loads(pickle.dumps(err))
        assert type(back) is cls and str(back) == str(err), cls
        if isinstance(err, E.ComponentError):
            assert (back.instance, back.time) == (err.instance, err.time)
        if isinstance(err, E.ScenarioError):
            assert back.problems == err.problems
    with_log = E.FmuError("f", 0.5, "doStep failed", ["[ERROR] a", "[WARNING] b"])
    back = pickle.loads(pickle.dumps(with_log))
    assert back.log == with_log.log and str(back) == str(with_log)


def test_experiment_override_in_exponent_notation_without_a_dot() -> None:
    assert twmr.load(FIXTURE, ["experiment.step=1e-3"]).system.experiment.step == 1e-3


def test_the_package_lists_its_entry_points_and_a_result_shows_itself_in_a_notebook() -> None:
    import html.parser

    import twmr

    assert {"load", "simulate", "read_result", "sweep"} <= set(dir(twmr))
    result = twmr.simulate(twmr.load(FIXTURE))
    assert repr(result).startswith(f"<Result completed: {len(result)} rows x ")

    class Cells(html.parser.HTMLParser):
        def __init__(self) -> None:
            super().__init__()
            self.cells: list[str] = []

        def handle_data(self, data: str) -> None:
            self.cells.append(data)

    page = Cells()
    page.feed(result._repr_html_())
    y = result["plant.y"]
    at = page.cells.index("plant.y") + (1 if result.units["plant.y"] else 0)  # its unit's cell
    assert page.cells[at + 1:at + 5] == [f"{y[0]:.6g}", f"{y[-1]:.6g}", f"{y.min():.6g}",
                                         f"{y.max():.6g}"]
