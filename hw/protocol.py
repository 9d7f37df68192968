"""ODrive "CAN Simple" frames: pure encode/decode, no I/O, SI units at the edges.

11-bit identifiers are node_id << 5 | cmd_id. The per-period path uses precompiled `struct`
formats (cantools costs ~8 us a frame); `check_layout` verifies those formats against the DBC of
the firmware in use (0.5.x and 0.6.x differ in the heartbeat) with cantools at start-up.

Units: the drive works in motor turns (rev, rev/s) and motor N.m; the ports are wheel rad, rad/s
and wheel N.m, through the gear ratio N (motor turns per wheel turn).
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from twmr.hw.link import option


@dataclass(frozen=True)
class OdriveOptions:
    """What an ODrive link, its decoder and its emulator read beyond `DriveSpec`."""

    firmware: str = option("0.6.10", description="ODrive firmware (0.5.x | 0.6.x)")
    encoder: str = option("cyclic", description="cyclic | polled estimates")
    speed_limit: float = option(200.0, unit="rad/s", min=0.0,
                                description="wheel speed limit (Set_Limits)")
    torque_constant: float = option(0.04, unit="N.m/A", min=1e-9, description="motor torque "
                                     "constant; current limit = torque_limit / (gear K_t)")
    drive_watchdog: float = option(0.1, unit="s", min=0.0, description="0.6.x: the axis "
                                   "watchdog timeout the host sets and reads back (0: not set)")
    endpoints: str = option("", file=True, description="0.6.x: flat_endpoints.json of the "
                            "firmware build (endpoint ids of the watchdog)")
    encoder_period: float = option(1e-3, unit="s", min=0.0, description="emulated drives: "
                                   "period of the cyclic encoder estimates (0: only when asked)")
    saved_watchdog: float = option(0.0, unit="s", min=0.0, description="emulated drives: the "
                                   "axis watchdog each arms from power-up, as saved with "
                                   "odrivetool (0: off, as from the factory)")


# command ids (both firmware lines)
HEARTBEAT, ESTOP, SET_AXIS_STATE, GET_ENCODER_ESTIMATES = 0x01, 0x02, 0x07, 0x09
SET_CONTROLLER_MODE, SET_INPUT_TORQUE, SET_LIMITS, CLEAR_ERRORS = 0x0B, 0x0E, 0x0F, 0x18
# arbitrary endpoint access (0.6.x only): RxSdo host -> drive, TxSdo drive -> host (read answers)
RX_SDO, TX_SDO = 0x04, 0x05
SDO_READ, SDO_WRITE = 0, 1
SDO_LINES = frozenset({"0.6"})
# the axis watchdog's endpoints (ids come from the firmware build's flat_endpoints.json)
WATCHDOG_TIMEOUT, ENABLE_WATCHDOG = "axis0.config.watchdog_timeout", "axis0.config.enable_watchdog"
# axis states and modes
AXIS_IDLE, AXIS_CLOSED_LOOP = 1, 8
CONTROL_TORQUE, INPUT_PASSTHROUGH = 1, 1

_F32 = struct.Struct("<f4x")  # the DBC gives these frames 8 bytes
_2F32 = struct.Struct("<ff")
_U32 = struct.Struct("<I4x")
_2U32 = struct.Struct("<II")
_HEARTBEAT = {"0.5": struct.Struct("<IBBBB"), "0.6": struct.Struct("<IBBBx")}
_SDO = struct.Struct("<BHB4s")  # opcode (reserved in TxSdo), endpoint id, reserved, value
_VALUE = {"float": "<f", "bool": "<?", "boolean": "<?", "uint8": "<B", "uint16": "<H",
          "uint32": "<I", "int32": "<i"}
DBC = {"0.5": "odrive-cansimple_v0.5.6.dbc", "0.6": "odrive-cansimple-0.6.10.dbc"}
EMULATED_ENDPOINTS = "odrive-endpoints-emulated.json"
# axis error bits that differ between the firmware lines (from the DBCs' value tables)
WATCHDOG_TIMER_EXPIRED = {"0.5": 0x800, "0.6": 0x1000000}
ESTOP_REQUESTED = {"0.5": 0x4000, "0.6": 0x2000000}
TWO_PI = 2.0 * math.pi


def can_id(node: int, cmd: int) -> int:
    """Arbitration id of command `cmd` for axis `node`."""
    return (node << 5) | cmd


def split_id(arbitration_id: int) -> tuple[int, int]:
    """(node, cmd) of an arbitration id."""
    return arbitration_id >> 5, arbitration_id & 0x1F


@dataclass(frozen=True)
class Heartbeat:
    """Axis error bits, axis state, and (0.6) procedure result."""

    axis_error: int
    axis_state: int
    extra: int = 0


def firmware_line(version: str) -> str:
    """'0.6.10' -> '0.6'; only 0.5 and 0.6 are known."""
    line = ".".join(str(version).split(".")[:2])
    if line not in DBC:
        raise ValueError(f"ODrive firmware {version!r} is not supported (use 0.5.x or 0.6.x)")
    return line


def has_sdo(version: str) -> bool:
    """Whether the firmware line's CAN Simple has RxSdo/TxSdo (0.6.x; 0.5.x has not)."""
    return firmware_line(version) in SDO_LINES


