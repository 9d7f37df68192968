"""twmr-cosim: co-simulation of wheeled mobile robots (engine).

`twmr.load`, `twmr.simulate` (how a run goes: `twmr.Options`), `twmr.build`, `twmr.read_result`,
`twmr.sweep`, `twmr.tune` (see `twmr.api`), `twmr.Workers` (local workers kept across them),
`twmr.Stepping` (a run step by step), `twmr.fit`, `twmr.linearize` and `twmr.trim` (its
equilibria), and all a
block of your own needs: `Component`, `Input`, `Output`, `Parameter`, `State`, `Kernel` and
`CosimError` (`docs/components.md`).
Imported on first use, so `import twmr` stays light.
"""
from __future__ import annotations

import importlib
from typing import Any

__version__ = "0.2.0"
#: the names of `twmr` and the module each comes from (imported when first used)
_FROM = {**dict.fromkeys(("Result", "Scenario", "build", "load", "read_result", "simulate",
                          "sweep", "tune"), "twmr.api"),
         **dict.fromkeys(("Component", "Input", "Output", "Parameter", "State", "CosimError"),
                         "twmr.core"),
         "Kernel": "twmr.core.kernel", "Options": "twmr.core.run", "fit": "twmr.fitting",
         "linearize": "twmr.linear_analysis", "trim": "twmr.linear_trim",
         "Stepping": "twmr.stepping",
         "Workers": "twmr.sweeps.pool"}
__all__ = sorted([*_FROM, "__version__"])


def __getattr__(name: str) -> Any:
    if name in _FROM:
        return getattr(importlib.import_module(_FROM[name]), name)
    raise AttributeError(f"module 'twmr' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The lazily imported names too, for tab completion."""
    return sorted({*globals(), *__all__})
