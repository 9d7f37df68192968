"""The engine's own blocks: sources, linear and discrete blocks, signal routing.

They are registered as component kinds like any other (`twmr components` lists them; the
pyproject entry-point group `twmr.components`).
"""
from twmr.blocks.discrete import FirstOrder, Pid, TransferFunction, TransportDelay, ZeroOrderHold
from twmr.blocks.linear import Delay, Gain, Integrator, StateSpace, Sum
from twmr.blocks.routing import Demux, Math, Mux, Product, Selector
from twmr.blocks.sources import Constant, Sine, Step

__all__ = ["Constant", "Delay", "Demux", "FirstOrder", "Gain", "Integrator", "Math", "Mux", "Pid",
           "Product", "Selector", "Sine", "StateSpace", "Step", "Sum", "TransferFunction",
           "TransportDelay", "ZeroOrderHold"]
