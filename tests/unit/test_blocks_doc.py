"""docs/blocks.md: one section per block of the library, and every example YAML line in it is a
component that `twmr check` accepts."""
from __future__ import annotations

import re
from pathlib import Path

import yaml

from twmr.registry import lookup
from twmr.scenario import loads

DOC = Path(__file__).resolve().parents[2] / "docs" / "blocks.md"
SOURCES = ["ramp", "pulse", "table", "data", "noise", "chirp"]
NONLINEAR = ["saturation", "dead_zone", "rate_limiter", "quantizer", "backlash", "relay",
             "lookup_1d", "lookup_2d"]
DISCRETE = ["transfer_function", "pid", "transport_delay", "zero_order_hold", "first_order",
            "state_space"]
ROUTING = ["gain", "sum", "product", "mux", "demux", "selector", "math"]
GROUPS = {"Sources": SOURCES, "Nonlinear": NONLINEAR, "Discrete and linear": DISCRETE,
          "Signal routing": ROUTING}


def test_each_block_has_its_entry_under_its_group() -> None:
    sections = dict(re.findall(r"^## (.+?)\n(.*?)(?=^## |\Z)", DOC.read_text(), re.M | re.S))
    for title, kinds in GROUPS.items():
        assert re.findall(r"^### `(\w+)`$", sections[title], re.M) == kinds, title


def test_every_example_line_is_accepted_by_check() -> None:
    examples = re.findall(r"```yaml\n(.*?)```", DOC.read_text(), re.S)
    assert len(examples) == sum(len(kinds) for kinds in GROUPS.values())
    for example in examples:
        (name, spec), = yaml.safe_load(example).items()
        has_inputs = any(v.kind == "input" for v in lookup(spec["kind"]).declared().values())
        scenario = {"components": {name: spec}, "open": [f"{name}.*"] if has_inputs else [],
                    "experiment": {"stop": 1.0, "step": 0.001}}
        system = loads(scenario)
        assert system.components[name].kind == spec["kind"]
