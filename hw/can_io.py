"""`CanIo` (kind `can_io`): the messages of a CAN database (DBC, ARXML, KCD) as ports, on any bus.

`dbc:` names the file; `receive:` and `send:` the messages ('A, B', '*'), or `node:` the node
whose messages they are (what it sends, what it receives). Each signal of a received message is a
Real output `<message>.<signal>` (unit, range and enumeration from the file; the last value
received), and each message has `<message>.age` [s] (run time since a frame of it was last seen;
since the start before the first), `<message>.timed_out` (age above the message's timeout:
`timeout`, else three times the file's cycle time, else none) and `<message>.frames` (frames
seen). `stop_on_timeout: true` stops the run at the first timeout, naming the message. Each
signal of a sent message is an optional Real input (its initial value from the file when not
wired); frames go out `send_mode` `cyclic` (each message at the file's cycle time, or `period`,
else every step), `on_change`, `every_step` or `on_request` (only as the answer to a remote
frame; a remote frame is answered in every mode). A multiplexed message is sent as one frame per
multiplexer value each time; the signals named in `counters` count up by one per frame sent
(wrapping at their range) and are checked on frames received (jumps are reported). CAN FD
messages go out as FD frames with bit-rate switching.

The bus: `bus: <can_bus block>` (the simulated bus with its bit timing, beside drives and LS-BUS
FMUs), or a python-can bus of its own (`interface`/`channel`/`bitrate`, or `can_config`: virtual,
udp_multicast across processes, socketcan, a real adapter). When nothing on the wall clock joins
the bus block (no drive, no bus outside) the block steps the bus in run time: a frame sent at a
step goes on the wire in the bus block's next step and is taken by the receivers at their first
step after it ended there, the same in every run, with periods and jitter measured in run time.
Otherwise frames are taken from the bus by a python-can notifier thread stamped with the host's
clock; the interface's own timestamp (the kernel's or the adapter's for socketcan; run time on a
bus block in run time) is kept beside it in the frame log
(`<name>_frames.parquet`: run time, host time, interface time, direction, identifier, data,
message). `report()` gives, per message, frames sent and seen, the send period's measured
mean and jitter, timeouts, saturated values and counter jumps.
"""
from __future__ import annotations

import logging
import math
import queue
import time
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

from twmr.core import BOOLEAN, STRING, Component, HardwareError, Input, Output, Parameter
from twmr.core.run import RunContext
from twmr.hw.bus import BusMember, member_problems
from twmr.hw.dbc import STATUS, CanDatabase, DatabaseError, MessagePorts, status_collisions

log = logging.getLogger("twmr.hw")

SEND_MODES = ("cyclic", "on_change", "every_step", "on_request")
#: how long a send on a bus block waits for its frames to be on the wire and handed on [s]
HAND_WAIT = 0.05


