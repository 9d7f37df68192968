"""CAN bus operations of FMI-LS-BUS, encoded to and decoded from the bytes of a Binary variable.

A Tx_Data or Rx_Data variable of a CAN bus terminal holds zero or more operations back to back.
Every operation starts with an 8-byte header — operation code (uint32) and total length in bytes
including the header (uint32) — followed by its fields, packed, little-endian:

=====  ====================  ==========================================================
code   operation             fields after the header (bytes)
=====  ====================  ==========================================================
0x01   Format Error          data length (2), data
0x10   CAN Transmit          id (4), ide (1), rtr (1), data length (2), data (0..8)
0x11   CAN FD Transmit       id (4), ide (1), brs (1), esi (1), data length (2), data (0..64)
0x12   CAN XL Transmit       id (4), ide (1), sec (1), sdt (1), vcid (1), af (4), length (2), data
0x20   Confirm               id (4)
0x30   Arbitration Lost      id (4)
0x31   Bus Error             id (4), error code (1), error flag (1), is sender (1)
0x40   Configuration         parameter (1), then baud rate (4, bit/s) or behaviour (1)
0x41   Status                status (1)
0x42   Wakeup                —
=====  ====================  ==========================================================

A remote frame (rtr) carries its requested data length but no data bytes.

Use::

    from twmr.fmi.lsbus.operations import CanTransmit, Confirm, decode, encode
    raw = encode([CanTransmit(id=0x123, data=b"\\x01\\x02")])
    ops = decode(raw)            # [CanTransmit(id=291, data=b'\\x01\\x02', ...)]

`decode` raises `BusOperationError` (a `CosimError`) naming the byte offset and what is wrong;
whoever decodes bytes from a port adds the FMU, terminal and time to the message. `encode`
refuses a frame its bus cannot carry (more than 8 bytes classic, not a CAN FD length, more than
2048 bytes XL). `name(op)` is the standard's name of an operation, for messages and logs.
"""
from __future__ import annotations

import struct
from dataclasses import dataclass

from twmr.core.errors import CosimError

HEADER = struct.Struct("<II")
"""Operation code and total length (bytes, header included)."""

OP_FORMAT_ERROR = 0x01
OP_CAN_TRANSMIT = 0x10
OP_CANFD_TRANSMIT = 0x11
OP_CANXL_TRANSMIT = 0x12
OP_CONFIRM = 0x20
OP_ARBITRATION_LOST = 0x30
OP_BUS_ERROR = 0x31
OP_CONFIGURATION = 0x40
OP_STATUS = 0x41
OP_WAKEUP = 0x42

ERROR_BIT = 0x1
ERROR_BIT_STUFFING = 0x2
ERROR_FORM = 0x3
ERROR_CRC = 0x4
ERROR_ACK = 0x5
ERROR_BROKEN_ERROR_FRAME = 0x6
FLAG_PRIMARY = 0x1
FLAG_SECONDARY = 0x2

CONFIG_CAN_BAUDRATE = 0x1
CONFIG_CANFD_BAUDRATE = 0x2
CONFIG_CANXL_BAUDRATE = 0x3
CONFIG_ARBITRATION_LOST_BEHAVIOR = 0x4
BUFFER_AND_RETRANSMIT = 0x1
DISCARD_AND_NOTIFY = 0x2

STATUS_ERROR_ACTIVE = 0x1
STATUS_ERROR_PASSIVE = 0x2
STATUS_BUS_OFF = 0x3

CAN_MAX_DATA = 8
CANFD_DATA_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
CANXL_MAX_DATA = 2048


class BusOperationError(CosimError):
    """Bytes that are not a valid sequence of bus operations."""


@dataclass(frozen=True)
class FormatError:
    """A receiver's report that it could not decode `data` (the offending bytes)."""

    data: bytes = b""


