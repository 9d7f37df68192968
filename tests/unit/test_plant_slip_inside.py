"""Slip and disturbance evaluated inside the plant's integration (`slip.model -> plant.slip_model`):
the slip is continuous in time, so halving the plant's internal step converges at RK4's rate to
the continuous-input solution; held over each step it cannot (an O(h) input error)."""
from __future__ import annotations

import itertools

import numpy as np
import pytest

from twmr.master import simulate
from twmr.scenario import loads

OPEN_LOOP = """
components:
  right: {kind: constant, parameters: {value: 3.0}}
  left: {kind: constant, parameters: {value: 2.0}}
  slip: {kind: slip_disturbance, parameters: {profile: %(profile)s}}
  plant:
    kind: twmr_plant
    parameters: {scale: 1.25, internal_step: %(inner)r}
    initial: {pose: [0.5, 0.0, -0.785], wheel_speed: [1.0, 1.0]}
connections:
  - right.y -> plant.torque[1]
  - left.y -> plant.torque[2]
  - slip.slip_rate -> plant.slip_rate
  - slip.slip_accel -> plant.slip_accel
  - slip.disturbance -> plant.disturbance
  - plant.pose -> slip.pose
%(model)s
experiment: {start: 0.0, stop: 2.0, step: %(step)r}
record: {signals: [plant.pose, plant.wheel_speed], decimation: %(decimation)d}
"""


def final_state(inside: bool, step: float, inner: float, profile: str = "paper") -> np.ndarray:
    text = OPEN_LOOP % {"profile": profile, "inner": inner, "step": step,
                        "decimation": round(2.0 / step),
                        "model": "  - slip.model -> plant.slip_model" if inside else ""}
    r = simulate(loads(text, source="open_loop.yaml"))
    return np.array([r[c][-1] for c in ("plant.pose[1]", "plant.pose[2]", "plant.pose[3]",
                                        "plant.wheel_speed[1]", "plant.wheel_speed[2]")])


def test_halving_the_plant_step_converges_at_rk4_rate_with_the_slip_inside() -> None:
    """Communication step fixed at 10 ms; plant substeps 10, 5, 2.5, 1.25 ms: successive
    differences shrink about 16x each halving (RK4), towards the continuous-slip solution."""
    states = [final_state(True, 0.01, h) for h in (1e-2, 5e-3, 2.5e-3, 1.25e-3)]
    diffs = [np.max(np.abs(b - a)) for a, b in itertools.pairwise(states)]
    assert diffs[0] > 1e-9
    assert diffs[0] / diffs[1] > 10 and diffs[1] / diffs[2] > 10


def test_held_slip_has_an_order_h_error_that_the_inside_slip_removes() -> None:
    """Against a fine reference (slip inside, 0.125 ms): held slip errs by O(h) (about half as
    much per halving of the communication step), slip inside by much less."""
    ref = final_state(True, 1.25e-4, 1.25e-4)
    held = [np.max(np.abs(final_state(False, h, h) - ref)) for h in (2e-3, 1e-3)]
    inside = [np.max(np.abs(final_state(True, h, h) - ref)) for h in (2e-3, 1e-3)]
    assert 1.6 < held[0] / held[1] < 2.5  # first order
    assert inside[0] < held[0] / 100 and inside[1] < held[1] / 100


@pytest.mark.parametrize("profile", ["none", "constant", "step", "mud"])
def test_other_profiles_inside_agree_with_held_where_they_are_constant(profile) -> None:
    """Profiles constant over each step give the same motion inside and held (within the O(h)
    switching of step/mud, which happens at most once)."""
    inside, held = final_state(True, 1e-3, 1e-3, profile), final_state(False, 1e-3, 1e-3, profile)
    assert np.max(np.abs(inside - held)) < (1e-12 if profile in ("none", "constant") else 0.05)
