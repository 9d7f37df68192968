"""The CAN protocol seam: every registered protocol is a `Link`, found by name through the
`twmr.can_protocols` entry points; an unknown name is refused with the closest one; the drive
block refuses to save or restore its state (hardware cannot be rolled back); the SDO frames of
ODrive 0.6.x match the shipped DBC."""
from __future__ import annotations

import can
import cantools
import pytest

from twmr.core import CosimError
from twmr.hw import protocol as p
from twmr.hw.drive import CanMotorDrive
from twmr.hw.link import DriveSpec, Link, protocol, protocols


def test_every_registered_protocol_is_a_link_with_its_own_node_range() -> None:
    assert {"odrive", "cia402"} <= set(protocols())
    for name in protocols():
        link = protocol(name)
        assert issubclass(link, Link) and not getattr(link, "__abstractmethods__", None)
        low, high = link.node_range.start, link.node_range.stop - 1
        assert link.node_problem((low, high)) == ""
        assert str(high + 1) in link.node_problem((low, high + 1))
        assert "repeat" in link.node_problem((low, low))


def test_an_unknown_protocol_names_the_closest_one() -> None:
    with pytest.raises(CosimError, match=r"unknown CAN protocol 'odrvie' \(did you mean "
                                         r"'odrive'\?\). Fix: use one of: cia402, odrive"):
        protocol("odrvie")


def test_the_drive_refuses_to_save_or_restore_its_state() -> None:
    d = CanMotorDrive("motor")
    assert CanMotorDrive.can_get_and_set_state is False
    with pytest.raises(CosimError, match=r"'motor'.*cannot be saved or rolled back"):
        d.get_state()
    with pytest.raises(CosimError, match="cannot be saved or rolled back"):
        d.set_state({})


def test_check_of_an_unknown_protocol_is_one_problem_with_the_closest_name() -> None:
    problems = CanMotorDrive("motor", protocol="cia420").check(frozenset({"protocol"}))
    assert problems == [("protocol", "protocol 'cia420' is unknown (did you mean 'cia402'?).",
                         "use one of: cia402, odrive (CAN protocols registered under "
                         "twmr.can_protocols).")]


def test_sdo_frames_follow_the_0_6_10_dbc() -> None:
    db = cantools.database.load_file(str(p.dbc_path("0.6.10")))
    ident, data = p.encode_sdo(3, p.SDO_WRITE, 0x1234, "float", 0.25)
    decoded = db.decode_message(ident & 0x1F, data, decode_choices=False)
    assert ident >> 5 == 3 and decoded["Opcode"] == p.SDO_WRITE
    assert decoded["Endpoint_ID"] == 0x1234
    assert p.sdo_value(data[4:], "float") == 0.25
    ident, data = p.encode_tx_sdo(3, 0x77, "bool", True)
    decoded = db.decode_message(ident & 0x1F, data, decode_choices=False)
    assert decoded["Endpoint_ID"] == 0x77 and decoded["Value"] == 1
    assert p.has_sdo("0.6.10") and not p.has_sdo("0.5.6")


def test_odrive_decoder_reads_sdo_frames_and_refuses_short_ones() -> None:
    link = protocol("odrive")
    spec = DriveSpec.of(link, None)
    ident, data = p.encode_sdo(1, p.SDO_READ, 200, "float")
    msg = can.Message(arbitration_id=ident, data=data, is_extended_id=False)
    assert link.decode(msg, spec) == [(1, "sdo_read_200", 0)]
    short = can.Message(arbitration_id=p.can_id(1, p.SET_INPUT_TORQUE), data=b"\x01",
                        is_extended_id=False)
    with pytest.raises(Exception, match="buffer"):
        link.decode(short, spec)
