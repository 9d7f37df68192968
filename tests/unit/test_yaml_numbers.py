"""A plain scalar with an exponent and no dot ('1e-5') is a number, as YAML 1.2 and every user
read it, though YAML 1.1 (PyYAML) reads it as text; quoted it stays text."""
from __future__ import annotations

import pytest

import twmr
from twmr.scenario.yamlread import read

pytestmark = pytest.mark.timeout(60)


def test_exponent_without_a_dot_is_a_float() -> None:
    data, _ = read("a: 1e-5\nb: '1e-5'\nc: -2E3\nd: 1e\ne: [+3e2]\n", "x.yaml")
    assert data == {"a": 1e-5, "b": "1e-5", "c": -2000.0, "d": "1e", "e": [300.0]}


def test_a_scenario_step_written_1e_minus_3_runs(tmp_path) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "s.yaml"
    path.write_text("components:\n  c: {kind: constant, parameters: {value: 1.0}}\n"
                    "experiment: {start: 0, stop: 1e-2, step: 1e-3}\n")
    rows = twmr.simulate(twmr.load(str(path), []), out=str(tmp_path / "r")).to_pandas()
    assert len(rows) == 11
