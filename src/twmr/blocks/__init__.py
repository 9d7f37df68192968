"""The engine's blocks: sources, linear and discrete blocks, signal routing, more signal sources
and nonlinear blocks.

Registered as component kinds like any other: `constant`, `sine`, `step`, `gain`, `sum`,
`integrator`, `state_space`, `delay`; `transfer_function`, `pid`, `transport_delay`,
`zero_order_hold`, `first_order` (`twmr.blocks.discrete`); `mux`, `demux`, `selector`,
`product`, `math` (`twmr.blocks.routing`); `ramp`, `pulse`, `table`, `noise`, `chirp`
(`twmr.blocks.signals`); `saturation`, `dead_zone`, `rate_limiter`, `quantizer`, `backlash`,
`relay`, `lookup_1d`, `lookup_2d` (`twmr.blocks.nonlinear`). docs/blocks.md describes them.
"""
from twmr.blocks.discrete import FirstOrder, Pid, TransferFunction, TransportDelay, ZeroOrderHold
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
from twmr.blocks.routing import Demux, Math, Mux, Product, Selector
from twmr.blocks.signals import Chirp, Noise, Pulse, Ramp, Table
from twmr.blocks.sources import Constant, Sine, Step

__all__ = ["Backlash", "Chirp", "Constant", "DeadZone", "Delay", "Demux", "FirstOrder", "Gain",
           "Integrator", "Lookup1D", "Lookup2D", "Math", "Mux", "Noise", "Pid", "Product",
           "Pulse", "Quantizer", "Ramp", "RateLimiter", "Relay", "Saturation", "Selector", "Sine",
           "StateSpace", "Step", "Sum", "Table", "TransferFunction", "TransportDelay",
           "ZeroOrderHold"]
