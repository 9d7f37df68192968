"""The CAN bus model (`twmr.hw.cansim`): frame lengths against bit counts made by hand from
ISO 11898-1's frame layout, arbitration order, delivery times, and the frames it refuses."""
from __future__ import annotations

import math
import random

import can
import pytest

from twmr.hw.cansim import CanBusModel, crc15, frame_problem, frame_timing, stuff_bits


def std(ident: int, data: bytes = b"", **kw: object) -> can.Message:
    return can.Message(arbitration_id=ident, data=data, is_extended_id=False, **kw)


def test_crc15_has_the_published_check_value() -> None:
    # CRC-15/CAN of the ASCII bytes "123456789": 0x059E (the CRC catalogue's check value)
    assert crc15("", b"123456789") == 0x059E
    assert crc15("".join(f"{b:08b}" for b in b"123456789")) == 0x059E


def test_stuff_bits_count_a_stuff_bit_in_the_run_after_it() -> None:
    assert stuff_bits("00000") == 1 and stuff_bits("00000", trailing=False) == 0
    assert stuff_bits("0000011110") == 2  # 00000[1]1111[0]0: the stuff 1 starts the ones' run
    assert stuff_bits("000010000") == 0
    assert stuff_bits("0" * 34) == 6


def test_an_all_zero_frame_has_the_bits_counted_by_hand() -> None:
    """Identifier 0, no data: SOF, 11 identifier bits, RTR, IDE, r0 and the DLC are 19 zeros;
    the CRC-15 of zeros is 0, so the stuffed part is 34 zeros, which take 6 stuff bits (one
    after every 5 equal bits, each starting the next run); then CRC delimiter, ACK slot, ACK
    delimiter, 7 EOF and 3 intermission bits: 34 + 6 + 13 = 53 bits, 106 us at 500 kbit/s,
    the last 3 of them (6 us) after the end of EOF."""
    timing = frame_timing(std(0), 500_000)
    assert timing.bits == 53
    assert timing.to_free == pytest.approx(106e-6, abs=1e-12)
    assert timing.to_eof == pytest.approx(100e-6, abs=1e-12)


@pytest.mark.parametrize("extended, n, bits", [(False, 8, 135), (True, 8, 160), (False, 0, 55)])
def test_worst_case_stuffing_is_the_classic_bound(extended: bool, n: int, bits: int) -> None:
    """g + 8n + 13 + floor((g + 8n - 1) / 4) bits, g = 34 (11-bit) or 54 (29-bit): 34 + 64 + 13
    + 24 = 135, 54 + 64 + 13 + 29 = 160, 34 + 13 + 8 = 55."""
    frame = can.Message(arbitration_id=0x123, data=bytes(n), is_extended_id=extended)
    assert frame_timing(frame, 1e6, stuffing="worst").bits == bits


def test_a_can_fd_frame_switches_to_the_data_rate_after_brs() -> None:
    """11-bit id 0x123, 64 zero bytes, BRS, 1 / 4 Mbit/s. Nominal: SOF 0, id 00100100011, RRS 0,
    IDE 0, FDF 1, res 0, BRS 1 (17 bits, no run of 5) + CRC delimiter, ACK, ACK delimiter, EOF,
    intermission (13) = 30 bits. Data phase: ESI 0, DLC 1111, 512 zero bits (102 stuff bits,
    none after the last), stuff count 4 + CRC-21 + 7 fixed stuff bits: 5 + 512 + 102 + 32 = 651
    bits. 30 us + 651 / 4 us = 192.75 us."""
    frame = can.Message(arbitration_id=0x123, data=bytes(64), is_extended_id=False, is_fd=True,
                        bitrate_switch=True)
    timing = frame_timing(frame, 1e6, 4e6)
    assert (timing.nominal_bits, timing.data_bits) == (30, 651)
    assert timing.to_free == pytest.approx(192.75e-6, abs=1e-12)
    slow = can.Message(arbitration_id=0x123, data=bytes(64), is_extended_id=False, is_fd=True)
    assert frame_timing(slow, 1e6, 4e6).to_free == pytest.approx(681e-6, abs=1e-12)


def test_exact_stuffing_lies_between_none_and_the_worst_case() -> None:
    rng = random.Random(7)
    for _ in range(300):
        n = rng.randint(0, 8)
        frame = can.Message(arbitration_id=rng.randint(0, 0x7FF), data=rng.randbytes(n),
                            is_extended_id=False)
        exact = frame_timing(frame, 1e6).bits
        assert 47 + 8 * n <= exact <= frame_timing(frame, 1e6, stuffing="worst").bits


def three_at_once(model: CanBusModel) -> None:
    for name, ident in (("a", 0x300), ("b", 0x100), ("c", 0x200)):
        model.join(name)
        assert model.submit(name, std(ident, bytes(8)), 0.0) == ""


