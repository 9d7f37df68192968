"""Controller tuning over realisations (`twmr tune`, `twmr.tune`): an Optuna study of a
scenario's parameters, each trial run over the same realisations, and its report."""
from __future__ import annotations

import sys
import types
from typing import Any

from twmr.tune.objective import (
    Constraint,
    Expression,
    Param,
    TuneError,
    parse_constraint,
    parse_param,
)
from twmr.tune.study import TuneOutcome, TuneSpec, tune

__all__ = ["Constraint", "Expression", "Param", "TuneError", "TuneOutcome", "TuneSpec",
           "parse_constraint", "parse_param", "tune"]


class _CallableModule(types.ModuleType):
    """`twmr.tune(...)` stays `twmr.api.tune` once this package is imported (it is then the
    attribute `tune` of `twmr`)."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        from twmr.api import tune as api_tune

        return api_tune(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
