"""Scenarios: YAML files -> checked `System` (components created, wired, ordered)."""
from twmr.scenario.build import load, loads, schema
from twmr.scenario.describe import describe, kinds_table
from twmr.scenario.system import Connection, Experiment, RecordSpec, System

__all__ = ["load", "loads", "schema", "describe", "kinds_table", "System", "Connection",
           "Experiment", "RecordSpec"]
