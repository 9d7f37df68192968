"""twmr-cosim: co-simulation of wheeled mobile robots (engine).

`twmr.load`, `twmr.simulate`, `twmr.build`, `twmr.read_result`, `twmr.sweep`, `twmr.tune` (see
`twmr.api`); imported on first use, so `import twmr` stays light.
"""
from __future__ import annotations

from typing import Any

__version__ = "0.2.0"
__all__ = ["Result", "Scenario", "__version__", "build", "load", "read_result", "simulate",
           "sweep", "tune"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from twmr import api

        return getattr(api, name)
    raise AttributeError(f"module 'twmr' has no attribute {name!r}")


def __dir__() -> list[str]:
    """The lazily imported names too, for tab completion."""
    return sorted({*globals(), *__all__})
