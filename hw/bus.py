"""The CAN bus of a drive block: python-can options from the scenario, and the frame log.

Options come either from `interface`/`channel`/`bitrate` (socketcan, pcan, kvaser, slcan,
virtual, ...) or from a python-can configuration file (`can_config`, INI, section `context`),
exactly as `can.Bus` reads them. Every frame sent and received is written to one log (python-can
ASC or BLF, by suffix) with its direction, so a run can be replayed (`twmr.hw.replay`).
"""
from __future__ import annotations

import contextlib
import copy
import threading
import time
from pathlib import Path
from typing import Any

import can

from twmr.core import STRING, Parameter

#: the python-can interface name of bus blocks (entry point group `can.interface`)
INTERFACE = "twmr"


def bus_options(interface: str, channel: str, bitrate: int, can_config: str = "",
                context: str = "default") -> dict[str, Any]:
    """Keyword arguments for `can.Bus`: from the python-can config file `can_config` (its
    section `context`) when given, else from interface/channel/bitrate."""
    if can_config:
        path = Path(can_config)
        if not path.is_file():
            raise FileNotFoundError(f"python-can configuration file {path} does not exist")
        import configparser

        try:
            options = dict(can.util.load_config(path=str(path), context=context))
        except (configparser.Error, UnicodeDecodeError):
            raise ValueError(f"{path} is not a python-can configuration file (INI with a "
                             f"[{context}] section)") from None
        if not options.get("interface"):
            raise ValueError(f"{path} [{context}] names no interface")
        wrong = interface_problem(str(options["interface"]))
        if wrong:
            raise ValueError(f"{path} [{context}]: {wrong}")
        return options
    wrong = interface_problem(interface)
    if wrong:
        raise ValueError(wrong)
    return {"interface": interface, "channel": channel, "bitrate": int(bitrate)}


def interface_problem(interface: str) -> str:
    """'' when python-can knows the interface name (`can.interfaces.VALID_INTERFACES`), else
    what is wrong, with the closest name."""
    from twmr.registry import suggest

    known = sorted(can.interfaces.VALID_INTERFACES)
    if interface in known:
        return ""
    return (f"python-can has no interface '{interface}'{suggest(interface, known)}; it knows "
            f"{', '.join(known)}")


class BusMember:
    """The parameters by which a CAN participant says where its frames go, and their check."""

    bus = Parameter("", type=STRING, description="a can_bus block of the scenario to join "
                    "(replaces interface/channel/can_config; '' = its own python-can bus)")
    interface = Parameter("virtual", type=STRING, description="python-can interface")
    channel = Parameter("twmr", type=STRING, description="python-can channel")
    bitrate = Parameter(1_000_000, type="Integer", description="bit/s")
    can_config = Parameter("", type=STRING, description="python-can config file (INI); replaces "
                           "interface/channel/bitrate when given")
    can_context = Parameter("default", type=STRING, description="section of can_config")


def member_problems(block: Any, given: frozenset[str]) -> list[tuple[str, str, str]]:
    """`bus:` beside its own python-can options, our bus blocks' interface named directly, and
    an unknown python-can interface."""
    own = sorted(given & {"interface", "channel", "can_config"})
    if block.bus and own:
        return [(own[0], f"bus: {block.bus} and {', '.join(own)} both say where the frames go.",
                 f"keep bus: {block.bus} (the bus block bridges any python-can bus with its "
                 f"own interface/channel), or drop bus:.")]
    if block.bus or block.can_config:
        return []
    if block.interface == INTERFACE:
        return [("interface", f"interface '{INTERFACE}' is how participants join a can_bus "
                 f"block.", "give bus: <the can_bus block's name> instead.")]
    wrong = interface_problem(block.interface)
    if wrong:
        return [("interface", wrong + ".", "give a python-can interface name (or can_config: "
                 "a python-can config file).")]
    return []


def describe(options: dict[str, Any]) -> str:
    """'interface:channel' of bus options, for messages."""
    return f"{options.get('interface')}:{options.get('channel')}"


