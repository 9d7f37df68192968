"""The bus of a run: one `CanBusModel` (`twmr.hw.cansim`) in real time, its participants, and its
frame log.

A `BusRunner` keeps the model on the monotonic clock: participants submit frames (stamped with
the time they were handed over), a thread (`can-bus <name>`) wakes at each event the model
computes and hands it to the participants, each through its `deliver` (never blocking; a failure
is counted and reported, never the end of the thread). Participants implement `Participant`:
python-can buses of our own interface `twmr` (`BlockBus`: how drive links, emulated drives and
canopen join), a `Gateway` to a python-can bus outside (virtual, udp_multicast, socketcan, ...),
and FMI-LS-BUS terminals of FMUs (`twmr.hw.lsbus_node.LsBusNode`). `BusCore` is what this runner
shares with the bus its block steps in run time (`twmr.hw.steppedbus.SteppedBus`). Runners are
found by channel (`runner(channel)`), a name unique to the run and the bus block, so
`can.Bus(interface="twmr", channel=...)` joins one.

The runner outlives its block's `terminate()` until the last participant has left (a drive's
terminate sends zero torque and disable through it, whatever the order of the stops), then
writes the log and stops its thread.
"""
from __future__ import annotations

import contextlib
import math
import queue
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from pathlib import Path
from typing import Any, ClassVar, Protocol

import can

from twmr.hw.bus import INTERFACE, frame_text
from twmr.hw.cansim import BusEvent, CanBusModel

_RUNNERS: dict[str, BusCore] = {}
_RUNNERS_LOCK = threading.Lock()


class Participant(Protocol):
    """A member of a bus: `deliver` is called from the bus thread with every `transmit` of the
    others and with its own frames' `confirm`, `arbitration_lost` and `bus_error`; it must
    return at once (queue the event)."""

    name: str

    def deliver(self, event: BusEvent) -> None: ...


def runner(channel: str) -> BusCore | None:
    """The running bus of `channel`, if any."""
    with _RUNNERS_LOCK:
        return _RUNNERS.get(channel)


def register(channel: str, bus: BusCore) -> None:
    """`bus` is reached as `channel` (by `runner` and python-can's interface `twmr`)."""
    with _RUNNERS_LOCK:
        _RUNNERS[channel] = bus


def unregister(channel: str, bus: BusCore) -> None:
    """`channel` no longer reaches `bus`."""
    with _RUNNERS_LOCK:
        if _RUNNERS.get(channel) is bus:
            del _RUNNERS[channel]