class CanIo(Component, BusMember):
    """Messages of a CAN database as typed ports, received and sent on a CAN bus."""

    kind = "can_io"
    can_get_and_set_state = False  # what went over a bus cannot be taken back
    construction_parameters = ("dbc", "node", "receive", "send", "network", "counters",
                               "can_config")
    #: the direction `node:` picks when `receive`/`send` are not given
    node_sends = "send"

    dbc = Parameter("", type=STRING, description="CAN database: .dbc, .arxml, .kcd or .sym")
    node = Parameter("", type=STRING, description="the node of the file this block is: its "
                     "messages are sent, those it receives received (when receive/send are "
                     "not given)")
    receive = Parameter("", type=STRING, description="messages received: 'A, B' or '*'")
    send = Parameter("", type=STRING, description="messages sent: 'A, B' or '*'")
    send_mode = Parameter("cyclic", type=STRING, description="cyclic | on_change | every_step "
                          "| on_request")
    period = Parameter(0.0, unit="s", min=0.0, description="send period of cyclic messages "
                       "(0: the file's cycle time, else every step)")
    timeout = Parameter(0.0, unit="s", min=0.0, description="a received message is late after "
                        "this (0: 3 x its cycle time from the file, none without one)")
    stop_on_timeout = Parameter(False, type=BOOLEAN, description="stop the run at a timeout")
    network = Parameter("", type=STRING, description="the file's bus the messages are on "
                        "(KCD and ARXML files describe several; '' = every bus)")
    counters = Parameter("", type=STRING, description="rolling counter signals: 'Msg.Sig, ...'")
    log_file = Parameter("auto", type=STRING, description="frame log: 'auto' = "
                         "<results>/<name>_frames.parquet, '' = none")

    def __init__(self, name: str = "", **parameters: Any):
        construction = {k: parameters.pop(k) for k in self.construction_parameters
                        if k in parameters}
        super().__init__(name)
        for key, value in construction.items():
            self.set_parameter(key, value)
        self.database: CanDatabase | None = None
        self.rx: dict[tuple[int, bool], MessagePorts] = {}
        self.tx: dict[str, MessagePorts] = {}
        self._counters: dict[str, str] = {}  # message -> its counter signal
        self.problem = ""
        if self.dbc:
            self._ports()
        for key, value in parameters.items():
            self.set_parameter(key, value)

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> CanIo:
        """`dbc` and `can_config` resolve against the scenario's folder."""
        for key in ("dbc", "can_config"):
            value = str(construction.get(key, "") or "")
            if value and not Path(value).is_absolute():
                construction[key] = str(base_dir / value)
        return cls(name, **construction)

    @property
    def needs_realtime(self) -> bool:  # type: ignore[override]  # the bus decides
        """Its own python-can bus reaches the world; on a bus block, the bus decides."""
        return not self.bus

    # -- ports -----------------------------------------------------------------------------------
    def _ports(self) -> None:
        """Ports of the chosen messages; what is wrong goes to `problem` (check says it)."""
        try:
            db = self.database = CanDatabase.load(self.dbc)
            receive = db.messages(self.receive, self.node, "receive")
            send = db.messages(self.send, self.node, self.node_sends)
        except DatabaseError as err:
            self.problem = str(err)
            return
        if not receive and not send:
            self.problem = (f"{db.path}: no message is chosen (receive: '{self.receive}', "
                            f"send: '{self.send}', node: '{self.node}')")
            return
        if self.network:
            buses = sorted({str(m.bus_name) for m in db.db.messages if m.bus_name})
            if self.network not in buses:
                self.problem = (f"{db.path}: there is no bus '{self.network}' in the file "
                                f"(network: gives one of {', '.join(buses) or 'none named'})")
                return
            receive = [m for m in receive if m.bus_name == self.network]
            send = [m for m in send if m.bus_name == self.network]
        for chosen in (receive, send):
            seen: dict[tuple[int, bool], Any] = {}
            for m in chosen:
                key = (int(m.frame_id), bool(m.is_extended_frame))
                if key in seen:
                    other = seen[key]
                    self.problem = (
                        f"{db.path}: messages {other.name}{_on(other)} and {m.name}{_on(m)} "
                        f"have the same identifier 0x{key[0]:x}, so a frame cannot be told "
                        f"apart; choose one of them by name, or the file's bus with network:")
                    return
                seen[key] = m
        both = {m.name for m in receive} & {m.name for m in send}
        if both:
            self.problem = (f"{db.path}: message(s) {', '.join(sorted(both))} both received "
                            f"and sent by one block")
            return
        for message in receive:
            mp = MessagePorts.of(message)
            self.rx[mp.key] = mp
            for signal in message.signals:
                self._add(Output(unit=_unit(signal), description=mp.describe(signal)),
                              mp.ports[signal.name])
            self._add(Output(unit="s", description=f"run time since a frame of {mp.name} "
                             f"was seen"), f"{mp.name}.age")
            self._add(Output(type=BOOLEAN, description=f"{mp.name} is late"),
                      f"{mp.name}.timed_out")
            self._add(Output(type="Integer", description=f"frames of {mp.name} seen"),
                      f"{mp.name}.frames")
        for message in send:
            mp = MessagePorts.of(message)
            self.tx[mp.name] = mp
        self._counters = {}
        for text in (p.strip() for p in self.counters.replace(";", ",").split(",")):
            if not text:
                continue
            msg, _, sig = text.partition(".")
            known = self.tx.get(msg) or next((m for m in self.rx.values() if m.name == msg),
                                             None)
            if known is None or sig not in known.ports:
                self.problem = (f"{db.path}: counter '{text}' is no signal of a message this "
                                f"block sends or receives (give Message.Signal)")
                return
            self._counters[msg] = sig
        for mp in self.tx.values():
            for signal in mp.message.signals:
                if any(signal.name in m for m, _ in mp.pages) or \
                        self._counters.get(mp.name) == signal.name:
                    continue  # multiplexers and counters are the block's to set
                self._add(Input(start=mp.initial(signal), unit=_unit(signal), optional=True,
                                description=mp.describe(signal)), mp.ports[signal.name])
        clash = status_collisions(self.rx.values())
        if clash:
            self.problem = (f"{db.path}: signal port(s) {', '.join(clash)} take the name of a "
                            f"message's status port ({', '.join(STATUS)})")

    def _add(self, var: Any, name: str) -> None:
        var.name = name
        self.variables[name] = var
        self.__dict__[name] = var.start

    # -- checks --------------------------------------------------------------------------------
    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if not self.dbc:
            return [("dbc", "no CAN database is given.", "give dbc: <file>.dbc (or .arxml, "
                     ".kcd, .sym), relative to the scenario's folder.")]
        if self.problem:
            key = "counters" if "counter '" in self.problem else "dbc"
            if self.database is None:
                fix = "give a CAN database that cantools reads, its path relative to the " \
                      "scenario's folder (the text above says where the file is wrong)."
            else:
                names = self.database.names
                fix = (f"choose messages the file has with receive:, send: or node: ("
                       f"{', '.join(names[:10])}{', ...' if len(names) > 10 else ''}).")
            return [(key, self.problem + ".", fix)]
        problems: list[tuple[str, str, str]] = []
        if self.send_mode not in SEND_MODES:
            from twmr.registry import suggest

            problems.append(("send_mode", f"send_mode '{self.send_mode}' is unknown"
                             f"{suggest(self.send_mode, SEND_MODES)}.",
                             f"use one of: {', '.join(SEND_MODES)}."))
        problems += member_problems(self, given)
        log_path = Path(self.log_file)
        if self.log_file not in ("auto", "") and (log_path.is_absolute() or ".." in
                                                  log_path.parts or
                                                  log_path.suffix.lower() != ".parquet"):
            problems.append(("log_file", f"log_file '{self.log_file}' must be a .parquet file "
                             f"name inside the results folder.", "give a plain name such as "
                             "imu.parquet, 'auto' or ''."))
        return problems

    def check_peers(self, peers: Mapping[str, Component]) -> list[tuple[str, str, str]]:
        """`bus:` names a can_bus block, an FD one when a chosen message is CAN FD."""
        if not self.bus:
            return []
        from twmr.hw.canbus_block import bus_problem, joins

        what = bus_problem(self.name, self.bus, peers)
        if what:
            return [("bus", what + ".", "name a component of kind can_bus (bus: can0), or "
                     "leave bus: out to use interface/channel.")]
        fd = sorted(m.name for m in self._all() if m.fd)
        block = peers[joins(self.name, self.bus, peers)]
        if fd and not getattr(block, "fd", False):
            return [("bus", f"message(s) {', '.join(fd[:3])} are CAN FD and can_bus "
                     f"'{block.name}' is a classic bus.", f"set fd: true (and a data_bitrate) "
                     f"on '{block.name}'.")]
        return []

    def _all(self) -> list[MessagePorts]:
        return [*self.rx.values(), *self.tx.values()]

    # -- life cycle ----------------------------------------------------------------------------
    def prepare(self, run: RunContext) -> None:
        self._run = run
        self._folder = run.folder

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        import can

        self._t = start
        self._seen = {key: start for key in self.rx}
        self._stats: dict[str, dict[str, Any]] = {mp.name: {"sent": 0, "seen": 0,
                                                              "timeouts": 0, "jumps": 0,
                                                              "times": []}
                                                  for mp in self._all()}
        self._late: set[tuple[int, bool]] = set()
        self._next_send = {name: start for name in self.tx}
        self._last_sent: dict[str, tuple[float, ...]] = {}
        self._count = {name: 0 for name in self.tx}
        self._last_count: dict[tuple[int, bool], int] = {}
        self._rows: list[tuple[Any, ...]] = []
        #: the frame log is kept (a log file asked for, a run folder to write it in)
        self._logging = bool(self.log_file) and getattr(self, "_folder", None) is not None
        #: per message sent: (signal, port) of the signals that are inputs
        self._wired = {mp.name: tuple((s, p) for s, p in mp.ports.items() if p in self.variables)
                       for mp in self.tx.values()}
        self._inbox: queue.SimpleQueue[tuple[can.Message, float]] = queue.SimpleQueue()
        self.canbus: Any = None
        self._notifier: Any = None
        if self.problem:
            raise HardwareError(self.name, start, self.problem)
        try:
            options = self._options()
            self.canbus = can.Bus(**options, fd=any(m.fd for m in self._all()))
        except (OSError, ValueError, can.CanError) as err:
            fix = "name a can_bus block of this scenario in bus:" if self.bus else \
                "give an existing python-can config file or interface and channel"
            raise HardwareError(self.name, start, f"cannot open the CAN bus ({err}). Fix: "
                                f"{fix}.") from err
        #: on a bus block stepped in run time: frames are taken at each step, periods measured
        #: in run time
        self._stepped = bool(getattr(self.canbus, "in_run_time", False))
        if self._stepped:
            return
        inbox = self._inbox

        class Inbox(can.Listener):
            def on_message_received(self, msg: can.Message) -> None:
                inbox.put((msg, time.time()))

        self._notifier = can.Notifier(self.canbus, [Inbox()], timeout=0.05)

    def _options(self) -> dict[str, Any]:
        if self.bus:
            from twmr.hw.canbus_block import drive_options

            return drive_options(self.name, self.bus, getattr(self, "_run", None), self.name)
        from twmr.hw.bus import bus_options

        return bus_options(self.interface, self.channel, int(self.bitrate), self.can_config,
                           self.can_context)

    def initialize(self) -> None:
        for mp in self.rx.values():
            self.__dict__[f"{mp.name}.age"] = 0.0
            self.__dict__[f"{mp.name}.timed_out"] = False
            self.__dict__[f"{mp.name}.frames"] = 0

    def do_step(self, t: float, h: float) -> None:
        """Send what is due at `t` from the inputs, then take what the bus brought; the outputs
        hold at t + h."""
        self._t = t
        sent = self._send_due(t, h)
        if sent and self.bus:
            flush = getattr(self.canbus, "flush_sent", None)
            if flush is not None:
                flush(HAND_WAIT)
        self._take(t + h)

    def _due(self, mp: MessagePorts, t: float, h: float) -> bool:
        mode = self.send_mode
        if mode == "every_step":
            return True
        if mode == "on_request":
            return False
        if mode == "on_change":
            return self._values(mp) != self._last_sent.get(mp.name)
        period = self.period or mp.cycle
        if not period:
            return True
        if t + 0.5 * h < self._next_send[mp.name]:  # due at the step nearest its time
            return False
        self._next_send[mp.name] = max(self._next_send[mp.name] + period, t)
        return True

    def _values(self, mp: MessagePorts) -> tuple[float, ...]:
        d = self.__dict__
        return tuple(float(d.get(p, math.nan)) for _, p in self._wired[mp.name])

    def _send_due(self, t: float, h: float) -> int:
        n = 0
        for mp in self.tx.values():
            if self._due(mp, t, h):
                n += self._send(mp, t)
        return n

    def _send(self, mp: MessagePorts, t: float) -> int:
        import can

        d = self.__dict__
        values = {s: float(d[p]) for s, p in self._wired[mp.name]}
        counter = self._counters.get(mp.name)
        frames = 0
        for data in self._frames(mp, values, counter):
            msg = can.Message(arbitration_id=mp.key[0], is_extended_id=mp.key[1], data=data,
                              is_fd=mp.fd, bitrate_switch=mp.fd)
            try:
                self.canbus.send(msg, timeout=0.01)
            except can.CanError as err:
                raise HardwareError(self.name, t, f"sending {mp.name} failed: {err}. Fix: check "
                                    f"the bus (its state, its bitrate, CAN FD).") from err
            if self._logging:
                self._rows.append((t, time.time(), math.nan, "tx", mp.key[0], bytes(data).hex(),
                                   mp.name))
            frames += 1
        stats = self._stats[mp.name]
        stats["sent"] += frames
        stats["times"].append(t if self._stepped else time.perf_counter())
        self._last_sent[mp.name] = self._values(mp)
        return frames

    def _frames(self, mp: MessagePorts, values: dict[str, float], counter: str | None
                ) -> list[bytes]:
        if counter is None:
            return mp.encode(values)
        out = []
        for mux, signals in mp.pages:
            signal = mp.message.get_signal_by_name(counter)
            span = (1 << int(signal.length))
            values[counter] = float(self._count[mp.name] % span) * float(signal.scale or 1) + \
                float(signal.offset or 0)
            self._count[mp.name] += 1
            page = MessagePorts(mp.message, mp.ports, [(mux, signals)], _ranges=mp._ranges)
            out += page.encode(values)
            mp.saturated += page.saturated
        return out

    def _arrivals(self) -> Iterator[tuple[Any, float]]:
        """(frame, host time) of each frame the bus brought since the last step: from the bus
        itself when a bus block steps it in run time, else from the notifier's inbox."""
        while True:
            if self._stepped:
                msg = self.canbus.recv(timeout=0)
                if msg is None:
                    return
                yield msg, time.time()
                continue
            try:
                yield self._inbox.get_nowait()
            except queue.Empty:
                return

    def _take(self, now: float) -> None:
        """Decode every frame the bus brought since the last step; age and timeouts at `now`."""
        import can

        answered: set[str] = set()
        for msg, host in self._arrivals():
            if not isinstance(msg, can.Message) or msg.is_error_frame:
                continue
            key = (int(msg.arbitration_id), bool(msg.is_extended_id))
            if msg.is_remote_frame:
                asked = next((m for m in self.tx.values() if m.key == key), None)
                if asked is not None and asked.name not in answered:
                    answered.add(asked.name)
                    self._send(asked, self._t)
                continue
            mp = self.rx.get(key)
            if mp is None:
                continue
            try:
                decoded = mp.decode(bytes(msg.data))
            except Exception as err:  # noqa: BLE001 - cantools raises several kinds
                log.warning("%s: a frame of %s could not be decoded (%s)", self.name, mp.name,
                            err)
                continue
            for signal, value in decoded.items():
                self.__dict__[mp.ports[signal]] = value
            self._check_counter(mp, key, decoded)
            self._seen[key] = now
            stats = self._stats[mp.name]
            stats["seen"] += 1
            self.__dict__[f"{mp.name}.frames"] = stats["seen"]
            if self._logging:
                self._rows.append((now, host, float(msg.timestamp), "rx", key[0],
                                   bytes(msg.data).hex(), mp.name))
        for key, mp in self.rx.items():
            age = now - self._seen[key]
            self.__dict__[f"{mp.name}.age"] = age
            limit = self.timeout or 3.0 * mp.cycle
            late = bool(limit) and age > limit + 1e-9
            self.__dict__[f"{mp.name}.timed_out"] = late
            if late and key not in self._late:
                self._stats[mp.name]["timeouts"] += 1
                if self.stop_on_timeout:
                    raise HardwareError(self.name, now, f"message {mp.name} "
                                        f"(0x{key[0]:x}) timed out: none seen for {age:.4g} s "
                                        f"(timeout {limit:g} s). Fix: check that its sender "
                                        f"is on the bus and sending, or raise timeout.")
            (self._late.add if late else self._late.discard)(key)

    def _check_counter(self, mp: MessagePorts, key: tuple[int, bool],
                       decoded: dict[str, float]) -> None:
        counter = self._counters.get(mp.name)
        if counter is None or counter not in decoded:
            return
        signal = mp.message.get_signal_by_name(counter)
        raw = round((decoded[counter] - float(signal.offset or 0)) /
                        float(signal.scale or 1))
        last = self._last_count.get(key)
        if last is not None and raw != (last + 1) % (1 << int(signal.length)):
            self._stats[mp.name]["jumps"] += 1
        self._last_count[key] = raw

    def report(self) -> dict[str, Any]:
        """Per message: frames sent and seen, timeouts, saturated and non-finite values,
        counter jumps, and the measured send period (mean) and its jitter (standard deviation
        and largest deviation from the mean) [ms]."""
        out: dict[str, Any] = {}
        for mp in self._all():
            stats = getattr(self, "_stats", {}).get(mp.name)
            if stats is None:
                continue
            entry = {k: stats[k] for k in ("sent", "seen", "timeouts", "jumps") if stats[k]}
            if mp.saturated:
                entry["saturated"] = mp.saturated
            if mp.not_finite:
                entry["not_finite"] = mp.not_finite
            times = stats["times"]
            if len(times) > 2:
                import numpy as np

                gaps = np.diff(np.asarray(times)) * 1e3
                entry.update(period_ms=round(float(gaps.mean()), 4),
                             jitter_std_ms=round(float(gaps.std()), 4),
                             jitter_max_ms=round(float(np.abs(gaps - gaps.mean()).max()), 4))
            out[mp.name] = entry
        return out

    def terminate(self) -> None:
        notifier, self._notifier = getattr(self, "_notifier", None), None
        bus, self.canbus = getattr(self, "canbus", None), None
        try:
            if notifier is not None:
                notifier.stop(timeout=1.0)
        finally:
            if bus is not None:
                bus.shutdown()
            self._write_log()

    def _write_log(self) -> None:
        folder = getattr(self, "_folder", None)
        rows = getattr(self, "_rows", [])
        if not self.log_file or folder is None or not rows:
            return
        import pyarrow as pa
        import pyarrow.parquet as pq

        names = ("run_time", "host_time", "interface_time", "direction", "id", "data",
                 "message")
        table = pa.table({n: [r[i] for r in rows] for i, n in enumerate(names)})
        name = f"{self.name}_frames.parquet" if self.log_file == "auto" else self.log_file
        Path(folder).mkdir(parents=True, exist_ok=True)
        pq.write_table(table, Path(folder) / name)


def _on(message: Any) -> str:
    return f" (bus {message.bus_name})" if message.bus_name else ""


def _unit(signal: Any) -> str:
    from twmr.hw.dbc import port_unit

    return port_unit(signal.unit)


class CanDevice(CanIo):
    """A device emulated from its CAN database: `node:` names it; it sends the node's messages
    (values from its inputs: a scenario's signals, or a `kind: data` block playing a file) and
    receives, and answers remote frames of, what the file says the node does."""

    kind = "can_device"

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if self.dbc and not self.node:
            nodes = [n.name for n in self.database.db.nodes] if self.database else []
            return [("node", "a can_device is a node of its CAN database and none is named.",
                     f"give node: <one of {', '.join(nodes) or 'the nodes of the file'}>.")]
        return super().check(given)