class FrameLog:
    """A python-can writer (`.asc` or `.blf`) shared by the sending thread and the bus's
    notifier thread; sent frames are stamped with the wall time and marked Tx, and no frame
    keeps the bus's channel (the log is of one bus). Writing never raises into the bus threads:
    the first failure is kept in `error` and ends the log."""

    def __init__(self, path: str | Path):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(path)
        self._writer = can.Logger(str(path))
        if isinstance(self._writer, can.BLFWriter):
            # BLF stamps each frame after the file's start, which python-can takes from the
            # first frame written: a received frame stamped before it (the notifier's thread
            # is a little behind the sender's) would be read back at the start, to the ms.
            # The start is now, before any frame of the bus this log is of.
            # (a whole ms, as python-can writes it into the file's header and reads it back)
            self._writer.start_timestamp = (int(time.time() * 1000) - 1) / 1000
        self._lock = threading.Lock()
        self.error = ""

    def _write(self, msg: can.Message) -> None:
        with self._lock:
            if self.error:
                return
            try:
                self._writer.on_message_received(msg)
            except Exception as err:  # noqa: BLE001 - a log must never stop the drives' thread
                self.error = f"{type(err).__name__}: {err}"

    def received(self, msg: can.Message) -> None:
        # BLF packs a channel number into 16 bits: python-can makes a channel named by digits
        # an int, and BLF reads the trailing digits of a channel name as one
        if msg.channel is not None:
            msg = copy.copy(msg)
            msg.channel = None
        self._write(msg)

    def sent(self, msg: can.Message) -> None:
        msg.timestamp = time.time()
        msg.is_rx = False
        msg.channel = None
        self._write(msg)

    def close(self) -> None:
        with self._lock:
            try:
                self._writer.stop()
            except Exception as err:  # noqa: BLE001 - reported, never raised over the stop
                self.error = self.error or f"{type(err).__name__}: {err}"


class FrameGuard(can.Listener):
    """First listener of a notifier: remembers the frame being handled, so that when a later
    listener raises on it (a short or malformed frame), `on_error` hands the frame and the error
    to `report` and the notifier thread goes on instead of dying."""

    def __init__(self, report: Any):
        self.report = report
        self.frame: can.Message | None = None
        self.count = 0

    def on_message_received(self, msg: can.Message) -> None:
        self.frame = msg

    def on_error(self, exc: Exception) -> None:
        self.count += 1
        self.report(self.frame, exc)


def discard_unsent(bus: Any) -> None:
    """Discard the frames `bus` (a python-can bus) holds unsent, where its interface can
    (`flush_tx_buffer`; the others send what they hold first)."""
    if bus is None:
        return
    with contextlib.suppress(NotImplementedError, can.CanError, OSError):
        bus.flush_tx_buffer()


def frame_text(msg: can.Message | None) -> str:
    """'0x021 [1] 0a' for messages."""
    if msg is None:
        return "an unknown frame"
    return f"0x{msg.arbitration_id:03x} [{msg.dlc}] {bytes(msg.data).hex(' ') or '-'}"


def strict_canopen(network: Any, report: Any) -> FrameGuard:
    """Make a canopen network's decoding errors reach `report(frame, error)`: canopen's own
    listener logs and swallows them, so it is replaced by one that lets them through to a
    `FrameGuard` (the notifier thread goes on either way)."""
    import canopen.network

    class Strict(canopen.network.MessageListener):
        def on_message_received(self, msg: can.Message) -> None:
            if not (msg.is_error_frame or msg.is_remote_frame):
                self.network.notify(msg.arbitration_id, msg.data, msg.timestamp)

    listeners = network.notifier.listeners
    for i, listener in enumerate(listeners):
        if isinstance(listener, canopen.network.MessageListener):
            listeners[i] = Strict(network)

    def handled(frame: can.Message | None, exc: Exception) -> None:
        network.notifier.exception = None  # canopen re-raises it at its next send otherwise
        report(frame, exc)

    guard = FrameGuard(handled)
    listeners.insert(0, guard)
    return guard
