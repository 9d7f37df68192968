"""The engine's blocks: sources, linear and discrete blocks, signal routing, more signal sources
and nonlinear blocks.

Registered as component kinds like any other: `constant`, `sine`, `step`, `gain`, `sum`,
`integrator`, `state_space`, `delay`; `transfer_function`, `pid`, `transport_delay`,
`zero_order_hold`, `first_order` (`twmr.blocks.discrete`); `mux`, `demux`, `selector`,
`product`, `math` (`twmr.blocks.routing`); `ramp`, `pulse`, `table`, `noise`, `chirp`
(`twmr.blocks.signals`); `saturation`, `dead_zone`, `rate_limiter`, `quantizer`, `backlash`,
`relay`, `lookup_1d`, `lookup_2d` (`twmr.blocks.nonlinear`); `port_fault` (`twmr.blocks.faults`,
what a scenario's `events:` inserts on a wire); `data` (`twmr.blocks.data`: measured samples
played from a file). docs/blocks.md describes them.
"""
from __future__ import annotations

import importlib
from typing import Any

#: each block class by the module that defines it, imported when first named (a scenario of a
#: sine and a gain loads two modules, not the whole library)
_MODULES = {
    "data": ("Data",),
    "discrete": ("FirstOrder", "Pid", "TransferFunction", "TransportDelay", "ZeroOrderHold"),
    "faults": ("PortFault",),
    "linear": ("Delay", "Gain", "Integrator", "StateSpace", "Sum"),
    "nonlinear": ("Backlash", "DeadZone", "Lookup1D", "Lookup2D", "Quantizer", "RateLimiter",
                  "Relay", "Saturation"),
    "routing": ("Demux", "Math", "Mux", "Product", "Selector"),
    "signals": ("Chirp", "Noise", "Pulse", "Ramp", "Table"),
    "sources": ("Constant", "Sine", "Step"),
    "watch": ("ConditionWatch",),
}
_WHERE = {name: module for module, names in _MODULES.items() for name in names}

__all__ = ["Backlash", "Chirp", "ConditionWatch", "Constant", "Data", "DeadZone", "Delay", "Demux",
           "FirstOrder", "Gain", "Integrator", "Lookup1D", "Lookup2D", "Math", "Mux", "Noise",
           "Pid", "PortFault", "Product", "Pulse", "Quantizer", "Ramp", "RateLimiter", "Relay",
           "Saturation", "Selector", "Sine", "StateSpace", "Step", "Sum", "Table",
           "TransferFunction", "TransportDelay", "ZeroOrderHold"]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'twmr.blocks' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"twmr.blocks.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
