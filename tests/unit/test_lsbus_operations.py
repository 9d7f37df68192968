"""LS-BUS CAN bus operations: the byte layout of the standard's packed structs, and bad input."""
from __future__ import annotations

import pytest

from twmr.fmi.lsbus import operations as ops
from twmr.fmi.lsbus.operations import (
    ArbitrationLost,
    BusError,
    BusOperationError,
    CanFdTransmit,
    CanTransmit,
    Configuration,
    Confirm,
    Status,
    Wakeup,
    decode,
    encode,
)

# CAN Transmit id 0x123, standard, no rtr, 2 bytes: header (opcode 0x10, length 18), id, ide, rtr,
# data length, data — as fmi3LsBusCanOperationCanTransmit lays it out (packed, little-endian).
TRANSMIT = bytes.fromhex("10000000" "12000000" "23010000" "00" "00" "0200" "abcd")
CONFIRM = bytes.fromhex("20000000" "0c000000" "23010000")
BAUD = bytes.fromhex("40000000" "0d000000" "01" "20a10700")  # 500 kbit/s


def test_layout_matches_the_standard() -> None:
    assert encode([CanTransmit(0x123, b"\xab\xcd")]) == TRANSMIT
    assert encode([Confirm(0x123)]) == CONFIRM
    assert encode([Configuration(ops.CONFIG_CAN_BAUDRATE, 500_000)]) == BAUD
    assert encode([Configuration(ops.CONFIG_ARBITRATION_LOST_BEHAVIOR,
                                 ops.DISCARD_AND_NOTIFY)]) == bytes.fromhex("400000000a0000000402")
    assert encode([Wakeup()]) == bytes.fromhex("4200000008000000")
    assert len(encode([BusError(1, ops.ERROR_CRC)])) == 8 + 4 + 3
    assert len(encode([CanFdTransmit(7, bytes(12), brs=True)])) == 8 + 4 + 3 + 2 + 12


def test_decode_sequence() -> None:
    raw = TRANSMIT + CONFIRM + BAUD + encode([ArbitrationLost(5), Status(ops.STATUS_BUS_OFF)])
    assert decode(raw) == [CanTransmit(0x123, b"\xab\xcd"), Confirm(0x123),
                           Configuration(ops.CONFIG_CAN_BAUDRATE, 500_000), ArbitrationLost(5),
                           Status(ops.STATUS_BUS_OFF)]
    assert decode(b"") == []


def test_remote_frame_has_no_data() -> None:
    raw = encode([CanTransmit(0x42, rtr=True, dlc=4)])
    assert raw == bytes.fromhex("10000000" "10000000" "42000000" "00" "01" "0400")
    assert decode(raw) == [CanTransmit(0x42, b"", False, True, 4)]


@pytest.mark.parametrize("raw, words", [
    (bytes.fromhex("99000000" "08000000"), ["unknown operation code 0x99", "byte 0"]),
    (CONFIRM + bytes.fromhex("20000000" "0d000000" "2301000000"),
     ["0x20 (Confirm) at byte 12", "length 13, expected 12"]),
    (TRANSMIT[:-1], ["runs past the end"]),
    (bytes.fromhex("10000000" "13000000" "23010000" "00" "00" "0200" "abcdef"),
     ["does not match its data length 2"]),
    (bytes.fromhex("10000000" "19000000" "23010000" "00" "00" "0900") + bytes(9),
     ["9 data bytes", "at most 8"]),
    (bytes.fromhex("2000"), ["shorter than the 8-byte operation header"]),
    (bytes.fromhex("20000000" "04000000"), ["shorter than the 8-byte header"]),
    (bytes.fromhex("40000000" "0d000000" "09" "00000000"), ["unknown parameter type 0x09"]),
])
def test_malformed_operations_are_named(raw: bytes, words: list[str]) -> None:
    with pytest.raises(BusOperationError) as err:
        decode(raw)
    for word in words:
        assert word in str(err.value)


def test_encode_refuses_impossible_frames() -> None:
    with pytest.raises(BusOperationError, match="at most 8"):
        encode([CanTransmit(1, bytes(9))])
    with pytest.raises(BusOperationError, match="not a CAN FD length"):
        encode([CanFdTransmit(1, bytes(9))])


def test_names_are_the_standards() -> None:
    assert [ops.name(op) for op in (CanTransmit(1), Confirm(1), ArbitrationLost(1),
                                    BusError(1, ops.ERROR_ACK), Wakeup())] == [
        "CAN Transmit", "Confirm", "Arbitration Lost", "Bus Error", "Wakeup"]
