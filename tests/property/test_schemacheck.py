"""The quick schema check (`twmr.scenario.schemacheck.conforms`) says "valid" exactly when
jsonschema finds no error: on every scenario file of the project, and on hypothesis' mutations of
the paper scenario (a value anywhere replaced by another JSON value, a key added or removed).
A "valid" that jsonschema refutes would let a broken scenario through unchecked."""
from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import jsonschema
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from twmr.scenario.loaders import schema
from twmr.scenario.schemacheck import conforms

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted(p for p in (ROOT / "scenarios").rglob("*.yaml"))
PAPER = yaml.safe_load((ROOT / "scenarios" / "paper_trajectory1_asmc.yaml").read_text())
SUBSYSTEM = yaml.safe_load((ROOT / "scenarios" / "robot.yaml").read_text())

scalars = st.one_of(st.none(), st.booleans(), st.integers(-3, 3),
                    st.floats(-2, 2, allow_nan=False), st.sampled_from([1.0, 0.0, 2.5]),
                    st.sampled_from(["", "a.b", "ref.position -> ctrl.ref_position", "x",
                                     "9bad", "ok_name", "gain"]))
values = st.recursive(scalars, lambda inner: st.lists(inner, max_size=3)
                      | st.dictionaries(st.sampled_from(["kind", "port", "unit", "stop", "step",
                                                         "x", "description", "signals"]),
                                        inner, max_size=3), max_leaves=6)


def _valid(instance: Any) -> bool:
    return not any(True for _ in jsonschema.Draft202012Validator(schema()).iter_errors(instance))


def _paths(node: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: str(p.relative_to(ROOT)))
def test_project_scenarios_agree(path: Path) -> None:
    data = yaml.safe_load(path.read_text())
    assert conforms(data, schema()) == _valid(data)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from([PAPER, SUBSYSTEM]), st.data(), values,
       st.sampled_from(["replace", "add", "remove"]),
       st.sampled_from(["kind", "x", "stop", "9", "port", "unit", "Bad-name"]))
def test_mutations_agree(base: dict[str, Any], data: st.DataObject, value: Any, how: str,
                         key: str) -> None:
    doc = copy.deepcopy(base)
    path = data.draw(st.sampled_from(_paths(doc)))
    if not path:
        doc = value if how == "replace" else doc
    else:
        parent = doc
        for k in path[:-1]:
            parent = parent[k]
        last = path[-1]
        if how == "replace":
            parent[last] = value
        elif how == "remove":
            del parent[last]
        elif isinstance(parent[last], dict):
            parent[last][key] = value
        elif isinstance(parent[last], list):
            parent[last].append(value)
    assert conforms(doc, schema()) == _valid(doc), doc


def test_a_known_break_is_found() -> None:
    doc = copy.deepcopy(PAPER)
    doc["experiment"]["step"] = "fast"
    assert not conforms(doc, schema())
    doc = copy.deepcopy(PAPER)
    doc["components"]["plant"]["step_multiple"] = 0
    assert not conforms(doc, schema())
