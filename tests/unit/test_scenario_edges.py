"""Rough edges of writing a scenario: an element of a vector set by `--set` or `twmr.load`
overrides, `open:` with wildcards and elements, a port typo answered with every port and a
suggestion."""
from __future__ import annotations

from pathlib import Path

import pytest

import twmr
from twmr.core import ScenarioError
from twmr.scenario import loads

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
THREE = """components:
  a: {kind: saturation, parameters: {n: 3, lower: -1, upper: 1}}
  b: {kind: saturation, parameters: {n: 3, lower: -1, upper: 1}}
  c: {kind: saturation}
open: OPEN
experiment: {stop: 0.1, step: 0.1}
"""


def test_an_element_override_sets_one_element_and_converts_its_unit() -> None:
    plain = twmr.load(PAPER).system.components["plant"].get("pose")
    s = twmr.load(PAPER, ["plant.pose[1]=0.6", "plant.pose[2]=30 cm"])
    assert s.system.components["plant"].get("pose") == (0.6, 0.3, plain[2])
    result = twmr.simulate(twmr.load(PAPER, ["plant.pose[1]=0.6", "experiment.stop=0.01"]),
                           formats=())
    assert result["plant.pose[1]"][0] == 0.6


@pytest.mark.parametrize("text, message", [
    ("plant.pose[4]=0.6", "'plant.pose' has 3 elements. Fix: index from 1 to 3."),
    ("plant.scale[1]=2", "'plant.scale' has no elements (a scalar). Fix: set plant.scale=value."),
])
def test_a_wrong_element_is_one_paragraph(text: str, message: str) -> None:
    with pytest.raises(ScenarioError) as err:
        twmr.load(PAPER, [text])
    assert f"--set ({text})" in str(err.value) and message in str(err.value)


@pytest.mark.parametrize("entries", ['["*.u"]', '[a.u, b.u, c.u]', '["a.*", "b.u[1,2,3]", c.u]'])
def test_open_takes_wildcards_and_elements(entries: str) -> None:
    system = loads(THREE.replace("OPEN", entries))
    assert set(system.components) == {"a", "b", "c"}


@pytest.mark.parametrize("entries, message", [
    ('["a.*", "b.u[1,2]", c.u]', "input 'b.u' (elements 3) is not connected"),
    ('["a.u[4]", b.u, c.u]', "'a.u[4]' in 'open:': 'a.u' has 3 element(s), not 4"),
    ('["x.*"]', "'x.*' in 'open:' is no input"),
])
def test_open_leaves_the_rest_to_be_wired(entries: str, message: str) -> None:
    with pytest.raises(ScenarioError, match=None) as err:
        loads(THREE.replace("OPEN", entries))
    assert message in str(err.value), str(err.value)


def test_a_port_typo_lists_every_port_with_a_suggestion(tmp_path: Path) -> None:
    bad = tmp_path / "typo.yaml"
    bad.write_text(PAPER.read_text().replace("plant.pose -> ctrl.pose", "plant.pos -> ctrl.pose"))
    with pytest.raises(ScenarioError) as err:
        twmr.load(bad)
    text = str(err.value)
    assert "has no port 'pos' (did you mean 'pose'?)" in text
    assert all(p in text for p in ("pose", "wheel_speed", "torque", "com"))
