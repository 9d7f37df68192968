"""Sweeps and Monte Carlo runs of a scenario on Dask (`twmr sweep`, `twmr.sweep`), and their
report (`twmr sweep-report`)."""
from __future__ import annotations

from twmr.sweeps.engine import SweepOutcome, spec_from, sweep
from twmr.sweeps.folder import write_table
from twmr.sweeps.spec import SweepError, SweepSpec, Vary, parse_vary, read_sweep_file, run_id

__all__ = ["SweepError", "SweepOutcome", "SweepSpec", "Vary", "parse_vary", "read_sweep_file",
           "run_id", "spec_from", "sweep", "write_table"]
