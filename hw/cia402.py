"""CiA 402 (CANopen drive profile): the power state machine and unit conversions, pure logic.

The host side walks a drive to OPERATION ENABLED with `next_controlword(state)` (fault reset,
shutdown, switch on, enable operation); the drive side (`drive_transition`) is the standard's
state table, used by an emulator and by the tests that check every transition. Torque is sent as
target torque 0x6071 in per-mille of the motor rated torque 0x6076 (mN.m), speed and position come
back as 0x606C (velocity units per second-scaled, here rpm by default as on maxon EPOS4) and 0x6064
(increments). The bus side (canopen nodes, PDOs, SYNC) is `cia402_link`; the drive side of the
emulator is `cia402_emulator`.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from enum import Enum

from twmr.hw.link import option


@dataclass(frozen=True)
class Cia402Options:
    """What a CiA 402 link, its decoder and its emulator read beyond `DriveSpec`."""

    eds: str = option("", file=True, description="EDS/DCF of the drives ('' = the shipped "
                      "maxon EPOS4 EDS)")
    rated_torque: int = option(100_000, min=1, description="rated torque [mN.m] used when the "
                               "drive reports 0 in 0x6076")
    increments_per_rev: int = option(4096, min=1, description="encoder increments per motor "
                                     "revolution")


CONTROLWORD, STATUSWORD, MODES_OF_OPERATION = 0x6040, 0x6041, 0x6060
TARGET_TORQUE, MAX_TORQUE, MOTOR_RATED_TORQUE = 0x6071, 0x6072, 0x6076
VELOCITY_ACTUAL, POSITION_ACTUAL = 0x606C, 0x6064
CYCLIC_SYNC_TORQUE = 10
HEARTBEAT_CONSUMER = 0x1016  # sub 1: (producer node << 16) | timeout [ms] (CiA 301)
ABORT_CONNECTION = 0x6007  # what the drive does when the host's heartbeat is lost
ABORT_FAULT = 1  # ... fault signal: the drive goes to FAULT (torque off)
HOST_NODE = 127  # the node id the host's heartbeat is sent under (0x77F)
# the PDOs the host maps (cia402_link.configure), COB-ID = base + node
RPDO1, TPDO1 = 0x200, 0x180  # controlword + target torque; statusword + velocity actual
_RPDO1, _TPDO1 = struct.Struct("<Hh"), struct.Struct("<Hi")

# controlword commands (bits 0-3, 7)
SHUTDOWN, SWITCH_ON, ENABLE_OPERATION = 0x06, 0x07, 0x0F
DISABLE_VOLTAGE, QUICK_STOP, DISABLE_OPERATION, FAULT_RESET = 0x00, 0x02, 0x07, 0x80


class State(Enum):
    NOT_READY = "not ready to switch on"
    SWITCH_ON_DISABLED = "switch on disabled"
    READY = "ready to switch on"
    SWITCHED_ON = "switched on"
    OPERATION_ENABLED = "operation enabled"
    QUICK_STOP = "quick stop active"
    FAULT_REACTION = "fault reaction active"
    FAULT = "fault"


_STATUS = [  # (mask, value, state), CiA 402 table of the statusword
    (0x4F, 0x00, State.NOT_READY), (0x4F, 0x40, State.SWITCH_ON_DISABLED),
    (0x6F, 0x21, State.READY), (0x6F, 0x23, State.SWITCHED_ON),
    (0x6F, 0x27, State.OPERATION_ENABLED), (0x6F, 0x07, State.QUICK_STOP),
    (0x4F, 0x0F, State.FAULT_REACTION), (0x4F, 0x08, State.FAULT),
]
_STATUSWORD = {State.NOT_READY: 0x00, State.SWITCH_ON_DISABLED: 0x40, State.READY: 0x21,
               State.SWITCHED_ON: 0x23, State.OPERATION_ENABLED: 0x27, State.QUICK_STOP: 0x07,
               State.FAULT_REACTION: 0x0F, State.FAULT: 0x08}


def decode_statusword(word: int) -> State:
    """The power state a statusword reports."""
    for mask, value, state in _STATUS:
        if word & mask == value:
            return state
    raise ValueError(f"statusword 0x{word:04x} matches no CiA 402 state")


def statusword(state: State) -> int:
    """A statusword reporting `state` (the bits the state table defines)."""
    return _STATUSWORD[state]


def next_controlword(state: State) -> int:
    """The controlword that moves a drive one transition toward OPERATION ENABLED."""
    return {State.FAULT: FAULT_RESET, State.SWITCH_ON_DISABLED: SHUTDOWN,
            State.READY: SWITCH_ON, State.SWITCHED_ON: ENABLE_OPERATION,
            State.OPERATION_ENABLED: ENABLE_OPERATION, State.QUICK_STOP: DISABLE_VOLTAGE,
            State.NOT_READY: DISABLE_VOLTAGE, State.FAULT_REACTION: DISABLE_VOLTAGE}[state]


def drive_transition(state: State, control: int, previous_control: int = 0) -> State:
    """The drive's next state after `control` (CiA 402 transitions 2-16; fault reset acts on
    the rising edge of bit 7)."""
    if state in (State.FAULT_REACTION,):
        return State.FAULT  # 14: automatic once the reaction is done
    if state == State.FAULT:
        rising = control & 0x80 and not previous_control & 0x80
        return State.SWITCH_ON_DISABLED if rising else State.FAULT  # 15
    if state == State.NOT_READY:
        return State.SWITCH_ON_DISABLED  # 1: automatic after self-test
    if control & 0x02 == 0:  # disable voltage: 7, 9, 10, 12
        return State.SWITCH_ON_DISABLED
    if control & 0x04 == 0:  # quick stop (bit 2 low)
        return State.QUICK_STOP if state == State.OPERATION_ENABLED else \
            State.SWITCH_ON_DISABLED  # 11 / 7, 10
    cmd = control & 0x0F
    if state == State.QUICK_STOP:
        return State.QUICK_STOP  # 16 (back to enabled) is optional: not supported
    if cmd == SHUTDOWN:
        return State.READY  # 2, 6, 8
    if cmd == SWITCH_ON:
        return {State.READY: State.SWITCHED_ON, State.OPERATION_ENABLED: State.SWITCHED_ON
                }.get(state, state)  # 3, 5
    if cmd == ENABLE_OPERATION:
        return {State.SWITCHED_ON: State.OPERATION_ENABLED, State.READY: State.OPERATION_ENABLED
                }.get(state, state)  # 4 (3+4 in one go allowed)
    return state


def torque_to_permille(wheel_torque: float, gear: float, rated_torque_mNm: int) -> int:
    """Target torque 0x6071 [per mille of 0x6076] for a wheel torque [N.m], clamped to INTEGER16."""
    value = round(1000.0 * (wheel_torque / gear) / (rated_torque_mNm / 1000.0))
    return max(-32768, min(32767, value))


def limit_to_permille(wheel_torque: float, gear: float, rated_torque_mNm: int) -> int:
    """Max torque 0x6072 [per mille of 0x6076, UNSIGNED16] for a wheel torque limit [N.m]."""
    return max(0, min(65535, round(1000.0 * (wheel_torque / gear) / (rated_torque_mNm / 1000.0))))


def permille_to_torque(permille: int, gear: float, rated_torque_mNm: int) -> float:
    """Wheel torque [N.m] of a 0x6071 / 0x6077 value."""
    return permille / 1000.0 * rated_torque_mNm / 1000.0 * gear


def velocity_to_si(value: int, gear: float, rpm_per_unit: float = 1.0) -> float:
    """Wheel speed [rad/s] from 0x606C (motor rpm times `rpm_per_unit`)."""
    return value * rpm_per_unit * 2.0 * math.pi / 60.0 / gear


def position_to_si(increments: int, gear: float, increments_per_rev: int) -> float:
    """Wheel angle [rad] from 0x6064 (motor encoder increments)."""
    return increments / increments_per_rev * 2.0 * math.pi / gear


def encode_rpdo1(node: int, controlword: int, permille: int) -> tuple[int, bytes]:
    """RPDO1 of `node`: controlword 0x6040, target torque 0x6071 [per mille]."""
    return RPDO1 + node, _RPDO1.pack(controlword, permille)


def decode_rpdo1(data: bytes) -> tuple[int, int]:
    """(controlword, target torque [per mille]) of an RPDO1 payload."""
    word, permille = _RPDO1.unpack_from(data)
    return word, permille


def encode_tpdo1(node: int, statusword: int, velocity: int) -> tuple[int, bytes]:
    """TPDO1 of `node`: statusword 0x6041, velocity actual 0x606C."""
    return TPDO1 + node, _TPDO1.pack(statusword, velocity)


def decode_tpdo1(data: bytes) -> tuple[int, int]:
    """(statusword, velocity actual 0x606C) of a TPDO1 payload."""
    word, velocity = _TPDO1.unpack_from(data)
    return word, velocity