def emulated_endpoints() -> Path:
    """The emulated ODrive's endpoint table (ids of its own, in flat_endpoints.json form)."""
    return Path(str(resources.files("twmr.hw") / "data" / EMULATED_ENDPOINTS))


def load_endpoints(path: str | Path) -> dict[str, tuple[int, str]]:
    """name -> (endpoint id, type) of an ODrive `flat_endpoints.json` (the file ODrive publishes
    for each firmware build: {"endpoints": {"axis0.config.watchdog_timeout": {"id": ..,
    "type": "float"}, ...}}). ValueError when the file cannot be read or holds no endpoint
    table."""
    import json

    source = Path(path)
    try:
        table = json.loads(source.read_text(encoding="utf-8"))["endpoints"]
        return {str(k): (int(v["id"]), str(v["type"])) for k, v in table.items()}
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError) as err:
        raise ValueError(f"{source} is not an ODrive flat_endpoints.json ({type(err).__name__}: "
                         f"{err})") from None


def encode_sdo(node: int, opcode: int, endpoint: int, kind: str,
               value: float | bool = 0) -> tuple[int, bytes]:
    """RxSdo: read (`SDO_READ`) or write an endpoint of type `kind` ('float', 'bool', ...)."""
    raw = _pack_value(kind, value) if opcode == SDO_WRITE else bytes(4)
    return can_id(node, RX_SDO), _SDO.pack(opcode, endpoint, 0, raw)


def _pack_value(kind: str, value: float | bool) -> bytes:
    return struct.pack(_VALUE[kind], value).ljust(4, b"\0")


def wire_value(kind: str, value: float | bool) -> float | bool:
    """`value` as an endpoint of type `kind` holds it (float32 for 'float')."""
    return sdo_value(_pack_value(kind, value), kind)


def decode_sdo(data: bytes) -> tuple[int, int, bytes]:
    """(opcode, endpoint id, 4 value bytes) of an RxSdo or TxSdo payload."""
    opcode, endpoint, _, raw = _SDO.unpack_from(data)
    return opcode, endpoint, raw


def sdo_value(raw: bytes, kind: str) -> float | bool:
    """The value of an endpoint of type `kind` in the 4 value bytes of an SDO frame."""
    fmt = _VALUE[kind]
    return struct.unpack_from(fmt, raw)[0]


def encode_tx_sdo(node: int, endpoint: int, kind: str, value: float | bool) -> tuple[int, bytes]:
    """TxSdo: the drive's answer to a read."""
    return can_id(node, TX_SDO), _SDO.pack(0, endpoint, 0, _pack_value(kind, value))


def dbc_path(version: str) -> Path:
    """The DBC shipped for this firmware line."""
    return Path(str(resources.files("twmr.hw") / "data" / DBC[firmware_line(version)]))


def encode_torque(node: int, wheel_torque: float, gear: float) -> tuple[int, bytes]:
    """Set_Input_Torque: wheel torque [N.m] -> motor torque [N.m] = wheel / N."""
    return can_id(node, SET_INPUT_TORQUE), _F32.pack(wheel_torque / gear)


def decode_torque(data: bytes, gear: float) -> float:
    """Wheel torque [N.m] of a Set_Input_Torque payload."""
    return _F32.unpack_from(data)[0] * gear


def encode_axis_state(node: int, state: int) -> tuple[int, bytes]:
    """Set_Axis_State (IDLE 1, CLOSED_LOOP_CONTROL 8)."""
    return can_id(node, SET_AXIS_STATE), _U32.pack(state)