@dataclass(frozen=True)
class CanTransmit:
    """A classic CAN frame: identifier, payload (0..8 bytes), extended id, remote request.

    For a remote frame (`rtr`), `dlc` is the requested length and `data` stays empty."""

    id: int
    data: bytes = b""
    ide: bool = False
    rtr: bool = False
    dlc: int | None = None

    @property
    def data_length(self) -> int:
        """The frame's data length field (bytes)."""
        return self.dlc if self.dlc is not None else len(self.data)


@dataclass(frozen=True)
class CanFdTransmit:
    """A CAN FD frame: payload of a valid FD length (0..8, 12, 16, 20, 24, 32, 48, 64 bytes)."""

    id: int
    data: bytes = b""
    ide: bool = False
    brs: bool = False
    esi: bool = False


@dataclass(frozen=True)
class CanXlTransmit:
    """A CAN XL frame (payload up to 2048 bytes)."""

    id: int
    data: bytes = b""
    ide: bool = False
    sec: int = 0
    sdt: int = 0
    vcid: int = 0
    af: int = 0


@dataclass(frozen=True)
class Confirm:
    """The bus acknowledged the sender's frame `id`."""

    id: int


@dataclass(frozen=True)
class ArbitrationLost:
    """The sender's frame `id` lost arbitration and was discarded."""

    id: int


@dataclass(frozen=True)
class BusError:
    """A bus error while frame `id` was on the bus (`ERROR_*` code, `FLAG_*` flag)."""

    id: int
    error_code: int
    error_flag: int = FLAG_PRIMARY
    is_sender: bool = False


@dataclass(frozen=True)
class Configuration:
    """One bus setting: `parameter` is a `CONFIG_*` code, `value` a baud rate (bit/s) or the
    arbitration-lost behaviour (`BUFFER_AND_RETRANSMIT` or `DISCARD_AND_NOTIFY`)."""

    parameter: int
    value: int


@dataclass(frozen=True)
class Status:
    """A node's error state (`STATUS_*`)."""

    status: int


@dataclass(frozen=True)
class Wakeup:
    """A bus wake-up."""


Operation = (FormatError | CanTransmit | CanFdTransmit | CanXlTransmit | Confirm |
             ArbitrationLost | BusError | Configuration | Status | Wakeup)

_ID = struct.Struct("<I")
_TRANSMIT = struct.Struct("<IBBH")
_FD = struct.Struct("<IBBBH")
_XL = struct.Struct("<IBBBBIH")
_BUS_ERROR = struct.Struct("<IBBB")
NAMES = {OP_FORMAT_ERROR: "Format Error", OP_CAN_TRANSMIT: "CAN Transmit",
         OP_CANFD_TRANSMIT: "CAN FD Transmit", OP_CANXL_TRANSMIT: "CAN XL Transmit",
         OP_CONFIRM: "Confirm", OP_ARBITRATION_LOST: "Arbitration Lost",
         OP_BUS_ERROR: "Bus Error", OP_CONFIGURATION: "Configuration", OP_STATUS: "Status",
         OP_WAKEUP: "Wakeup"}


def _check_data(op: Operation) -> None:
    if isinstance(op, CanTransmit):
        if op.data_length > CAN_MAX_DATA or (not op.rtr and op.dlc not in (None, len(op.data))):
            raise BusOperationError(
                f"CAN Transmit id 0x{op.id:x}: {op.data_length} data bytes, a classic CAN frame "
                f"carries at most {CAN_MAX_DATA}; use CanFdTransmit for longer payloads")
        if op.rtr and op.data:
            raise BusOperationError(f"CAN Transmit id 0x{op.id:x}: a remote frame (rtr) carries no "
                                    "data; give its requested length as dlc")
    elif isinstance(op, CanFdTransmit) and len(op.data) not in CANFD_DATA_LENGTHS:
        raise BusOperationError(
            f"CAN FD Transmit id 0x{op.id:x}: {len(op.data)} data bytes is not a CAN FD length "
            f"(one of {', '.join(map(str, CANFD_DATA_LENGTHS))})")
    elif isinstance(op, CanXlTransmit) and not 1 <= len(op.data) <= CANXL_MAX_DATA:
        raise BusOperationError(f"CAN XL Transmit id 0x{op.id:x}: {len(op.data)} data bytes, "
                                f"a CAN XL frame carries 1 to {CANXL_MAX_DATA}")


