"""The port-level graph: wiring that only looks like a loop at component level runs; a real loop
is refused with its cycle; a component is evaluated twice when the wiring passes through it
twice."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.helpers import system
from twmr.core import AlgebraicLoopError, Component, Input, Output
from twmr.master import simulate
from twmr.scenario.graph import evaluation_plan

PAPER = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"


def encoder_wired() -> str:
    text = PAPER.read_text().replace("stop: 30.0", "stop: 0.5")
    return text.replace("  - plant.wheel_speed -> ctrl.wheel_speed\n",
                        "  - motor.measured_speed -> ctrl.wheel_speed\n")


def test_encoder_feedback_is_not_an_algebraic_loop() -> None:
    # ctrl.torque -> motor.torque_command => motor.torque, but motor.measured_speed depends on
    # no input: a component-level graph saw a loop here
    result = twmr.simulate(twmr.load(encoder_wired()))
    assert len(result) == 51 and np.all(np.isfinite(result.values))


def test_a_real_loop_is_refused_with_its_cycle_and_the_hint() -> None:
    text = encoder_wired().replace("motor.measured_speed -> ctrl.wheel_speed",
                                   "motor.torque[1] -> fb.u\n  - fb.y -> ctrl.wheel_speed[1]\n"
                                   "  - plant.wheel_speed[2] -> ctrl.wheel_speed[2]")
    text = text.replace("components:\n", "components:\n  fb: {kind: gain}\n")
    with pytest.raises(AlgebraicLoopError) as err:
        twmr.load(text)
    message = str(err.value)
    assert "algebraic loop: fb.y -> ctrl.wheel_speed => ctrl.torque -> motor.torque_command " \
           "=> motor.torque -> fb.u => fb.y —" in message
    assert "delay" in message
    assert "conservatively" in message and "<string>:" in message


class TwoPaths(Component):
    """y1 = u1 + 1 and y2 = 10 u2: two feedthrough paths through one block."""

    u1 = Input(0.0)
    u2 = Input(0.0)
    y1 = Output(0.0, depends_on=("u1",))
    y2 = Output(0.0, depends_on=("u2",))
    evaluations = 0

    def evaluate(self, t: float) -> None:
        self.evaluations += 1
        self.y1 = self.u1 + 1.0
        self.y2 = 10.0 * self.u2


class Doubler(Component):
    u = Input(0.0)
    y = Output(0.0, depends_on=("u",))

    def evaluate(self, t: float) -> None:
        self.y = 2.0 * self.u


def test_a_block_on_both_sides_of_a_chain_is_evaluated_twice_per_point() -> None:
    from twmr.blocks import Constant

    comps = [Constant("c", value=3.0), TwoPaths("a"), Doubler("b")]
    sysm = system(comps, ["c.y -> a.u1", "a.y1 -> b.u", "b.y -> a.u2"], 0.05, 0.01,
                  record=["a.y2"])
    plan, cycle = evaluation_plan(sysm.components, sysm.connections)
    assert not cycle
    assert [(act, n) for act, n, _ in plan].count(("evaluate", "a")) == 2
    r = simulate(sysm)
    np.testing.assert_array_equal(r["a.y2"], 10.0 * 2.0 * (3.0 + 1.0))
    assert sysm.components["a"].evaluations == 2 * 6
