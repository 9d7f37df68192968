"""The engine's own small blocks: sources, gain, sum, integrator, LTI state space, unit delay.

They exercise the master in tests and benchmarks and are registered as component kinds like any
other (`constant`, `sine`, `step`, `gain`, `sum`, `integrator`, `state_space`, `delay`).
"""
from twmr.blocks.linear import Delay, Gain, Integrator, StateSpace, Sum
from twmr.blocks.sources import Constant, Sine, Step

__all__ = ["Constant", "Delay", "Gain", "Integrator", "Sine", "StateSpace", "Step", "Sum"]