def _body(op: Operation) -> tuple[int, bytes]:
    if isinstance(op, CanTransmit):
        return OP_CAN_TRANSMIT, _TRANSMIT.pack(op.id, op.ide, op.rtr, op.data_length) + op.data
    if isinstance(op, CanFdTransmit):
        return OP_CANFD_TRANSMIT, _FD.pack(op.id, op.ide, op.brs, op.esi, len(op.data)) + op.data
    if isinstance(op, CanXlTransmit):
        return OP_CANXL_TRANSMIT, _XL.pack(op.id, op.ide, op.sec, op.sdt, op.vcid, op.af,
                                           len(op.data)) + op.data
    if isinstance(op, Confirm):
        return OP_CONFIRM, _ID.pack(op.id)
    if isinstance(op, ArbitrationLost):
        return OP_ARBITRATION_LOST, _ID.pack(op.id)
    if isinstance(op, BusError):
        return OP_BUS_ERROR, _BUS_ERROR.pack(op.id, op.error_code, op.error_flag, op.is_sender)
    if isinstance(op, Configuration):
        if op.parameter == CONFIG_ARBITRATION_LOST_BEHAVIOR:
            return OP_CONFIGURATION, struct.pack("<BB", op.parameter, op.value)
        return OP_CONFIGURATION, struct.pack("<BI", op.parameter, op.value)
    if isinstance(op, Status):
        return OP_STATUS, struct.pack("<B", op.status)
    if isinstance(op, Wakeup):
        return OP_WAKEUP, b""
    if isinstance(op, FormatError):
        return OP_FORMAT_ERROR, struct.pack("<H", len(op.data)) + op.data
    raise TypeError(f"not a bus operation: {op!r}")


def encode(ops: list[Operation] | tuple[Operation, ...]) -> bytes:
    """The bytes of `ops`, back to back, as a Tx_Data or Rx_Data variable carries them."""
    out = bytearray()
    for op in ops:
        _check_data(op)
        code, body = _body(op)
        out += HEADER.pack(code, HEADER.size + len(body)) + body
    return bytes(out)


def _fixed(code: int, body: bytes, at: int, size: int) -> None:
    if len(body) != size:
        raise BusOperationError(
            f"bus operation 0x{code:02x} ({NAMES[code]}) at byte {at}: length "
            f"{HEADER.size + len(body)}, expected {HEADER.size + size}")


def _variable(code: int, body: bytes, at: int, fixed: int, n: int) -> bytes:
    if len(body) != fixed + n:
        raise BusOperationError(
            f"bus operation 0x{code:02x} ({NAMES[code]}) at byte {at}: length "
            f"{HEADER.size + len(body)} does not match its data length {n} "
            f"(expected {HEADER.size + fixed + n})")
    return body[fixed:]


