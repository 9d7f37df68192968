"""Scenarios: YAML files -> checked `System` (components created, wired, ordered).

The loader (YAML, JSON Schema) is imported on first use, so the master can use the `System`
records without it."""
from __future__ import annotations

from typing import Any

from twmr.scenario.system import Connection, Experiment, RecordSpec, System

_LAZY = {"load": "build", "loads": "build", "schema": "build", "describe": "listing",
         "kinds_table": "listing"}
__all__ = [
    "Connection",
    "Experiment",
    "RecordSpec",
    "System",
    "describe",
    "kinds_table",
    "load",
    "loads",
    "schema",
]


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"twmr.scenario.{_LAZY[name]}"), name)
    raise AttributeError(f"module 'twmr.scenario' has no attribute {name!r}")