def encode_limits(node: int, wheel_speed_limit: float, current_limit: float,
                  gear: float) -> tuple[int, bytes]:
    """Set_Limits: wheel speed limit [rad/s] -> motor velocity limit [rev/s]; current limit [A]."""
    return can_id(node, SET_LIMITS), _2F32.pack(wheel_speed_limit * gear / TWO_PI, current_limit)


def decode_limits(data: bytes, gear: float) -> tuple[float, float]:
    """(wheel speed limit [rad/s], current limit [A]) of a Set_Limits payload."""
    vel, current = _2F32.unpack_from(data)
    return vel * TWO_PI / gear, current


def encode_clear_errors(node: int, version: str) -> tuple[int, bytes]:
    """Clear_Errors: no data on 0.5.x, one `Identify` byte (0) on 0.6.x."""
    return can_id(node, CLEAR_ERRORS), b"" if firmware_line(version) == "0.5" else b"\x00"


def encode_estop(node: int) -> tuple[int, bytes]:
    """Estop: the axis disarms to IDLE and latches ESTOP_REQUESTED."""
    return can_id(node, ESTOP), b""


def encode_controller_mode(node: int, control: int = CONTROL_TORQUE,
                           input_mode: int = INPUT_PASSTHROUGH) -> tuple[int, bytes]:
    return can_id(node, SET_CONTROLLER_MODE), _2U32.pack(control, input_mode)


def encode_encoder(node: int, wheel_angle: float, wheel_speed: float,
                   gear: float) -> tuple[int, bytes]:
    """Get_Encoder_Estimates from wheel angle [rad] and speed [rad/s] (motor rev, rev/s)."""
    return can_id(node, GET_ENCODER_ESTIMATES), _2F32.pack(wheel_angle * gear / TWO_PI,
                                                            wheel_speed * gear / TWO_PI)


def decode_encoder(data: bytes, gear: float) -> tuple[float, float]:
    """(wheel angle [rad], wheel speed [rad/s]) of a Get_Encoder_Estimates payload."""
    pos, vel = _2F32.unpack_from(data)
    return pos * TWO_PI / gear, vel * TWO_PI / gear


def encode_heartbeat(node: int, hb: Heartbeat, version: str) -> tuple[int, bytes]:
    """Heartbeat: 0.5.x carries motor/encoder/controller error flags after the state, 0.6.x the
    procedure result and the trajectory-done flag."""
    line = firmware_line(version)
    tail = (hb.extra, 0, 0) if line == "0.5" else (hb.extra, 0)
    return can_id(node, HEARTBEAT), _HEARTBEAT[line].pack(hb.axis_error, hb.axis_state, *tail)


def error_bit(name: str, version: str) -> int:
    """An axis error bit ('watchdog' | 'estop') for the firmware line."""
    table = {"watchdog": WATCHDOG_TIMER_EXPIRED, "estop": ESTOP_REQUESTED}[name]
    return table[firmware_line(version)]


@cache
def _axis_error_bits(line: str) -> dict[int, str]:
    """Bit -> name of the heartbeat's Axis_Error in the firmware line's DBC (its value table)."""
    import cantools

    db = cantools.database.load_file(str(dbc_path(line + ".0")))
    assert isinstance(db, cantools.database.can.Database)
    signal = db.get_message_by_frame_id(HEARTBEAT).get_signal_by_name("Axis_Error")
    return {int(k): str(v) for k, v in (signal.choices or {}).items() if int(k) > 0}


def axis_error_text(code: int, version: str) -> str:
    """An axis error as '0x1000000 (WATCHDOG_TIMER_EXPIRED)': the bits named by the firmware's
    DBC, any unnamed ones in hex."""
    try:
        bits = _axis_error_bits(firmware_line(version))
    except Exception:  # noqa: BLE001 - a name is a courtesy; the code is the fact
        bits = {}
    names = [name for bit, name in sorted(bits.items()) if code & bit]
    rest = code & ~sum(bit for bit in bits if code & bit)
    names += [f"0x{rest:x}"] if rest and names else []
    return f"0x{code:x}" + (f" ({' | '.join(names)})" if names else "")