def _parse(code: int, body: bytes, at: int) -> Operation:
    if code == OP_CAN_TRANSMIT:
        if len(body) < _TRANSMIT.size:
            _fixed(code, body, at, _TRANSMIT.size)
        ident, ide, rtr, n = _TRANSMIT.unpack_from(body)
        if rtr:
            _fixed(code, body, at, _TRANSMIT.size)
            op: Operation = CanTransmit(ident, b"", bool(ide), True, n)
        else:
            op = CanTransmit(ident, _variable(code, body, at, _TRANSMIT.size, n), bool(ide))
    elif code == OP_CANFD_TRANSMIT:
        if len(body) < _FD.size:
            _fixed(code, body, at, _FD.size)
        ident, ide, brs, esi, n = _FD.unpack_from(body)
        op = CanFdTransmit(ident, _variable(code, body, at, _FD.size, n), bool(ide), bool(brs),
                           bool(esi))
    elif code == OP_CANXL_TRANSMIT:
        if len(body) < _XL.size:
            _fixed(code, body, at, _XL.size)
        ident, ide, sec, sdt, vcid, af, n = _XL.unpack_from(body)
        op = CanXlTransmit(ident, _variable(code, body, at, _XL.size, n), bool(ide), sec, sdt,
                           vcid, af)
    elif code in (OP_CONFIRM, OP_ARBITRATION_LOST):
        _fixed(code, body, at, _ID.size)
        (ident,) = _ID.unpack(body)
        op = Confirm(ident) if code == OP_CONFIRM else ArbitrationLost(ident)
    elif code == OP_BUS_ERROR:
        _fixed(code, body, at, _BUS_ERROR.size)
        ident, error_code, flag, sender = _BUS_ERROR.unpack(body)
        op = BusError(ident, error_code, flag, bool(sender))
    elif code == OP_CONFIGURATION:
        if not body:
            _fixed(code, body, at, 5)
        parameter = body[0]
        if parameter == CONFIG_ARBITRATION_LOST_BEHAVIOR:
            _fixed(code, body, at, 2)
            op = Configuration(parameter, body[1])
        elif parameter in (CONFIG_CAN_BAUDRATE, CONFIG_CANFD_BAUDRATE, CONFIG_CANXL_BAUDRATE):
            _fixed(code, body, at, 5)
            op = Configuration(parameter, _ID.unpack_from(body, 1)[0])
        else:
            raise BusOperationError(f"bus operation 0x40 (Configuration) at byte {at}: unknown "
                                    f"parameter type 0x{parameter:02x} (known: 0x01 to 0x04)")
    elif code == OP_STATUS:
        _fixed(code, body, at, 1)
        op = Status(body[0])
    elif code == OP_WAKEUP:
        _fixed(code, body, at, 0)
        op = Wakeup()
    else:
        if len(body) < 2:
            _fixed(code, body, at, 2)
        op = FormatError(_variable(code, body, at, 2, struct.unpack_from("<H", body)[0]))
    _check_data(op)
    return op


def decode(raw: bytes) -> list[Operation]:
    """The operations in `raw` (the bytes of a Tx_Data/Rx_Data variable), in order.

    Raises `BusOperationError` for a truncated header, a length that overruns the buffer or does
    not match the operation, an unknown operation code or a payload too long for its frame."""
    ops: list[Operation] = []
    at = 0
    view = bytes(raw)
    while at < len(view):
        if len(view) - at < HEADER.size:
            raise BusOperationError(f"bus operation at byte {at}: {len(view) - at} bytes left, "
                                    f"shorter than the {HEADER.size}-byte operation header")
        code, length = HEADER.unpack_from(view, at)
        if code not in NAMES:
            raise BusOperationError(
                f"bus operation at byte {at}: unknown operation code 0x{code:02x} (CAN knows "
                f"{', '.join(f'0x{c:02x}' for c in NAMES)})")
        if length < HEADER.size:
            raise BusOperationError(
                f"bus operation 0x{code:02x} ({NAMES[code]}) at byte {at}: length {length} is "
                f"shorter than the {HEADER.size}-byte header")
        if at + length > len(view):
            raise BusOperationError(
                f"bus operation 0x{code:02x} ({NAMES[code]}) at byte {at}: length {length} runs "
                f"past the end of the {len(view)}-byte buffer")
        ops.append(_parse(code, view[at + HEADER.size:at + length], at))
        at += length
    return ops


def name(op: Operation) -> str:
    """The standard's name of an operation (e.g. 'CAN Transmit')."""
    return NAMES[_body(op)[0]]
