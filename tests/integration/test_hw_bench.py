"""CAN drive against emulated ODrives on python-can's virtual bus: the closed loop, every safety
path, the frame log, and the paper scenario with the motor block swapped for CAN drives."""
from __future__ import annotations

import time
import uuid
from pathlib import Path

import can
import numpy as np
import pytest

from twmr.core import HardwareError
from twmr.hw import protocol as p
from twmr.hw.drive import CanMotorDrive
from twmr.master import simulate
from twmr.scenario import load, loads

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"


def channel() -> str:
    return f"test-{uuid.uuid4().hex[:8]}"


def started(**kw) -> CanMotorDrive:
    """A started drive pair; the host watchdog is 0.3 s unless a test sets it, because these
    unpaced runs keep the garbage collector on (paced runs freeze it)."""
    kw.setdefault("feedback_timeout", 0.3)
    d = CanMotorDrive("drive", **kw)
    d.setup(0.0, 1.0)
    d.initialize()
    return d


def step_for(d: CanMotorDrive, seconds: float, torque=(1.0, -1.0), speed=(2.0, -3.0)) -> None:
    t0 = time.monotonic()
    k = 0
    while time.monotonic() - t0 < seconds:
        d.torque_command, d.wheel_speed = torque, speed
        d.evaluate(k * 1e-3)
        d.do_step(k * 1e-3, 1e-3)
        k += 1
        time.sleep(1e-3)


def test_torque_reaches_the_drive_and_speed_comes_back() -> None:
    d = started(channel=channel(), gear=5.0)
    try:
        step_for(d, 0.1)
        axes = d.emulator.axes
        assert axes[0].command == pytest.approx(1.0) and axes[1].command == pytest.approx(-1.0)
        assert d.measured_speed == pytest.approx((2.0, -3.0), rel=1e-6)
    finally:
        d.terminate()


def test_torque_limit_applies() -> None:
    d = started(channel=channel(), torque_limit=0.5)
    try:
        step_for(d, 0.02, torque=(3.0, -3.0))
        assert d.torque == (0.5, -0.5)
        assert d.emulator.axes[0].command == pytest.approx(0.5)
    finally:
        d.terminate()


def test_silent_drive_trips_the_watchdog_within_the_timeout() -> None:
    d = started(channel=channel(), feedback_timeout=0.1)
    try:
        step_for(d, 0.02)
        d.emulator.silent = True
        t0 = time.monotonic()
        with pytest.raises(HardwareError, match="no encoder frame"):
            step_for(d, 1.0)
        assert time.monotonic() - t0 < 0.1 + 0.2  # timeout plus a few periods of slack
    finally:
        d.terminate()


def test_estop_from_the_bus_is_a_hardware_error() -> None:
    ch = channel()
    d = started(channel=ch)
    other = can.Bus(interface="virtual", channel=ch)
    try:
        step_for(d, 0.02)
        other.send(can.Message(arbitration_id=p.can_id(0, p.ESTOP), data=b"",
                               is_extended_id=False))
        with pytest.raises(HardwareError, match="axis error"):
            step_for(d, 0.5)
    finally:
        d.terminate()
        other.shutdown()


def test_quiet_host_makes_the_drive_stop_itself() -> None:
    d = started(channel=channel())
    try:
        step_for(d, 0.02, torque=(2.0, 2.0))
        time.sleep(0.3)  # host sends nothing: the drive's own watchdog (0.1 s) must act
        axis = d.emulator.axes[0]
        assert axis.state == p.AXIS_IDLE and axis.torque == 0.0
        assert axis.error & p.error_bit("watchdog", "0.6.10")
    finally:
        d.terminate()


def test_terminate_sends_zero_torque_and_idle(tmp_path) -> None:
    ch = channel()
    log = tmp_path / "frames.asc"
    d = started(channel=ch, log_file=str(log))
    monitor = can.Bus(interface="virtual", channel=ch)
    step_for(d, 0.02, torque=(2.0, 2.0))
    while monitor.recv(timeout=0) is not None:
        pass
    d.terminate()
    seen = []
    msg = monitor.recv(timeout=0.2)
    while msg is not None:
        seen.append(msg)
        msg = monitor.recv(timeout=0.05)
    monitor.shutdown()
    torques = {p.split_id(m.arbitration_id)[0]: p.decode_torque(m.data, 1.0) for m in seen
               if p.split_id(m.arbitration_id)[1] == p.SET_INPUT_TORQUE}
    idles = [m for m in seen if p.split_id(m.arbitration_id)[1] == p.SET_AXIS_STATE and
             int.from_bytes(m.data[:4], "little") == p.AXIS_IDLE]
    assert torques == {0: 0.0, 1: 0.0} and len(idles) == 2
    # the frame log replays to the same decoded commands
    replay = [m for m in can.LogReader(str(log))
              if p.split_id(m.arbitration_id)[1] == p.SET_INPUT_TORQUE]
    assert replay and p.decode_torque(bytes(replay[-1].data), 1.0) == 0.0
    assert any(p.decode_torque(bytes(m.data), 1.0) == 2.0 for m in replay)


def test_paper_scenario_with_can_drives_matches_the_simulated_motor() -> None:
    """The motor block as CAN drives (ideal torque path, limit above the law's torques): the
    plant sees the torques the controller sent, so the trajectories equal the simulated run's."""
    text = SCENARIO.read_text().replace("stop: 30.0", "stop: 1.0")
    native = np.array(simulate(loads(text, source="native.yaml")))
    swapped = text.replace("kind: motor_driver\n    parameters: {mode: ideal}",
                           f"kind: can_motor_drive\n    parameters: {{channel: {channel()}, "
                           f"torque_limit: 1.0e6, feedback_timeout: 1.0}}")  # unpaced run
    assert swapped != text
    result = np.array(simulate(loads(swapped, source="bench.yaml")))
    for col in native.dtype.names:
        np.testing.assert_array_equal(result[col], native[col], err_msg=col)
