"""ODrive drives (CAN Simple) against the emulated drives on python-can's virtual bus: start-up,
torque and feedback with their units, limits on both sides, polled estimates and round trips,
bus configuration from a python-can config file, the paper scenario with the motor block as
CAN drives, and the drives started after the other blocks' initialize."""
from __future__ import annotations

import time
from pathlib import Path

import can
import numpy as np
import pytest

from tests.hw_bench import WATCHDOG, Monitor, Paced, channel, eventually, started
from twmr.components.metrics import errors
from twmr.hw import protocol as p
from twmr.master import simulate
from twmr.scenario import loads

SCENARIO = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
BENCH = SCENARIO.with_name("bench_odrive_trajectory1.yaml")


@pytest.mark.parametrize("firmware", ["0.5.6", "0.6.10"])
def test_torque_reaches_the_drive_and_speed_comes_back(firmware: str) -> None:
    d = started(firmware=firmware, gear=5.0)
    try:
        Paced(d).run(40)
        axes = d.emulators[0].axes
        assert axes[0].command == pytest.approx(1.0) and axes[1].command == pytest.approx(-1.0)
        assert axes[0].control_mode == p.CONTROL_TORQUE and axes[0].state == p.AXIS_CLOSED_LOOP
        assert d.measured_speed == pytest.approx((2.0, -3.0), rel=1e-6)  # float32 rev/s
    finally:
        d.terminate()


def test_start_up_sends_the_documented_sequence() -> None:
    ch = channel()
    mon = Monitor(ch)
    d = started(channel=ch, gear=4.0, torque_limit=2.0, torque_constant=0.05, speed_limit=10.0)
    d.terminate()
    first = {}
    for m in mon.frames():
        node, cmd = p.split_id(m.arbitration_id)
        first.setdefault((node, cmd), m)
    for node in (0, 1):
        assert (node, p.CLEAR_ERRORS) in first and (node, p.SET_CONTROLLER_MODE) in first
        speed, current = p.decode_limits(first[(node, p.SET_LIMITS)].data, 4.0)
        assert speed == pytest.approx(10.0, rel=1e-6)
        assert current == pytest.approx(2.0 / (4.0 * 0.05), rel=1e-6)  # 10 A at the motor
        assert int.from_bytes(first[(node, p.SET_AXIS_STATE)].data[:4], "little") == 8


def test_torque_is_limited_by_the_host_and_by_the_drive() -> None:
    ch = channel()
    d = started(channel=ch, torque_limit=0.5)
    rogue = can.Bus(interface="virtual", channel=ch)
    try:
        Paced(d).run(10, torque=(3.0, -3.0))
        assert d.torque == (0.5, -0.5)
        assert d.emulators[0].axes[0].torque == pytest.approx(0.5)
        # a raw command past the limit: the drive's own limit (Set_Limits current x torque
        # constant = 12.5 A x 0.04 N.m/A) holds it
        rogue.send(can.Message(arbitration_id=p.can_id(0, p.SET_INPUT_TORQUE),
                               data=p.encode_torque(0, 9.0, 1.0)[1], is_extended_id=False))
        axis = d.emulators[0].axes[0]
        assert eventually(lambda: axis.command == pytest.approx(9.0))
        assert axis.torque == pytest.approx(0.5)
    finally:
        d.terminate()
        rogue.shutdown()


def test_polled_estimates_answer_each_period_with_a_round_trip() -> None:
    d = started(encoder="polled")
    d.emulators[0].encoder_period = 0.0  # no cyclic estimates: only the answers to our requests
    try:
        loop = Paced(d)
        loop.run(50)
        report = d.report()
        # every period asks both drives; on a loaded machine an answer may come after the next
        # request and is not paired with it, so at least half are asked for
        assert report["can_rtt_samples"] >= 49
        assert 0 < report["can_rtt_p50_us"] < 1e6 * 0.002 * (1 + loop.behind)
        assert d.measured_speed == pytest.approx((2.0, -3.0), rel=1e-6)
    finally:
        d.terminate()


def test_bus_from_a_python_can_config_file(tmp_path: Path) -> None:
    ch = channel()
    ini = tmp_path / "can.ini"
    ini.write_text(f"[default]\ninterface = virtual\nchannel = wrong\n\n"
                   f"[bench]\ninterface = virtual\nchannel = {ch}\nbitrate = 1000000\n")
    mon = Monitor(ch)
    d = started(channel="not-used", can_config=str(ini), can_context="bench")
    try:
        Paced(d).run(5)
    finally:
        d.terminate()
    assert any(p.split_id(m.arbitration_id)[1] == p.SET_INPUT_TORQUE for m in mon.frames())


def test_paper_scenario_with_can_drives_is_close_to_the_simulated_motor() -> None:
    """The motor block as ODrive drives (48 N.m limit, as the simulated motor), paced at 1 kHz.
    Torques travel as float32 (relative rounding <= 6e-8) and the plant receives what the drives
    receive; the closed loop can amplify such rounding over time. Bound asserted over 1 s: 1e-6 m
    (the all-simulated tracking error is ~1 m there)."""
    text = SCENARIO.read_text().replace("stop: 30.0", "stop: 1.0")
    native = np.array(simulate(loads(text, source="native.yaml")))
    swapped = text.replace("kind: motor_driver\n    parameters: {mode: ideal, torque_max: 48.0}",
                           f"kind: can_drive\n    parameters: {{channel: {channel()}, "
                           f"torque_limit: 48.0, watchdog_periods: {WATCHDOG}}}")
    assert swapped != text
    result = np.array(simulate(loads(swapped, source="bench.yaml")))
    _t, ex, ey = errors(native)
    _, bx, by = errors(result)
    assert np.max(np.hypot(ex - bx, ey - by)) < 1e-6
    assert np.max(np.hypot(ex, ey)) > 0.1  # the bound is small against what is tracked
    torque_sent = np.column_stack([result["motor.torque[1]"], result["motor.torque[2]"]])
    torque_law = np.column_stack([result["ctrl.torque[1]"], result["ctrl.torque[2]"]])
    np.testing.assert_allclose(torque_sent, torque_law.astype(np.float32), rtol=0, atol=0)


def test_drives_start_after_the_other_blocks_initialize(monkeypatch: pytest.MonkeyPatch) -> None:
    """Started drives hear nothing until the first step, and their own watchdog (drive_watchdog
    0.1 s) stops them: a block after them whose initialize took 0.6-2.3 s (the plant's numba
    compile from a cold cache, measured) stopped the bench run at t = 0. Here the plant's
    initialize takes 0.5 s more: the drives start after it, and the run ends normally."""
    text = BENCH.read_text().replace("stop: 10.0", "stop: 0.05").replace(
        "channel: bench", f"channel: {channel()}, watchdog_periods: {WATCHDOG}")
    system = loads(text, source="bench.yaml")
    assert system.order.index("motor") < system.order.index("plant")
    plant = system.components["plant"]
    initialize = plant.initialize

    def slow() -> None:
        initialize()
        time.sleep(0.5)

    monkeypatch.setattr(plant, "initialize", slow)
    result = simulate(system)
    assert len(result) == 6  # every recorded row (decimation 5) up to the stop
    assert result["ctrl.torque[1]"][-1] != 0.0