class BusCore:
    """What every bus of a block keeps: `model`, its participants, the events recorded for the
    log, the counts and the first bus errors. Bus time is run time minus `offset`. What a
    participant of interface `twmr` (`BlockBus`) calls: `join`, `leave`, `submit`, `handed`;
    `in_run_time`: whether bus time is run time (the block steps it) or the monotonic clock."""

    in_run_time: ClassVar[bool] = False

    def join(self, member: Participant, keeps_open: bool = True) -> str:
        raise NotImplementedError

    def leave(self, name: str, flush: float = 0.5) -> None:
        raise NotImplementedError

    def submit(self, sender: str, frame: can.Message, at: float | None = None) -> str:
        raise NotImplementedError

    def handed(self, name: str, timeout: float) -> bool:
        raise NotImplementedError

    def bus_time(self) -> float:
        """The bus's present time [s of bus time]."""
        raise NotImplementedError

    def discard(self, name: str) -> int:
        """Forget the frames `name` queued and not yet on the wire (python-can's
        `flush_tx_buffer`: a host that stops sends its stop frames next, not after a backlog),
        each logged as `discarded`; how many."""
        with self._cond:
            frames = self.model.take(name)
            now = self.bus_time()
            for frame in frames:
                self._record(BusEvent("discarded", now, frame, name, "unsent, discarded by its "
                                      "sender as it stopped (flush_tx_buffer)"))
            return len(frames)

    def __init__(self, name: str, model: CanBusModel, offset: float):
        self.name, self.model = name, model
        self.offset = offset
        #: (event, bus time, start, frame, sender, detail)
        self.rows: list[tuple[Any, ...]] = []
        self.failures: list[str] = []  # of participants, gateways, the log, the thread
        self._errors: list[BusEvent] = []  # the first bus errors
        self.counts = {"transmit": 0, "bus_error": 0, "arbitration_lost": 0, "dropped": 0,
                       "faulted": 0}
        self.sent_by: Counter[str] = Counter()  # frames transmitted, by participant
        self.last_error: BusEvent | None = None
        self._members: dict[str, Participant] = {}
        self._cond = threading.Condition()

    def take_rows(self) -> list[tuple[Any, ...]]:
        """The events recorded since the last call (for the log)."""
        with self._cond:
            rows, self.rows = self.rows, []
        return rows

    def problems(self) -> list[str]:
        """The first bus errors (each naming the participant, the frame and its run time),
        then any other failure."""
        return [self.describe(e) for e in list(self._errors)] + list(self.failures)

    def describe(self, event: BusEvent) -> str:
        """One line naming the bus, the participant, the frame and the bus time."""
        t = event.time + (0.0 if math.isnan(self.offset) else self.offset)
        return (f"bus '{self.name}': frame {frame_text(event.frame)} of participant "
                f"'{event.sender}' at t = {t:.6f} s: {event.detail}")

    def _add(self, member: Participant) -> str:
        name, n = member.name, 1
        while name in self._members:
            n += 1
            name = f"{member.name}#{n}"
        member.name = name
        self._members[name] = member
        self.model.join(name)
        return name

    def _record(self, event: BusEvent) -> None:
        if event.kind in self.counts:
            self.counts[event.kind] += 1
        if event.kind == "transmit":
            self.sent_by[event.sender] += 1
        elif event.kind == "bus_error":
            self.last_error = event
        if event.kind != "confirm":
            self.rows.append((event.kind, event.time, event.start, event.frame, event.sender,
                              event.detail))
        if event.kind == "bus_error" and len(self._errors) < 20:
            self._errors.append(event)

    def _dispatch(self, events: list[BusEvent], members: dict[str, Participant]) -> None:
        for event in events:
            if event.kind in ("dropped", "faulted"):  # for the log: what a fault did
                continue
            targets = [m for n, m in members.items() if n != event.sender] \
                if event.kind == "transmit" else [members[event.sender]] \
                if event.sender in members else []
            for member in targets:
                try:
                    member.deliver(event)
                except Exception as err:  # noqa: BLE001 - one participant never stops the bus
                    self.failures.append(f"bus '{self.name}': participant '{member.name}' "
                                         f"failed on {frame_text(event.frame)}: "
                                         f"{type(err).__name__}: {err}")


