"""ODrive CAN Simple frames: our struct encoders against the real DBCs decoded by cantools."""
from __future__ import annotations

import math
from pathlib import Path

import cantools
import pytest

from twmr.hw import protocol as p

SHARED = Path(__file__).resolve().parents[3] / "shared" / "can"
DBCS = {"0.5.6": "odrive-cansimple_v0.5.6.dbc", "0.6.10": "odrive-cansimple-0.6.10.dbc"}


@pytest.fixture(params=sorted(DBCS))
def fw(request):
    path = SHARED / DBCS[request.param]
    if not path.exists():
        path = p.dbc_path(request.param)
    return request.param, cantools.database.load_file(str(path))


def test_ids_are_node_shifted_by_five() -> None:
    assert p.can_id(3, p.SET_INPUT_TORQUE) == (3 << 5) | 0x0E == 0x6E
    assert p.split_id(0x6E) == (3, 0x0E)


def test_torque_frame_decodes_with_the_dbc(fw) -> None:
    _, db = fw
    ident, data = p.encode_torque(0, 3.0, gear=10.0)
    msg = db.decode_message(ident, data)
    assert msg["Input_Torque"] == pytest.approx(0.3)  # motor torque = wheel / gear
    assert p.decode_torque(data, 10.0) == pytest.approx(3.0)


def test_encoder_frame_round_trip_and_units(fw) -> None:
    _, db = fw
    ident, data = p.encode_encoder(0, wheel_angle=math.pi, wheel_speed=2 * math.pi, gear=4.0)
    msg = db.decode_message(ident, data)
    assert msg["Pos_Estimate"] == pytest.approx(2.0)  # rev of the motor
    assert msg["Vel_Estimate"] == pytest.approx(4.0)  # rev/s of the motor
    angle, speed = p.decode_encoder(data, 4.0)
    assert angle == pytest.approx(math.pi, rel=1e-6) and speed == pytest.approx(2 * math.pi)


def test_state_and_mode_frames(fw) -> None:
    _, db = fw
    ident, data = p.encode_axis_state(1, p.AXIS_CLOSED_LOOP)
    decoded = db.decode_message(ident - (1 << 5), data, decode_choices=False)
    assert decoded["Axis_Requested_State"] == 8
    ident, data = p.encode_controller_mode(0)
    m = db.decode_message(ident, data)
    assert (str(m["Control_Mode"]), str(m["Input_Mode"])) == ("TORQUE_CONTROL", "PASSTHROUGH")


def test_heartbeat_layout_per_firmware(fw) -> None:
    version, db = fw
    bit = p.error_bit("watchdog", version)
    ident, data = p.encode_heartbeat(0, p.Heartbeat(bit, 8, 1), version)
    m = db.decode_message(ident, data)
    assert (str(m["Axis_Error"]), str(m["Axis_State"])) == ("WATCHDOG_TIMER_EXPIRED",
                                                            "CLOSED_LOOP_CONTROL")
    assert p.decode_heartbeat(data, version).axis_state == 8
    p.check_layout(version)


def test_unknown_firmware_is_refused() -> None:
    with pytest.raises(ValueError, match="not supported"):
        p.firmware_line("0.4.12")


def test_limits_frame_decodes_with_the_dbc(fw) -> None:
    _, db = fw
    ident, data = p.encode_limits(2, wheel_speed_limit=math.pi, current_limit=12.5, gear=4.0)
    msg = db.decode_message(ident - (2 << 5), data)
    assert msg["Velocity_Limit"] == pytest.approx(2.0)  # motor rev/s = wheel rad/s * N / 2 pi
    assert msg["Current_Limit"] == pytest.approx(12.5)
    assert p.decode_limits(data, 4.0) == pytest.approx((math.pi, 12.5))


def test_clear_errors_and_estop_lengths_follow_the_firmware_dbc(fw) -> None:
    version, db = fw
    ident, data = p.encode_clear_errors(0, version)
    assert len(data) == db.get_message_by_frame_id(ident).length  # 0 bytes on 0.5, 1 on 0.6
    ident, data = p.encode_estop(0)
    if version.startswith("0.6"):  # the 0.5.6 DBC does not list Estop (the firmware has it)
        assert len(data) == db.get_message_by_frame_id(ident).length == 0


def test_the_shared_dbcs_pass_the_start_up_check_unchanged() -> None:
    for version, name in DBCS.items():
        path = SHARED / name
        if not path.exists():
            pytest.skip(f"{path} not present")
        p.check_layout(version, path)


def test_a_dbc_with_another_layout_is_refused(tmp_path) -> None:
    text = p.dbc_path("0.6.10").read_text()
    moved = text.replace("SG_ Input_Torque : 0|32@1+", "SG_ Input_Torque : 8|32@1+", 1)
    assert moved != text
    path = tmp_path / "odd.dbc"
    path.write_text(moved)
    with pytest.raises(ValueError, match="Set_Input_Torque"):
        p.check_layout("0.6.10", path)


def test_an_axis_error_comes_with_the_fix_of_its_cause_on_each_firmware_line() -> None:
    # the watchdog bit is 0x800 on 0.5.x and 0x1000000 on 0.6.x (the DBCs' value tables)
    for version, bit in (("0.5.6", 0x800), ("0.6.10", 0x1000000)):
        assert "axis watchdog" in p.axis_error_fix(bit, version)
        assert "axis watchdog" not in p.axis_error_fix(bit << 1, version)
    assert p.axis_error_fix(0x20, "0.6.10").startswith("read the drive's errors")  # DRV_FAULT
    assert "Estop frame" in p.axis_error_fix(0x2000000 | 0x20, "0.6.10")
