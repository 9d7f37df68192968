"""Bus options (python-can config files), the frame log, the host watchdog's staleness rule,
torque clamping, and the CiA 402 frame decoder of the replay against frames built from a real EDS
by canopen."""
from __future__ import annotations

import math
import uuid
from pathlib import Path

import can
import canopen
import pytest

from twmr.hw import cia402 as c
from twmr.hw import protocol as odrive
from twmr.hw.bus import FrameLog, bus_options
from twmr.hw.replay import Decoder, decode_log
from twmr.hw.safety import clamp, stale

EDS = Path(__file__).resolve().parents[2] / "hw" / "data" / "maxon_epos4_module_50-5.eds"


def test_bus_options_from_parameters_and_from_a_python_can_file(tmp_path: Path) -> None:
    assert bus_options("pcan", "PCAN_USBBUS1", 500000) == {
        "interface": "pcan", "channel": "PCAN_USBBUS1", "bitrate": 500000}
    ini = tmp_path / "can.ini"
    ini.write_text("[default]\ninterface = socketcan\nchannel = can0\n\n"
                   "[bench]\ninterface = kvaser\nchannel = 0\nbitrate = 1000000\n")
    got = bus_options("virtual", "x", 1, str(ini), "bench")
    assert (got["interface"], str(got["channel"]), int(got["bitrate"])) == ("kvaser", "0", 1000000)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        bus_options("virtual", "x", 1, str(tmp_path / "missing.ini"))


@pytest.mark.parametrize("suffix", [".blf", ".asc"])
@pytest.mark.parametrize("name", ["digits", "name-70000"])
def test_frame_log_keeps_the_frames_of_a_channel_named_by_digits(tmp_path: Path, suffix: str,
                                                                 name: str) -> None:
    """python-can makes a virtual channel named by digits an int (and BLF reads a channel
    name's trailing digits as its number); BLF packs the channel into 16 bits, so such a frame
    once ended the log at the first received frame: an empty log."""
    ch = str(10**9 + uuid.uuid4().int % 10**9) if name == "digits" else \
        f"{uuid.uuid4().hex[:8]}-70000"
    drive, host = (can.Bus(interface="virtual", channel=ch) for _ in range(2))
    log = FrameLog(tmp_path / f"frames{suffix}")
    try:
        drive.send(can.Message(arbitration_id=0x009, data=bytes(8), is_extended_id=False))
        got = host.recv(timeout=1.0)
        assert got is not None and got.channel is not None
        log.received(got)
        ident, data = odrive.encode_torque(0, 1.5, 1.0)
        log.sent(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
    finally:
        log.close()
        drive.shutdown()
        host.shutdown()
    assert log.error == ""
    decoded = decode_log(log.path, Decoder())
    assert [(d.direction, d.node, d.signal, d.value) for d in decoded] == [
        ("Rx", 0, "angle", 0.0), ("Rx", 0, "speed", 0.0), ("Tx", 0, "torque_command", 1.5)]


def test_stale_names_the_first_old_feedback_then_heartbeat() -> None:
    assert stale(10.0, {0: 9.995, 1: 9.999}, {0: 9.9, 1: 9.9}, 0.01, 0.5) is None
    fault = stale(10.0, {0: 9.995, 1: 9.98}, {0: 9.9, 1: 9.9}, 0.01, 0.5)
    assert fault is not None and fault.node == 1 and "20.0 ms" in fault.what
    fault = stale(10.0, {0: 10.0, 1: 10.0}, {0: 9.9, 1: 9.2}, 0.01, 0.5)
    assert fault is not None and fault.node == 1 and "heartbeat lost" in fault.what
    assert "drive node 1" in fault.text() and "Torque set to zero" in fault.text()


def test_clamp() -> None:
    assert clamp((3.0, -7.5, 0.2), 1.0) == (1.0, -1.0, 0.2)


def test_cia402_frames_decode_to_si() -> None:
    od = canopen.import_od(str(EDS), 3)
    rpdo = od[c.CONTROLWORD].encode_raw(0x0F) + od[c.TARGET_TORQUE].encode_raw(-250)
    tpdo1 = od[c.STATUSWORD].encode_raw(0x0627) + od[c.VELOCITY_ACTUAL].encode_raw(600)
    tpdo2 = od[c.POSITION_ACTUAL].encode_raw(8192)
    dec = Decoder("cia402", gear=10.0,
                  options=(("rated_torque", 2000), ("increments_per_rev", 4096)))
    frame = lambda ident, data: can.Message(arbitration_id=ident, data=data)  # noqa: E731
    assert dec(frame(0x203, rpdo)) == [(3, "controlword", 0x0F), (3, "torque_command",
                                                                  pytest.approx(-5.0))]
    (_, _, word), (_, _, speed) = dec(frame(0x183, tpdo1))
    assert c.decode_statusword(int(word)) == c.State.OPERATION_ENABLED
    assert speed == pytest.approx(2 * math.pi)  # 600 rpm / gear 10 = 1 rev/s
    assert dec(frame(0x283, tpdo2)) == [(3, "angle", pytest.approx(2 * math.pi / 10 * 2))]
    assert dec(frame(0x083, bytes([0x10, 0x23, 1, 0, 0, 0, 0, 0]))) == [(3, "emcy", 0x2310)]
    assert dec(frame(0x080, b"")) == [(None, "sync", 1.0)]


def test_a_frame_log_keeps_the_time_of_a_frame_received_before_the_first_written(
        tmp_path: Path) -> None:
    """The notifier's thread can hand a received frame after the sender has logged a later
    one: in the BLF each keeps its own time (python-can's writer used to take the file's start
    from the first frame written and put an earlier one at that start, to the ms)."""
    import time

    import can

    from twmr.hw.bus import FrameLog

    log = FrameLog(tmp_path / "frames.blf")
    log.sent(can.Message(arbitration_id=0x0E, data=bytes(8), is_extended_id=False))
    sent_at = time.time()
    early = can.Message(arbitration_id=0x09, data=bytes(8), is_extended_id=False, is_rx=True,
                        timestamp=sent_at - 0.0007)
    log.received(early)
    log.close()
    frames = list(can.LogReader(str(tmp_path / "frames.blf")))
    got = {m.arbitration_id: m.timestamp for m in frames}
    assert got[0x09] == pytest.approx(sent_at - 0.0007, abs=2e-6)
    assert got[0x09] < got[0x0E]
