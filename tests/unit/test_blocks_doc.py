"""docs/blocks.md: one section per block of the library, and every example YAML line in it is a
component that `twmr check` accepts."""
from __future__ import annotations

import re
from pathlib import Path

import yaml

from twmr.registry import lookup
from twmr.scenario import loads

DOC = Path(__file__).resolve().parents[2] / "docs" / "blocks.md"
SOURCES = ["ramp", "pulse", "table", "noise", "chirp"]
NONLINEAR = ["saturation", "dead_zone", "rate_limiter", "quantizer", "backlash", "relay",
             "lookup_1d", "lookup_2d"]


def test_each_block_has_its_entry_under_its_group() -> None:
    text = DOC.read_text()
    sources, nonlinear = text.split("## Sources")[1].split("## Nonlinear")
    for group, kinds in ((sources, SOURCES), (nonlinear, NONLINEAR)):
        found = re.findall(r"^### `(\w+)`$", group, re.M)
        assert found == kinds


def test_every_example_line_is_accepted_by_check() -> None:
    examples = re.findall(r"```yaml\n(.*?)```", DOC.read_text(), re.S)
    assert len(examples) == len(SOURCES) + len(NONLINEAR)
    for example in examples:
        (name, spec), = yaml.safe_load(example).items()
        ports = [p for p, v in lookup(spec["kind"]).declared().items() if v.kind == "input"]
        scenario = {"components": {name: spec}, "open": [f"{name}.{p}" for p in ports],
                    "experiment": {"stop": 1.0, "step": 0.001}}
        system = loads(scenario)
        assert system.components[name].kind == spec["kind"]
