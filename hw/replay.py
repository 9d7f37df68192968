"""Frame logs of a run (python-can BLF/ASC, written by `bus.FrameLog`) read back: each frame
decoded to SI values per drive node by the protocol's own `Link.decode` (found in the
`twmr.can_protocols` registry), or played onto a bus with its original timing. A frame its
protocol cannot decode (too short for its identifier) is skipped and counted, never the end of
the log.
"""
from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import can

from twmr.hw.bus import frame_text
from twmr.hw.link import DriveSpec, Link, Signals, protocol


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
    """How to read the frames of a run: protocol, gear, and the protocol's own options
    (name, value) it decodes with (ODrive: firmware; CiA 402: rated_torque,
    increments_per_rev)."""

    protocol: str = "odrive"
    gear: float = 1.0
    options: tuple[tuple[str, Any], ...] = ()

    @cached_property
    def _link(self) -> type[Link]:
        return protocol(self.protocol)

    @cached_property
    def _spec(self) -> DriveSpec:
        return DriveSpec.of(self._link, None, gear=self.gear, **dict(self.options))

    def problems(self) -> list[tuple[str, str, str]]:
        """What is wrong with the decoding parameters (parameter, what, fix)."""
        found = [] if self.gear > 0 else [("gear", f"gear {self.gear:g} is not positive.",
                                           "give the motor turns per wheel turn (> 0).")]
        return found + self._link.check(self._spec)

    def __call__(self, msg: can.Message) -> Signals:
        """(node, signal, value) of what `msg` carries; [] for frames it does not know."""
        if msg.is_error_frame:
            return [(None, "error_frame", 1.0)]
        return self._link.decode(msg, self._spec)


def decode_frames(frames: Iterable[can.Message], decoder: Decoder,
                  bad: list[str] | None = None) -> Iterator[Decoded]:
    """Every known signal of `frames`, in order; a frame that cannot be decoded is skipped and
    described in `bad` when given."""
    for msg in frames:
        direction = "Rx" if msg.is_rx else "Tx"
        try:
            signals = decoder(msg)
        except (ValueError, struct.error, IndexError):
            if bad is not None:
                bad.append(f"{frame_text(msg)} at {msg.timestamp:.6f} s")
            continue
        for node, signal, value in signals:
            yield Decoded(msg.timestamp, direction, node, signal, float(value))


def decode_log(path: str | Path, decoder: Decoder, bad: list[str] | None = None
               ) -> list[Decoded]:
    """The decoded signals of a BLF/ASC frame log (frames that cannot be decoded: in `bad`)."""
    return list(decode_frames(can.LogReader(str(path)), decoder, bad))


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