class BusRunner(BusCore):
    """`model` on the monotonic clock, for the bus block `name` reached as `channel`;
    `on_close(self)` once it has stopped (every participant that keeps it open gone)."""

    def __init__(self, name: str, channel: str, model: CanBusModel,
                 on_close: Callable[[BusRunner], None] | None = None):
        # bus time = monotonic + offset (set at the block's first step)
        super().__init__(name, model, math.nan)
        self.channel = channel
        self.on_close = on_close
        model.live = False  # until `begin`: the drives power up before the host joins
        model.run_offset = math.nan
        self._keepers: set[str] = set()
        self._closing = False
        self._stopped = False
        self._handing = False  # the thread is handing events to the participants
        self._thread = threading.Thread(target=self._run, name=f"can-bus {name}", daemon=True)
        register(channel, self)
        self._thread.start()

    # -- participants ------------------------------------------------------------------------
    def join(self, member: Participant, keeps_open: bool = True) -> str:
        """Add `member`; its name on the bus (made unique with '#2', '#3', ...). A closed bus
        stops when the last member that `keeps_open` has left (a gateway does not)."""
        with self._cond:
            if self._stopped:
                raise can.CanInitializationError(f"bus '{self.name}' has stopped")
            name = self._add(member)
            if keeps_open:
                self._keepers.add(name)
            return name

    def leave(self, name: str, flush: float = 0.5) -> None:
        """`name` leaves once its frames are on the wire (at most `flush` [s] of waiting); the
        last participant that keeps a closed bus open stops it."""
        deadline = time.monotonic() + flush
        with self._cond:
            while (self.model.pending(name) or self._handing) and \
                    time.monotonic() < deadline and self._thread.is_alive():
                self._cond.wait(deadline - time.monotonic())
            self._members.pop(name, None)
            self._keepers.discard(name)
            self.model.leave(name)
            self.model.live = False  # participants leave when the run stops
            last = self._closing and not self._keepers
        if last:
            self._stop()

    def handed(self, name: str, timeout: float) -> bool:
        """Wait (at most `timeout` [s]) until the frames `name` queued have been on the wire
        and handed to the others; whether they have."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while (self.model.pending(name) or self._handing) and self._thread.is_alive():
                left = deadline - time.monotonic()
                if left <= 0:
                    return False
                self._cond.wait(left)
            return not self.model.pending(name)

    def submit(self, sender: str, frame: can.Message, at: float | None = None) -> str:
        """Queue `frame` of `sender` now (or at run time `at` [s], for a participant stepped in
        simulated time); '' or why the bus refuses it."""
        with self._cond:
            queued = now = time.monotonic()
            if at is not None and not math.isnan(self.offset):
                now = at - self.offset
            problem = self.model.submit(sender, frame, now, queued)
            if problem:
                self._record(BusEvent("bus_error", now, frame, sender, problem))
            self._cond.notify_all()
        return problem

    def begin(self, t: float) -> None:
        """The run's first step, at run time `t` [s]: bus time is run time from now, and a
        frame no one acknowledges is an ACK error."""
        with self._cond:
            self.offset = self.model.run_offset = t - time.monotonic()
            self.model.live = not self._closing

    def now(self) -> float:
        """Bus time [s] (the run's time once the block has stepped)."""
        return time.monotonic() + (0.0 if math.isnan(self.offset) else self.offset)

    def bus_time(self) -> float:
        return time.monotonic()  # bus time is the monotonic clock (the log adds the offset)

    # -- the thread ----------------------------------------------------------------------------
    def _run(self) -> None:
        while True:
            try:
                with self._cond:
                    while not self._stopped:
                        due = self.model.next_time()
                        now = time.monotonic()
                        if due is not None and due <= now:
                            break
                        self._cond.wait(None if due is None else due - now)
                    if self._stopped:
                        return
                    events = self.model.advance(time.monotonic())
                    for event in events:
                        if event.kind != "bus_error" or not math.isnan(event.start):
                            self._record(event)  # refusals were recorded at submission
                    members = dict(self._members)
                    self._handing = True
                self._dispatch(events, members)
                with self._cond:
                    self._handing = False
                    self._cond.notify_all()
            except Exception as err:  # noqa: BLE001 - the bus thread outlives any failure
                self.failures.append(f"bus '{self.name}' thread: {type(err).__name__}: {err}")

    # -- the end -------------------------------------------------------------------------------
    def close(self) -> None:
        """The block is done: stop now if no participant is left, else when the last leaves."""
        with self._cond:
            self._closing = True
            self.model.live = False
            empty = not self._keepers
        if empty:
            self._stop()

    def _stop(self) -> None:
        with self._cond:
            if self._stopped:
                return
            self._stopped = True
            self._cond.notify_all()
        if threading.current_thread() is not self._thread:
            self._thread.join(timeout=1.0)
        with self._cond:
            events = self.model.advance(math.inf)  # what was still queued goes at once
            for event in events:
                self._record(event)
            members = dict(self._members)
        self._dispatch(events, members)
        unregister(self.channel, self)
        if self.on_close is not None:
            self.on_close(self)


class BlockBus(can.BusABC):
    """python-can interface `twmr`: a participant of the bus block reached as `channel`
    (`participant`: its name on the bus and in the frame log)."""

    def __init__(self, channel: str, participant: str = "", **kwargs: Any):
        bus = runner(str(channel))
        if bus is None:
            raise can.CanInitializationError(
                f"no running can_bus block on channel '{channel}' in this process (interface "
                f"'{INTERFACE}' reaches bus blocks of a run: give the drive bus: <block>)")
        super().__init__(channel=channel, **kwargs)
        self.name = participant or "python-can"
        self.channel_info = f"can_bus '{bus.name}'"
        self._runner = bus
        #: frames delivered and not yet received (as python-can's virtual bus has it)
        self.queue: queue.SimpleQueue[can.Message] = queue.SimpleQueue()
        self._runner.join(self)

    @property
    def in_run_time(self) -> bool:
        """Whether the bus is stepped in run time by its block (frames arrive as it steps,
        stamped with run time), not on the wall clock."""
        return self._runner.in_run_time

    def deliver(self, event: BusEvent) -> None:
        """Queue a frame of another participant (an error frame for a bus error), stamped with
        the time it ended on the wire: run time on a bus in run time, else the host's clock."""
        stamp = event.time if self._runner.in_run_time else time.time()
        if event.kind == "transmit":
            msg = can.Message(timestamp=stamp, arbitration_id=event.frame.arbitration_id,
                              is_extended_id=event.frame.is_extended_id,
                              is_remote_frame=event.frame.is_remote_frame,
                              is_fd=event.frame.is_fd, bitrate_switch=event.frame.bitrate_switch,
                              dlc=event.frame.dlc, data=bytes(event.frame.data), is_rx=True,
                              channel=self._runner.name, check=False)
            self.queue.put(msg)
        elif event.kind == "bus_error" and not math.isnan(event.start):
            self.queue.put(can.Message(timestamp=stamp, is_error_frame=True,
                                        channel=self._runner.name, is_rx=True))

    def send(self, msg: can.Message, timeout: float | None = None) -> None:
        problem = self._runner.submit(self.name, msg)
        if problem:
            raise can.CanOperationError(f"{problem} (frame {frame_text(msg)} refused by bus "
                                        f"'{self._runner.name}')")

    def flush_sent(self, timeout: float) -> bool:
        """Wait (at most `timeout` [s]) until the frames sent so far are on the wire and handed
        to the others; whether they are."""
        return self._runner.handed(self.name, timeout)

    def flush_tx_buffer(self) -> None:
        """Discard the frames sent and not yet on the wire (python-can's API)."""
        self._runner.discard(self.name)

    def _recv_internal(self, timeout: float | None) -> tuple[can.Message | None, bool]:
        try:
            msg = self.queue.get_nowait() if timeout == 0 else self.queue.get(timeout=timeout)
        except queue.Empty:
            return None, False
        return msg, False

    def shutdown(self) -> None:
        if self._is_shutdown:
            return
        super().shutdown()
        self._runner.leave(self.name)


class Gateway:
    """The bus block's link to a python-can bus outside (`options` for `can.Bus`): frames of
    the block's participants are sent onto it when they end on the simulated wire; frames
    received from it are submitted as from participant `name` (a store-and-forward gateway:
    one simulated frame time later)."""

    #: python-can interfaces that hand a bus its own frames back (udp_multicast: the multicast
    #: loop of the host), and how long [s] after sending one its echo may come (a loaded
    #: machine delays it by tens of ms; an identical frame from another node in that time is
    #: taken for the echo, and the echo passed on in its place: the same frame either way)
    ECHOING: ClassVar[frozenset[str]] = frozenset({"udp_multicast"})
    ECHO_WINDOW = 2.0

    def __init__(self, bus: BusRunner, options: dict[str, Any], name: str):
        self.name = name
        self._runner = bus
        self._echoes: deque[tuple[float, tuple[Any, ...]]] | None = \
            deque() if options.get("interface") in self.ECHOING else None
        self._echo_lock = threading.Lock()
        self._bus = can.Bus(**options)
        self._stop = threading.Event()
        bus.join(self, keeps_open=False)
        self._thread = threading.Thread(target=self._receive, name=f"can-gateway {name}",
                                        daemon=True)
        self._thread.start()

    def deliver(self, event: BusEvent) -> None:
        if event.kind == "transmit":
            if self._echoes is not None:
                with self._echo_lock:
                    self._echoes.append((time.monotonic(), _key(event.frame)))
            try:
                self._bus.send(can.Message(
                    arbitration_id=event.frame.arbitration_id, data=bytes(event.frame.data),
                    is_extended_id=event.frame.is_extended_id,
                    is_remote_frame=event.frame.is_remote_frame, is_fd=event.frame.is_fd,
                    bitrate_switch=event.frame.bitrate_switch, dlc=event.frame.dlc,
                    check=False))
            except (can.CanError, OSError) as err:
                self._runner.failures.append(f"bus '{self._runner.name}': gateway {self.name} "
                                             f"could not send {frame_text(event.frame)}: {err}")

    def _receive(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self._bus.recv(timeout=0.05)
                if msg is not None and not msg.is_error_frame and not self._echo(msg):
                    self._runner.submit(self.name, msg)
            except Exception as err:  # noqa: BLE001 - a bad frame or adapter never ends it
                self._runner.failures.append(f"bus '{self._runner.name}': gateway {self.name}: "
                                             f"{type(err).__name__}: {err}")
                time.sleep(0.05)

    def _echo(self, msg: can.Message) -> bool:
        """Whether `msg` is the echo of a frame this gateway sent (interfaces in `ECHOING`):
        the same frame, sent within `ECHO_WINDOW`, each frame sent taken back once."""
        if self._echoes is None:
            return False
        key, now = _key(msg), time.monotonic()
        with self._echo_lock:
            while self._echoes and now - self._echoes[0][0] > self.ECHO_WINDOW:
                self._echoes.popleft()
            for i, (_, sent) in enumerate(self._echoes):
                if sent == key:
                    del self._echoes[i]
                    return True
        return False

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
        self._runner.leave(self.name, flush=0.0)
        with contextlib.suppress(Exception):
            self._bus.shutdown()


def _key(frame: can.Message) -> tuple[Any, ...]:
    return (frame.arbitration_id, bool(frame.is_extended_id), bool(frame.is_remote_frame),
            bool(frame.is_fd), int(frame.dlc), bytes(frame.data or b""))


class FrameLog:
    """A bus's events streamed to an Arrow IPC stream file (readable after a crash, like the
    run's `result.arrows`) by a thread of its own, every `period` [s] once the bus has its run
    time (its block's first step; `period` None: no thread, all at `close`): time (end of
    EOF, or of the refusal) and start [s, run time], event, id, extended, remote, fd, brs,
    dlc, data, sender, detail."""

    def __init__(self, bus: BusCore, path: Path, period: float | None = 0.5):
        self.bus, self.path, self.period = bus, path, period
        self.error = ""
        self._writer: Any = None
        self._sink: Any = None
        self._schema: Any = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        if period is not None:
            self._thread = threading.Thread(target=self._run, args=(period,),
                                            name=f"can-log {bus.name}", daemon=True)
            self._thread.start()

    def _run(self, period: float) -> None:
        while not self._stop.wait(period):
            if not math.isnan(self.bus.offset):
                self._write()

    def _write(self) -> None:
        import pyarrow as pa

        rows = self.bus.take_rows()
        if self.error or (not rows and self._writer is not None):
            return
        try:
            off = self.bus.offset
            frames = [r[3] for r in rows]
            batch = pa.record_batch({
                "time": pa.array([r[1] + off for r in rows], pa.float64()),
                "start": pa.array([r[2] + off for r in rows], pa.float64()),
                "event": pa.array([r[0] for r in rows], pa.string()),
                "id": pa.array([f.arbitration_id for f in frames], pa.uint32()),
                "extended": pa.array([bool(f.is_extended_id) for f in frames], pa.bool_()),
                "remote": pa.array([bool(f.is_remote_frame) for f in frames], pa.bool_()),
                "fd": pa.array([bool(f.is_fd) for f in frames], pa.bool_()),
                "brs": pa.array([bool(f.bitrate_switch) for f in frames], pa.bool_()),
                "dlc": pa.array([int(f.dlc) for f in frames], pa.uint8()),
                "data": pa.array([bytes(f.data or b"") for f in frames], pa.binary()),
                "sender": pa.array([r[4] for r in rows], pa.string()),
                "detail": pa.array([r[5] for r in rows], pa.string()),
            })
            if self._writer is None:
                model = self.bus.model
                schema = batch.schema.with_metadata({
                    "bus": self.bus.name, "bitrate": str(model.bitrate),
                    "data_bitrate": str(model.data_bitrate), "stuffing": model.stuffing,
                    "time": "s; end of EOF (start: first bit); before 0: before the first step"})
                self.path.parent.mkdir(parents=True, exist_ok=True)
                self._sink = pa.OSFile(str(self.path), "wb")
                self._writer = pa.ipc.new_stream(self._sink, schema)
                self._schema = schema
            self._writer.write_batch(batch.replace_schema_metadata(self._schema.metadata))
            self._sink.flush()
        except Exception as err:  # noqa: BLE001 - a log never stops the bus or the run
            self.error = f"{type(err).__name__}: {err}"

    def close(self) -> None:
        """Write what is left and close the file (after the bus has stopped)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        if math.isnan(self.bus.offset):
            self.bus.offset = 0.0
        self._write()
        for part in (self._writer, self._sink):
            if part is not None:
                with contextlib.suppress(Exception):
                    part.close()


def read_log(path: str | Path) -> Any:
    """A bus block's frame log (`FrameLog`) as a pandas DataFrame."""
    import pyarrow as pa

    with pa.OSFile(str(path), "rb") as source:
        return pa.ipc.open_stream(source).read_all().to_pandas()
