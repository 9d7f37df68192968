"""`LsBusNode`: an FMI-LS-BUS CAN terminal of another component (an FMU) as a participant of a
bus block, and the translation between LS-BUS operations and the bus's frames and events.

What the node writes (its Tx_Data at each tick of its Tx_Clock): `CanTransmit` and
`CanFdTransmit` become frames handed to the bus at the tick's time; `Configuration` sets the bus
(bit rates, checked against the block's) or the node's arbitration-lost behaviour; `Status` and
`Wakeup` change nothing. What the bus tells it (its Rx_Data, with a tick of its Rx_Clock):
`transmit` of the others' frames -> `CanTransmit`/`CanFdTransmit`, `confirm` -> `Confirm`,
`bus_error` -> `BusError` (ACK error when no one acknowledged, form error when the bus refused
the frame), `arbitration_lost` -> `ArbitrationLost` only when the node configured
DISCARD_AND_NOTIFY (with BUFFER_AND_RETRANSMIT, the default, the bus sends the frame again).
"""
from __future__ import annotations

from collections import deque

import can

from twmr.fmi.lsbus import operations as ops
from twmr.hw.cansim import BusEvent


class LsBusNode:
    """Terminal `name` of a bus block, behind which `peer`'s bus terminal `terminal` is; events
    the bus delivers wait in `inbox` until the block's next communication point."""

    def __init__(self, name: str, peer: str, terminal: str, limit: int | None = None):
        self.name, self.peer, self.terminal = name, peer, terminal
        self.limit = limit  # the most bytes its Rx_Data takes at once (its maxSize)
        self.inbox: deque[BusEvent] = deque()
        self.discard = False  # DISCARD_AND_NOTIFY configured

    def deliver(self, event: BusEvent) -> None:
        self.inbox.append(event)

    def received(self) -> bytes:
        """The operations for the node's Rx_Data, encoded: the events delivered since the last
        call, as many as `limit` bytes hold (the others wait for the next call)."""
        out = bytearray()
        while self.inbox:
            op = operation_of(self.inbox[0], self.discard)
            raw = ops.encode([op]) if op is not None else b""
            if self.limit is not None and out and len(out) + len(raw) > self.limit:
                break
            self.inbox.popleft()
            out += raw
        return bytes(out)


def frame_of(op: ops.CanTransmit | ops.CanFdTransmit) -> can.Message:
    """The CAN frame of a transmit operation."""
    if isinstance(op, ops.CanFdTransmit):
        return can.Message(arbitration_id=op.id, is_extended_id=op.ide, is_fd=True,
                           bitrate_switch=op.brs, error_state_indicator=op.esi,
                           dlc=len(op.data), data=op.data, check=False)
    return can.Message(arbitration_id=op.id, is_extended_id=op.ide, is_remote_frame=op.rtr,
                       dlc=op.data_length, data=b"" if op.rtr else op.data, check=False)


def operation_of(event: BusEvent, discard: bool) -> ops.Operation | None:
    """The operation that tells a node of `event` (None: LS-BUS tells it nothing)."""
    frame = event.frame
    if event.kind == "transmit":
        data = bytes(frame.data or b"")
        if frame.is_fd:
            return ops.CanFdTransmit(frame.arbitration_id, data, bool(frame.is_extended_id),
                                     bool(frame.bitrate_switch),
                                     bool(frame.error_state_indicator))
        return ops.CanTransmit(frame.arbitration_id, b"" if frame.is_remote_frame else data,
                               bool(frame.is_extended_id), bool(frame.is_remote_frame),
                               int(frame.dlc) if frame.is_remote_frame else None)
    if event.kind == "confirm":
        return ops.Confirm(frame.arbitration_id)
    if event.kind == "arbitration_lost":
        return ops.ArbitrationLost(frame.arbitration_id) if discard else None
    if event.kind == "bus_error":
        code = ops.ERROR_ACK if event.detail.startswith("ACK error") else ops.ERROR_FORM
        return ops.BusError(frame.arbitration_id, code, ops.FLAG_PRIMARY, True)
    return None
