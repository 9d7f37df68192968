"""Frame logs of a run (python-can BLF/ASC, written by `bus.FrameLog`) read back: each frame
decoded to SI values per drive node, or played onto a bus with its original timing.

ODrive frames decode with the CAN Simple layouts of `protocol`; CiA 402 frames with the PDO
mapping `cia402_link` configures (RPDO1 0x200+n: controlword, target torque; TPDO1 0x180+n:
statusword, velocity; TPDO2 0x280+n: position), SYNC, EMCY and heartbeats.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can

from twmr.hw import cia402 as c
from twmr.hw import protocol as p


@dataclass(frozen=True)
class Decoded:
    """One signal of one frame: time [s, log clock], 'Tx'/'Rx', node (None: bus-wide), value."""

    time: float
    direction: str
    node: int | None
    signal: str
    value: float


@dataclass(frozen=True)
class Decoder:
    """How to read the frames of a run: protocol, ODrive firmware, gear, CiA 402 scaling."""

    protocol: str = "odrive"
    firmware: str = "0.6.10"
    gear: float = 1.0
    rated_torque: int = 1000  # CiA 402 0x6076 [mN.m]
    increments_per_rev: int = 4096

    def __call__(self, msg: can.Message) -> list[tuple[int | None, str, float]]:
        """(node, signal, value) of what `msg` carries; [] for frames it does not know."""
        if msg.is_error_frame:
            return [(None, "error_frame", 1.0)]
        if self.protocol == "odrive":
            return self._odrive(msg)
        return self._cia402(msg)

    def _odrive(self, msg: can.Message) -> list[tuple[int | None, str, float]]:
        node, cmd = p.split_id(msg.arbitration_id)
        data = bytes(msg.data)
        if msg.is_remote_frame:
            return [(node, f"request_0x{cmd:02x}", 1.0)]
        if cmd == p.SET_INPUT_TORQUE:
            return [(node, "torque_command", p.decode_torque(data, self.gear))]
        if cmd == p.GET_ENCODER_ESTIMATES:
            angle, speed = p.decode_encoder(data, self.gear)
            return [(node, "angle", angle), (node, "speed", speed)]
        if cmd == p.HEARTBEAT:
            beat = p.decode_heartbeat(data, self.firmware)
            return [(node, "axis_error", beat.axis_error), (node, "axis_state", beat.axis_state)]
        if cmd == p.SET_AXIS_STATE:
            return [(node, "requested_state", int.from_bytes(data[:4], "little"))]
        if cmd == p.SET_LIMITS:
            speed, current = p.decode_limits(data, self.gear)
            return [(node, "speed_limit", speed), (node, "current_limit", current)]
        names = {p.ESTOP: "estop", p.CLEAR_ERRORS: "clear_errors",
                 p.SET_CONTROLLER_MODE: "controller_mode"}
        return [(node, names[cmd], 1.0)] if cmd in names else []

    def _cia402(self, msg: can.Message) -> list[tuple[int | None, str, float]]:
        ident, data = msg.arbitration_id, bytes(msg.data)
        base, node = ident & 0x780, ident & 0x7F
        if ident == 0x080:
            return [(None, "sync", 1.0)]
        if base == 0x200 and len(data) >= 4:
            word, permille = struct.unpack_from("<Hh", data)
            return [(node, "controlword", word), (node, "torque_command",
                    c.permille_to_torque(permille, self.gear, self.rated_torque))]
        if base == 0x180 and len(data) >= 6:
            word, rpm = struct.unpack_from("<Hi", data)
            return [(node, "statusword", word), (node, "speed", c.velocity_to_si(rpm, self.gear))]
        if base == 0x280 and len(data) >= 4:
            (inc,) = struct.unpack_from("<i", data)
            return [(node, "angle", c.position_to_si(inc, self.gear, self.increments_per_rev))]
        if base == 0x080 and node and len(data) >= 2:
            return [(node, "emcy", int.from_bytes(data[:2], "little"))]
        if base == 0x700 and data:
            return [(node, "heartbeat", data[0])]
        return []


def decode_frames(frames: Iterable[can.Message], decoder: Decoder) -> Iterator[Decoded]:
    """Every known signal of `frames`, in order."""
    for msg in frames:
        direction = "Rx" if msg.is_rx else "Tx"
        for node, signal, value in decoder(msg):
            yield Decoded(msg.timestamp, direction, node, signal, float(value))


def decode_log(path: str | Path, decoder: Decoder) -> list[Decoded]:
    """The decoded signals of a BLF/ASC frame log."""
    return list(decode_frames(can.LogReader(str(path)), decoder))


def play(path: str | Path, options: dict[str, Any], paced: bool = True) -> int:
    """Send every frame of the log onto the bus `options` (with the log's timing when `paced`);
    the number of frames sent."""
    frames: Iterable[can.Message] = can.LogReader(str(path))
    if paced:
        frames = can.MessageSync(frames, gap=0.0, skip=60.0)
    count = 0
    with can.Bus(**options) as bus:
        for msg in frames:
            if not msg.is_error_frame:
                bus.send(msg)
                count += 1
    return count