def test_the_lowest_identifier_pending_wins_and_each_frame_takes_its_bits() -> None:
    """Worst-case stuffing: every 8-byte frame is 135 bits, 270 us at 500 kbit/s, received at
    the end of EOF (132 bits, 264 us after its start); the bus is free after the intermission."""
    model = CanBusModel(bitrate=500_000, stuffing="worst")
    three_at_once(model)
    events = model.advance(1.0)
    sent = [(e.frame.arbitration_id, e.start, e.time) for e in events if e.kind == "transmit"]
    assert [s[0] for s in sent] == [0x100, 0x200, 0x300]
    for (_, start, end), k in zip(sent, range(3), strict=True):
        assert start == pytest.approx(k * 270e-6, abs=1e-12)
        assert end == pytest.approx(k * 270e-6 + 264e-6, abs=1e-12)
    lost = [(e.frame.arbitration_id, e.time) for e in events if e.kind == "arbitration_lost"]
    assert lost == [(0x300, 0.0), (0x200, 0.0), (0x300, pytest.approx(270e-6))]
    confirms = [(e.sender, e.time) for e in events if e.kind == "confirm"]
    assert [c[0] for c in confirms] == ["b", "c", "a"]


def test_delivery_waits_for_its_time() -> None:
    model = CanBusModel(bitrate=500_000, stuffing="worst")
    three_at_once(model)
    assert model.next_time() == 0.0
    first = model.advance(263e-6)
    assert [e.kind for e in first] == ["arbitration_lost", "arbitration_lost"]
    assert model.next_time() == pytest.approx(264e-6)
    assert [e.kind for e in model.advance(264e-6)] == ["transmit", "confirm"]


def test_a_frame_on_the_wire_is_not_preempted_and_each_sender_keeps_its_order() -> None:
    model = CanBusModel(bitrate=1e6, stuffing="worst")
    for name in ("a", "b"):
        model.join(name)
    model.submit("a", std(0x400, bytes(8)), 0.0)
    model.submit("b", std(0x010, bytes(8)), 10e-6)  # bus busy: waits for 0x400 to end
    model.submit("a", std(0x005, bytes(8)), 20e-6)  # behind a's 0x400 in a's own queue
    order = [e.frame.arbitration_id for e in model.advance(1.0) if e.kind == "transmit"]
    assert order == [0x400, 0x005, 0x010]


@pytest.mark.parametrize("first, second", [
    (std(0x123, bytes(8)), std(0x123, is_remote_frame=True, dlc=8)),
    (std(0x123, bytes(8)), can.Message(arbitration_id=0x123 << 18, data=bytes(8),
                                       is_extended_id=True)),
], ids=["data-beats-remote", "standard-beats-extended"])
def test_arbitration_beyond_the_identifier(first: can.Message, second: can.Message) -> None:
    model = CanBusModel()
    for name in ("x", "y"):
        model.join(name)
    model.submit("x", second, 0.0)
    model.submit("y", first, 0.0)
    sent = [e.frame for e in model.advance(1.0) if e.kind == "transmit"]
    assert sent[0] is first


def test_a_frame_no_one_acknowledges_is_an_ack_error() -> None:
    model = CanBusModel()
    model.join("alone")
    model.submit("alone", std(0x10, b"\x01"), 0.0)
    events = model.advance(1.0)
    assert [e.kind for e in events] == ["bus_error"]
    assert "ACK error" in events[0].detail and not math.isnan(events[0].start)


@pytest.mark.parametrize("frame, fd, says", [
    (std(0x10, bytes(9)), False, "longer than classic CAN allows (8)"),
    (std(0x10, bytes(4), dlc=2), False, "DLC says 2 bytes and it carries 4"),
    (std(0x800, b""), False, "outside 0..0x7ff"),
    (can.Message(arbitration_id=1, data=bytes(8), is_fd=True), False, "classic CAN bus"),
    (can.Message(arbitration_id=1, data=bytes(9), is_fd=True), True, "no CAN FD length"),
    (can.Message(arbitration_id=1, data=bytes(65), is_fd=True), True, "longer than CAN FD"),
    (can.Message(arbitration_id=1, is_error_frame=True), False, "error frame"),
], ids=["9-bytes", "dlc-short", "id-range", "fd-on-classic", "fd-9", "fd-65", "error-frame"])
def test_a_frame_that_cannot_exist_on_the_bus_is_refused(frame: can.Message, fd: bool,
                                                          says: str) -> None:
    frame = can.Message(arbitration_id=frame.arbitration_id, data=frame.data, dlc=frame.dlc,
                        is_fd=frame.is_fd, is_extended_id=frame.is_extended_id,
                        is_error_frame=frame.is_error_frame, check=False)
    assert says in frame_problem(frame, fd)
    model = CanBusModel(fd=fd)
    model.join("a")
    model.join("b")
    assert says in model.submit("a", frame, 0.5)
    events = model.advance(1.0)
    assert [(e.kind, e.sender, e.time) for e in events] == [("bus_error", "a", 0.5)]


def test_a_bus_reference_is_found_beside_the_drive_first_then_outward() -> None:
    from twmr.hw.canbus_block import CanBus, bus_problem, candidates
    from twmr.hw.drive import CanMotorDrive

    assert candidates("robot.base.motor", "can0") == ["robot.base.can0", "robot.can0", "can0"]
    peers = {"robot.can0": CanBus("robot.can0"), "robot.motor": CanMotorDrive("robot.motor"),
             "plant": CanMotorDrive("plant")}
    assert bus_problem("robot.motor", "can0", peers) == ""
    assert "not a can_bus" in bus_problem("robot.motor", "plant", peers)
    missing = bus_problem("motor", "can0", peers)
    assert "no component" in missing and "robot.can0" in missing
