"""What `twmr.master.scenario_loop.kernels_of` refuses before anything compiles, and how it says so
(no numba here)."""
from __future__ import annotations

from tests.helpers import system
from twmr.blocks.linear import Gain
from twmr.core.port import INTEGER, Input
from twmr.master.scenario_loop import kernels_of as _kernels


class CountedGain(Gain):
    """A gain with an Integer input its kernel does not carry."""

    count = Input(0, type=INTEGER)


def test_a_port_that_is_not_real_is_named() -> None:
    sys_ = system([Gain("a", k=2.0), CountedGain("b", k=3.0)], ["a.y -> b.u"], 1.0, 0.1)
    kernels, reason = _kernels(sys_, [], False)
    assert kernels is None and reason == "port 'b.count' is Integer, not Real"


def test_real_ports_give_every_kernel() -> None:
    sys_ = system([Gain("a", k=2.0), Gain("b", k=3.0)], ["a.y -> b.u"], 1.0, 0.1)
    kernels, reason = _kernels(sys_, [], False)
    assert reason == "" and kernels is not None and list(kernels) == ["a", "b"]
    assert kernels["b"].params == (3.0,)
