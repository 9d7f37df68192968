"""Controller tuning over realisations (`twmr tune`, the function `twmr.tune`): an Optuna study
of a scenario's parameters, each trial run over the same realisations, and its report."""
from __future__ import annotations

from twmr.tuning.objective import (
    Constraint,
    Expression,
    Param,
    TuneError,
    parse_constraint,
    parse_param,
)
from twmr.tuning.study import TuneOutcome, TuneSpec, tune

__all__ = ["Constraint", "Expression", "Param", "TuneError", "TuneOutcome", "TuneSpec",
           "parse_constraint", "parse_param", "tune"]
