"""The engine's blocks: sources, linear blocks, more signal sources and nonlinear blocks.

Registered as component kinds like any other: `constant`, `sine`, `step`, `gain`, `sum`,
`integrator`, `state_space`, `delay`; `ramp`, `pulse`, `table`, `noise`, `chirp`
(`twmr.blocks.signals`); `saturation`, `dead_zone`, `rate_limiter`, `quantizer`, `backlash`,
`relay`, `lookup_1d`, `lookup_2d` (`twmr.blocks.nonlinear`). docs/blocks.md describes them.
"""
from twmr.blocks.linear import Delay, Gain, Integrator, StateSpace, Sum
from twmr.blocks.nonlinear import (
    Backlash,
    DeadZone,
    Lookup1D,
    Lookup2D,
    Quantizer,
    RateLimiter,
    Relay,
    Saturation,
)
from twmr.blocks.signals import Chirp, Noise, Pulse, Ramp, Table
from twmr.blocks.sources import Constant, Sine, Step

__all__ = ["Backlash", "Chirp", "Constant", "DeadZone", "Delay", "Gain", "Integrator",
           "Lookup1D", "Lookup2D", "Noise", "Pulse", "Quantizer", "Ramp", "RateLimiter", "Relay",
           "Saturation", "Sine", "StateSpace", "Step", "Sum", "Table"]
