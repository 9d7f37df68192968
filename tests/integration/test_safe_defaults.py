"""The controllers' defaults on a robot at rest on, behind or beside its path (no slip): bounded
torque from the first step, the look-ahead side chosen by `drive: auto`, and the path tracked."""
from __future__ import annotations

import logging
import math

import numpy as np
import pytest

import twmr

LIMIT = 48.0  # N.m, the default torque_limit (the default DC drive's current limit at the wheel)


def scenario(kind: str, shape: str, offset: str, controller: dict | None = None) -> dict:
    """Robot at rest on the reference's start, facing along its velocity, moved by `offset`."""
    if shape == "paper1":  # x_T = -t, y_T = sin(t/2) + t/2 + 1: (0, 1), velocity (-1, 1.5)
        x, y, th = 0.0, 1.0, math.atan2(1.5, -1.0)
    else:  # circle of 5 m at 0.1 pi rad/s from (5, 0), velocity along +y
        x, y, th = 5.0, 0.0, math.pi / 2
    c, s = math.cos(th), math.sin(th)
    dx, dy = {"on": (0.0, 0.0), "behind": (-0.5 * c, -0.5 * s), "beside": (0.5 * s, -0.5 * c),
              "reversed": (0.0, 0.0)}[offset]
    if offset == "reversed":
        th += math.pi
    ctrl: dict = {"kind": kind}
    if controller:
        ctrl["parameters"] = controller
    return {"components": {
        "ref": {"kind": "trajectory", "parameters": {"shape": shape}},
        "ctrl": ctrl,
        "motor": {"kind": "motor_driver"},
        "plant": {"kind": "twmr_plant", "initial": {"pose": [x + dx, y + dy, th]}}},
        "connections": [
            "ref.position -> ctrl.ref_position", "ref.velocity -> ctrl.ref_velocity",
            "ref.acceleration -> ctrl.ref_acceleration", "plant.pose -> ctrl.pose",
            "plant.wheel_speed -> ctrl.wheel_speed", "ctrl.torque -> motor.torque_command",
            "plant.wheel_speed -> motor.wheel_speed", "motor.torque -> plant.torque"],
        "open": ["plant.slip_rate", "plant.slip_accel", "plant.disturbance"],
        "experiment": {"stop": 15.0, "step": 1e-3},
        "record": {"signals": ["ref.position", "plant.pose", "ctrl.torque"], "decimation": 10}}


@pytest.mark.parametrize("offset", ["on", "behind", "beside", "reversed"])
@pytest.mark.parametrize("shape", ["paper1", "circle"])
@pytest.mark.parametrize("kind", ["asmc", "smc"])
def test_defaults_track_with_bounded_torque(kind: str, shape: str, offset: str, caplog) -> None:
    with caplog.at_level(logging.WARNING, logger="twmr"):
        d = twmr.simulate(scenario(kind, shape, offset)).data
    torque = np.abs(np.c_[d["ctrl.torque[1]"], d["ctrl.torque[2]"]])
    assert torque.max() <= LIMIT
    t = d["time"]
    e = np.hypot(d["ref.position[1]"] - d["plant.pose[1]"],
                 d["ref.position[2]"] - d["plant.pose[2]"])
    assert e[t >= 10.0].max() < 0.08  # the 5 cm look-ahead offset plus a little
    assert "far beyond" not in caplog.text


def test_fixed_wrong_drive_direction_loses_the_path() -> None:
    """What `drive: auto` protects against: the look-ahead point on the unstable side."""
    d = twmr.simulate(scenario("asmc", "paper1", "on", {"drive": "backward"})).data
    e = np.hypot(d["ref.position[1]"] - d["plant.pose[1]"],
                 d["ref.position[2]"] - d["plant.pose[2]"])
    assert e[-1] > 1.0


def test_unbounded_law_is_warned_about_once(caplog) -> None:
    """Without the torque limit the law commands tens of kN.m at t = 0 from the paper's start: the
    motor driver says so once."""
    sc = scenario("asmc", "paper1", "on", {"torque_limit": 0.0, "drive": "backward"})
    sc["components"]["plant"]["initial"]["pose"] = [0.5, 0.0, -math.pi / 4]
    sc["experiment"]["stop"] = 1.0
    with caplog.at_level(logging.WARNING, logger="twmr"):
        twmr.simulate(sc)
    warnings = [r for r in caplog.records if "far beyond the drive's limit" in r.getMessage()]
    assert len(warnings) == 1
    assert "t = 0 s" in warnings[0].getMessage()