#: what to do about an axis error bit (by its name in the firmware's DBC)
_AXIS_ERROR_FIX = {
    "WATCHDOG_TIMER_EXPIRED": "the drive heard no torque command within its axis watchdog "
    "(drive_watchdog, set by the host; or the one saved in the drive): the host fell behind "
    "(a loaded machine, a long first step) or frames were lost. Give the watchdog room "
    "(drive_watchdog: 0.5) or run on a quieter machine, then Clear_Errors",
    "ESTOP_REQUESTED": "an Estop frame reached the drive (the host sends one when a run stops "
    "on a fault; so may another node on the bus): find the first fault in the run's log, "
    "then Clear_Errors",
    "MISSING_INPUT": "the drive's input source (the CAN torque command) went missing: check "
    "that the host sends Set_Input_Torque each period and that no frame is lost",
    "DC_BUS_UNDER_VOLTAGE": "the supply voltage sagged: check the power supply and its cabling",
    "DC_BUS_OVER_VOLTAGE": "the supply voltage rose (braking energy with no brake resistor): "
    "check the brake resistor and its configuration",
}


def axis_error_fix(code: int, version: str) -> str:
    """The fix of an axis error: that of its first bit with a known cause, else reading the
    drive's errors (odrivetool's dump_errors) and Clear_Errors."""
    try:
        bits = _axis_error_bits(firmware_line(version))
    except Exception:  # noqa: BLE001 - the generic fix stands without names
        bits = {}
    for bit, name in sorted(bits.items()):
        if code & bit and name in _AXIS_ERROR_FIX:
            return _AXIS_ERROR_FIX[name]
    return "read the drive's errors (odrivetool: dump_errors), remove their cause, then " \
        "Clear_Errors"


def decode_heartbeat(data: bytes, version: str) -> Heartbeat:
    values = _HEARTBEAT[firmware_line(version)].unpack_from(data)
    return Heartbeat(values[0], values[1], values[2])


@cache
def check_layout(version: str, path: Path | None = None) -> None:
    """Raise ValueError when the DBC's layout of the frames used here differs from ours (each
    file is read once per process)."""
    import cantools

    db = cantools.database.load_file(str(path or dbc_path(version)))
    if not isinstance(db, cantools.database.can.Database):
        raise ValueError(f"{path or dbc_path(version)} is not a CAN database (DBC)")
    expect = {SET_INPUT_TORQUE: [(0, 32, True)], GET_ENCODER_ESTIMATES: [(0, 32, True),
                                                                       (32, 32, True)],
              SET_AXIS_STATE: [(0, 32, False)], SET_CONTROLLER_MODE: [(0, 32, False),
                                                                      (32, 32, False)],
              HEARTBEAT: [(0, 32, False), (32, 8, False)],
              SET_LIMITS: [(0, 32, True), (32, 32, True)]}
    line = firmware_line(version)
    clear = db.get_message_by_frame_id(CLEAR_ERRORS)
    if clear.length != len(encode_clear_errors(0, version)[1]):
        raise ValueError(f"{clear.name}: {clear.length} bytes in the DBC, "
                         f"{len(encode_clear_errors(0, version)[1])} sent here")
    for cmd, fields in expect.items():
        msg = db.get_message_by_frame_id(cmd)
        if msg.length != 8:
            raise ValueError(f"{msg.name}: {msg.length} bytes in the DBC, 8 expected")
        got = sorted((s.start, s.length, s.is_float) for s in msg.signals)
        for f in fields:
            if f not in got or msg.signals[0].byte_order != "little_endian":
                raise ValueError(f"{msg.name}: layout {got} in the DBC does not hold {f}")
    if line in SDO_LINES:
        expect_sdo = [(0, 8, False), (8, 16, False), (32, 32, False)]
        for cmd in (RX_SDO, TX_SDO):
            msg = db.get_message_by_frame_id(cmd)
            got = sorted((s.start, s.length, s.is_float) for s in msg.signals)
            if msg.length != 8 or any(f not in got for f in expect_sdo):
                raise ValueError(f"{msg.name}: layout {got} in the DBC is not the SDO layout")
    signal = db.get_message_by_frame_id(HEARTBEAT).get_signal_by_name("Axis_Error")
    choices: dict[Any, Any] = dict(signal.choices or {})
    names = {str(v): int(k) for k, v in choices.items()}
    for bit, table in (("WATCHDOG_TIMER_EXPIRED", WATCHDOG_TIMER_EXPIRED),
                       ("ESTOP_REQUESTED", ESTOP_REQUESTED)):
        if names.get(bit, table[line]) != table[line]:
            raise ValueError(f"{bit} is 0x{names[bit]:x} in the DBC, 0x{table[line]:x} here")
