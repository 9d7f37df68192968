"""Scenarios: loaders (YAML file, YAML text, dict) -> `ScenarioSpec` (the typed structure, every
value with where it came from) -> checked `System` (components created, wired, ordered).

The loaders (YAML, JSON Schema) and the builder are imported on first use, so the master can use
the `System` records without them."""
from __future__ import annotations

from typing import Any

from twmr.scenario.structure import ComponentSpec, Given, ScenarioSpec
from twmr.scenario.system import Connection, Experiment, RecordSpec, System

_LAZY = {"load": "build", "loads": "build", "build_system": "build", "scenario_spec": "build",
         "schema": "loaders", "load_structure": "loaders", "read_structure": "loaders",
         "describe": "listing", "kinds_table": "listing"}
__all__ = [
    "ComponentSpec",
    "Connection",
    "Experiment",
    "Given",
    "RecordSpec",
    "ScenarioSpec",
    "System",
    "build_system",
    "describe",
    "kinds_table",
    "load",
    "load_structure",
    "loads",
    "read_structure",
    "scenario_spec",
    "schema",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"twmr.scenario.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'twmr.scenario' has no attribute {name!r}")
