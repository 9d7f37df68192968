"""The CAN bus of a drive block: python-can options from the scenario, and the frame log.

Options come either from `interface`/`channel`/`bitrate` (socketcan, pcan, kvaser, slcan,
virtual, ...) or from a python-can configuration file (`can_config`, INI, section `context`),
exactly as `can.Bus` reads them. Every frame sent and received is written to one log (python-can
ASC or BLF, by suffix) with its direction, so a run can be replayed (`twmr.hw.replay`).
"""
from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import can


def bus_options(interface: str, channel: str, bitrate: int, can_config: str = "",
                context: str = "default") -> dict[str, Any]:
    """Keyword arguments for `can.Bus`: from the python-can config file `can_config` (its
    section `context`) when given, else from interface/channel/bitrate."""
    if can_config:
        path = Path(can_config)
        if not path.is_file():
            raise FileNotFoundError(f"python-can configuration file {path} does not exist")
        options = dict(can.util.load_config(path=str(path), context=context))
        if not options.get("interface"):
            raise ValueError(f"{path} [{context}] names no interface")
        return options
    return {"interface": interface, "channel": channel, "bitrate": int(bitrate)}


def describe(options: dict[str, Any]) -> str:
    """'interface:channel' of bus options, for messages."""
    return f"{options.get('interface')}:{options.get('channel')}"


class FrameLog:
    """A python-can writer (`.asc` or `.blf`) shared by the sending thread and the bus's
    notifier thread; sent frames are stamped with the wall time and marked Tx."""

    def __init__(self, path: str | Path):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(path)
        self._writer = can.Logger(str(path))
        self._lock = threading.Lock()

    def received(self, msg: can.Message) -> None:
        with self._lock:
            self._writer.on_message_received(msg)

    def sent(self, msg: can.Message) -> None:
        msg.timestamp = time.time()
        msg.is_rx = False
        with self._lock:
            self._writer.on_message_received(msg)

    def close(self) -> None:
        with self._lock:
            self._writer.stop()
