"""A CAN bus in time, no I/O: how long a frame is on the wire, which frame wins the bus, and
what each participant is told when (the bus simulation an FMI-LS-BUS importer performs).

Frame length (ISO 11898-1). Classic CAN: SOF, identifier (11 bits; extended: 11, SRR, IDE, 18),
RTR, IDE/r1, r0, DLC (4), data, CRC-15 are bit-stuffed; CRC delimiter, ACK slot, ACK delimiter,
7 EOF bits and 3 intermission bits are not. `stuffing="exact"` inserts the stuff bits the frame's
own bits need (its CRC-15 computed); `"worst"` counts floor((n - 1) / 4) stuff bits over the n
stuffed bits, the bound of Davis et al. (2007): 135 bits for 8 data bytes and an 11-bit
identifier. CAN FD: SOF through the data are bit-stuffed, then the stuff count (4 bits) and
CRC-17 (up to 16 bytes) or CRC-21 carry one fixed stuff bit per 4 bits, ceil((4 + L) / 4); with
bit-rate switching the bits after BRS up to the end of the CRC go at `data_bitrate`, the rest at
`bitrate` (BRS and the CRC delimiter are counted at the nominal rate).

Bus time is in seconds, in whatever clock the caller uses. A participant hands frames to its own
transmit queue (FIFO, as a socketcan socket); when the bus is free, the oldest frame of each
participant pending at that instant contends and the lowest identifier wins (bitwise arbitration:
a data frame beats a remote frame of the same identifier, a standard frame the extended one that
shares its 11 bits; equal keys go in submission order; frames handed over within `SAME_INSTANT`
of each other contend as one instant); the others are told `arbitration_lost` and contend again
when the bus is free, unless their sender is in `discarding` (LS-BUS DISCARD_AND_NOTIFY): then
the frame is dropped. A frame is received by every other participant, and
confirmed to its sender, at the end of its EOF; the bus is free 3 intermission bits later. A frame
that no other participant is there to acknowledge ends in an ACK error (`bus_error` to its
sender, not delivered, not retransmitted; while the bus is not `live`, as its runner keeps it
before the run's first step and once the run stops, it is only `unheard`). A frame that cannot
exist on the bus (data longer than its DLC, more than 8 bytes in classic CAN, an FD length that
is no DLC, an identifier out of range, FD on a bus without `fd`) is refused at submission:
`submit` returns why, and the sender is told `bus_error` at once.
"""
from __future__ import annotations

import functools
import math
import random
import re
from collections import deque
from dataclasses import dataclass, field
from typing import Any

import can

#: bits of a classic frame after the CRC: CRC delimiter, ACK slot, ACK delimiter, EOF (7)
TAIL = 10
#: intermission bits after EOF before the bus is free
INTERMISSION = 3
CRC15_POLY = 0x4599
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)
STUFFING = ("exact", "worst")
#: frames handed over this close together [s] contend in one arbitration (far below a bit time)
SAME_INSTANT = 1e-9


def _crc15_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 7
        for _ in range(8):
            crc = (crc << 1) ^ CRC15_POLY if crc & 0x4000 else crc << 1
        table.append(crc & 0x7FFF)
    return tuple(table)


_CRC15 = _crc15_table()
_LONG_RUNS = re.compile(r"0{4,}|1{4,}")


def crc15(bits: str, data: bytes = b"") -> int:
    """CRC-15/CAN (polynomial 0x4599, initial value 0) of the bit string `bits` ('0'/'1', MSB
    first) followed by the bytes `data`."""
    crc = 0
    for bit in bits:
        top = (bit == "1") ^ ((crc >> 14) & 1)
        crc = (crc << 1) & 0x7FFF
        if top:
            crc ^= CRC15_POLY
    for byte in data:
        crc = ((crc << 8) & 0x7FFF) ^ _CRC15[((crc >> 7) ^ byte) & 0xFF]
    return crc


def _header(frame: can.Message) -> tuple[str, int]:
    """The stuffed bits of `frame` before its data ('0'/'1'), and how many of them go at the
    nominal rate (through BRS for FD, all for classic)."""
    ident = frame.arbitration_id
    if frame.is_extended_id:
        head = f"0{ident >> 18:011b}11{ident & 0x3FFFF:018b}"  # SOF, base, SRR, IDE, extension
    else:
        head = f"0{ident:011b}"
    if frame.is_fd:
        head += ("0" if frame.is_extended_id else "00") + f"10{int(frame.bitrate_switch)}"
        nominal = len(head)  # RRS (+ IDE), FDF, res, BRS
        return head + f"{int(frame.error_state_indicator)}{FD_LENGTHS.index(frame.dlc):04b}", \
            nominal
    head += f"{int(frame.is_remote_frame)}00{min(frame.dlc, 15):04b}"  # RTR, r1/IDE, r0, DLC
    return head, len(head)


def stuff_bits(bits: str, trailing: bool = True) -> int:
    """Stuff bits of the bit string `bits`: one after five equal bits in a row, each counting
    in the run that follows it; `trailing`: also one after the last bit. Only runs of four or
    more equal bits can hold one (with the stuff bit ending the run before them)."""
    count = carry = 0
    end = -1
    for run in _LONG_RUNS.finditer(bits):
        n = run.end() - run.start() + (carry if run.start() == end else 0)
        count += n // 5
        carry, end = int(n % 5 == 0), run.end()
    if not trailing and carry and end == len(bits):
        count -= 1
    return count


def _data_bits(data: bytes) -> str:
    return format(int.from_bytes(data, "big"), f"0{8 * len(data)}b") if data else ""


@dataclass(frozen=True)
class Timing:
    """Bits of one frame on the wire: at the nominal rate, at the data rate, and the total
    duration [s] to the end of EOF and to the bus being free (after the intermission)."""

    nominal_bits: int
    data_bits: int
    to_eof: float
    to_free: float

    @property
    def bits(self) -> int:
        """Every bit of the frame, intermission included."""
        return self.nominal_bits + self.data_bits


@functools.lru_cache(maxsize=4096)
def _timing(key: tuple[Any, ...], bitrate: float, data_bitrate: float, stuffing: str
            ) -> Timing:
    frame = can.Message(arbitration_id=key[0], is_extended_id=key[1], is_remote_frame=key[2],
                        is_fd=key[3], bitrate_switch=key[4], error_state_indicator=key[5],
                        dlc=key[6], data=key[7], check=False)
    head, nominal = _header(frame)
    data = b"" if frame.is_remote_frame else bytes(frame.data)
    worst = stuffing == "worst"
    n_body = len(head) + 8 * len(data)
    if frame.is_fd:
        crc_len = 17 if len(data) <= 16 else 21
        fixed = 4 + crc_len + math.ceil((4 + crc_len) / 4)
        if worst:
            arb_stuff = (nominal - 1) // 4
            dyn_stuff = (n_body - 1) // 4 - arb_stuff
        else:
            arb_stuff = stuff_bits(head[:nominal], trailing=False)
            dyn_stuff = stuff_bits(head + _data_bits(data),
                                   trailing=False) - arb_stuff
        nominal_bits = nominal + arb_stuff + TAIL + INTERMISSION
        data_bits = n_body - nominal + dyn_stuff + fixed
        fast = data_bitrate if frame.bitrate_switch and data_bitrate > 0 else bitrate
    else:
        n = n_body + 15
        if worst:
            extra = (n - 1) // 4
        else:
            extra = stuff_bits(head + _data_bits(data) +
                               f"{crc15(head, data):015b}")
        nominal_bits, data_bits, fast = n + extra + TAIL + INTERMISSION, 0, bitrate
    to_free = nominal_bits / bitrate + data_bits / fast
    return Timing(nominal_bits, data_bits, to_free - INTERMISSION / bitrate, to_free)


def frame_timing(frame: can.Message, bitrate: float, data_bitrate: float = 0.0,
                 stuffing: str = "exact") -> Timing:
    """How long `frame` (checked by `frame_problem`) takes at `bitrate` [bit/s] (data phase of a
    BRS frame at `data_bitrate`, default `bitrate`), stuff bits counted as `stuffing` says."""
    key = (frame.arbitration_id, bool(frame.is_extended_id), bool(frame.is_remote_frame),
           bool(frame.is_fd), bool(frame.bitrate_switch), bool(frame.error_state_indicator),
           int(frame.dlc), bytes(frame.data or b""))
    return _timing(key, float(bitrate), float(data_bitrate), stuffing)


def frame_problem(frame: can.Message, fd: bool) -> str:
    """'' when `frame` can be sent on the bus (`fd`: CAN FD allowed), else why not."""
    n, dlc = len(frame.data or b""), frame.dlc
    limit = 0x1FFFFFFF if frame.is_extended_id else 0x7FF
    if frame.is_error_frame:
        return "an error frame is the bus's to signal, not a participant's to send"
    if not 0 <= frame.arbitration_id <= limit:
        return (f"identifier 0x{frame.arbitration_id:x} is outside 0..0x{limit:x} "
                f"({'29' if frame.is_extended_id else '11'}-bit)")
    if frame.is_fd:
        if not fd:
            return "a CAN FD frame on a classic CAN bus (fd: false)"
        if frame.is_remote_frame:
            return "CAN FD has no remote frames"
        if n > 64:
            return f"data of {n} bytes is longer than CAN FD allows (64)"
        if n not in FD_LENGTHS:
            return (f"data of {n} bytes is no CAN FD length (0-8, 12, 16, 20, 24, 32, 48 "
                    f"or 64)")
    elif frame.is_remote_frame:
        if n:
            return f"a remote frame carries no data (it has {n} bytes)"
        if not 0 <= dlc <= 8:
            return f"DLC {dlc} of a remote frame is outside 0..8"
        return ""
    elif n > 8:
        return f"data of {n} bytes is longer than classic CAN allows (8)"
    if dlc != n:
        return f"its DLC says {dlc} bytes and it carries {n}"
    return ""


def priority(frame: can.Message) -> tuple[int, ...]:
    """Arbitration key: the lower wins (identifier bits, then RTR/SRR, IDE, extension, RTR)."""
    ident = frame.arbitration_id
    rtr = int(frame.is_remote_frame and not frame.is_fd)
    if frame.is_extended_id:
        return (ident >> 18, 1, 1, ident & 0x3FFFF, rtr)
    return (ident, rtr, 0, 0, 0)


@dataclass(frozen=True)
class BusEvent:
    """What the bus tells participants: `transmit` (a frame every participant but its sender
    receives), `confirm`, `arbitration_lost` or `bus_error` (to the sender), `dropped` (a frame
    the bus's drop fault took: no one receives it, its sender is confirmed; for the log),
    `faulted` (what another fault did to a frame, in `detail`; for the log), at bus time
    `time` [s]; `start` is when the frame began on the wire (NaN: it never did)."""

    kind: str
    time: float
    frame: can.Message
    sender: str
    detail: str = ""
    start: float = math.nan


@dataclass
class _Pending:
    frame: can.Message
    sender: str
    time: float
    seq: int
    queued: float = -math.inf  # bus time it was handed over (later than `time` for one late)


#: what a fault of the bus does to a frame it takes (`FrameFault.kind`)
FAULTS = {
    "drop": "lost: received by no one, confirmed to its sender (a gateway or a failing "
            "transceiver that loses it silently)",
    "duplicate": "received twice by every receiver (a sender that missed the ACK and sent it "
                 "again)",
    "delay": "received `delay` s after it ended on the wire (a gateway's latency), confirmed to "
             "its sender on time",
    "corrupt": "received with one data bit flipped and a valid CRC (a fault before the CRC is "
               "computed: a gateway's or a node's memory)",
    "crc_error": "one bit flipped on the wire: no receiver accepts it, its sender sees the error "
                 "frame and sends it again (unless it discards frames)",
    "error_frame": "destroyed by an error frame that every participant sees (a disturbed bus); "
                   "its sender sends it again (unless it discards frames)",
    "bus_off": "its sender is bus-off for the window: the frame never reaches the wire and the "
               "sender gets a bus error (a node whose error counter passed 255)",
    "babble": "a babbling node floods the bus with frames of the lowest identifier named (0x000 "
              "for all) back to back for the window: they win every arbitration and the others "
              "wait",
}
#: the name a babbling node's frames come from
BABBLER = "babbling node"


@dataclass(frozen=True)
class FrameFault:
    """A fault of the bus: frames of identifiers `ids` (all when empty) that end on the wire in
    [start, stop) [s of run time] are taken, each with probability `probability`, drawn from
    `seed`, at most `count` of them (0: no limit), and `kind` happens to them (`FAULTS`):
    `delay` [s] for a delay, `bit` the data bit flipped for a corruption (-1: drawn)."""

    ids: frozenset[int] = frozenset()
    start: float = 0.0
    stop: float = math.inf
    probability: float = 1.0
    seed: int = 0
    count: int = 0
    kind: str = "drop"
    delay: float = 0.0
    bit: int = -1
    #: the participants whose frames it takes (empty: every one)
    senders: frozenset[str] = frozenset()

    def applies(self, frame: can.Message, t: float, sender: str = "") -> bool:
        """Whether `frame` of `sender`, ending at run time t [s], is one the fault may take."""
        return self.start <= t < self.stop and (not self.ids or
                                                frame.arbitration_id in self.ids) and \
            (not self.senders or sender in self.senders)


def flipped(frame: can.Message, bit: int) -> can.Message:
    """A copy of `frame` with data bit `bit` (0: the first byte's lowest) flipped."""
    data = bytearray(frame.data)
    data[bit // 8] ^= 1 << (bit % 8)
    return can.Message(arbitration_id=frame.arbitration_id, data=bytes(data),
                       is_extended_id=frame.is_extended_id, is_fd=frame.is_fd,
                       bitrate_switch=frame.bitrate_switch, dlc=frame.dlc,
                       is_remote_frame=frame.is_remote_frame, channel=frame.channel,
                       timestamp=frame.timestamp)


@dataclass
class CanBusModel:
    """One CAN bus at `bitrate` [bit/s] (`fd`: CAN FD frames allowed, data phase at
    `data_bitrate`), stuffing `exact` or `worst`. Participants `join` and `leave` by name,
    `submit` frames at a bus time, and `advance` returns what happened up to a time."""

    bitrate: float = 1_000_000
    data_bitrate: float = 0.0
    fd: bool = False
    stuffing: str = "exact"
    members: set[str] = field(default_factory=set)
    busy_time: float = 0.0  # [s] of bus time carrying frames (intermission included)
    #: the longest a frame waited for the bus since the owner last set it to 0 [s of bus time,
    #: the model's own]: from when it was due (or handed over, if later) to its start, or to
    #: the end of the last frame for one still waiting (a flood makes it grow)
    longest_wait: float = 0.0
    live: bool = True  # False while the bus comes up or winds down: no ACK errors then
    #: participants whose frames that lose arbitration are dropped, not sent again
    discarding: set[str] = field(default_factory=set)
    #: frames taken on purpose (a fault injected), or None
    fault: FrameFault | None = None
    #: run time = bus time + run_offset [s] (NaN until the run begins: no fault before)
    run_offset: float = 0.0

    def __post_init__(self) -> None:
        self._random = random.Random(self.fault.seed if self.fault else 0)
        self._draw = self._random.random
        self.faulted = 0  # frames the fault took
        self._later: list[BusEvent] = []  # delayed deliveries, in time order
        self._queues: dict[str, deque[_Pending]] = {}
        self._seq = 0
        self._on_wire: tuple[_Pending, float, Timing] | None = None
        self._free_at = -math.inf
        self._now: list[BusEvent] = []

    def join(self, name: str) -> None:
        self.members.add(name)

    def _taken(self, frame: can.Message, end: float, sender: str = "") -> bool:
        """Whether the fault takes `frame` of `sender`, ending on the wire at bus time `end`
        (a babbling node's frames and a bus-off are not taken here)."""
        fault = self.fault
        if fault is None or fault.kind in ("babble", "bus_off") or sender == BABBLER or \
                not fault.applies(frame, end + self.run_offset, sender) or \
                (fault.count and self.faulted >= fault.count) or \
                (fault.probability < 1.0 and self._draw() >= fault.probability) or \
                (fault.kind == "corrupt" and not frame.data):
            return False
        self.faulted += 1
        return True

    def _faulted(self, item: _Pending, start: float, end: float) -> list[BusEvent]:
        """What the fault does to `item`, on the wire from `start` to `end`: the events now
        (the delayed delivery goes to `_later`)."""
        fault = self.fault
        assert fault is not None
        frame, sender = item.frame, item.sender
        heard = bool(self.members - {sender})
        if fault.kind == "drop":
            return [BusEvent("dropped", end, frame, sender,
                             "lost on purpose (the bus's drop fault)", start=start),
                    BusEvent("confirm", end, frame, sender, start=start)]
        if fault.kind == "crc_error":
            if sender not in self.discarding:  # sent again once the bus is free
                self._queues.setdefault(sender, deque()).appendleft(item)
            return [BusEvent("faulted", end, frame, sender, "crc_error: a bit flipped on the "
                             "wire, no receiver accepted it", start=start),
                    BusEvent("bus_error", end, frame, sender, "CRC error: a bit flipped on the "
                             "wire (the bus's crc_error fault)", start=start)]
        if fault.kind == "error_frame":
            if sender not in self.discarding:
                self._queues.setdefault(sender, deque()).appendleft(item)
            seen = [BusEvent("bus_error", end, frame, member, "error frame: the frame was "
                             "destroyed on the wire (the bus's error_frame fault)", start=start)
                    for member in sorted(self.members | {sender})]
            return [BusEvent("faulted", end, frame, sender, "error_frame: destroyed by an "
                             "error frame every participant saw", start=start), *seen]
        out = [BusEvent("confirm", end, frame, sender, start=start)]
        if not heard:
            return out
        if fault.kind == "duplicate":
            out[:0] = [BusEvent("faulted", end, frame, sender, "duplicate: received twice",
                                start=start),
                       BusEvent("transmit", end, frame, sender, start=start),
                       BusEvent("transmit", end, frame, sender, start=start)]
        elif fault.kind == "delay":
            out.insert(0, BusEvent("faulted", end, frame, sender,
                                   f"delay: received {fault.delay:g} s later", start=start))
            self._later.append(BusEvent("transmit", end + fault.delay, frame, sender,
                                        start=start))
            self._later.sort(key=lambda e: e.time)
        else:  # corrupt
            bit = fault.bit if 0 <= fault.bit < 8 * len(frame.data) else \
                self._random.randrange(8 * len(frame.data))
            out[:0] = [BusEvent("faulted", end, frame, sender,
                                f"corrupt: data bit {bit} flipped, CRC valid", start=start),
                       BusEvent("transmit", end, flipped(frame, bit), sender, start=start)]
        return out

    def _babble(self) -> None:
        """Queue the babbling node's next frame, back to back from the bus's next free instant,
        while its window lasts (`babble` fault)."""
        fault = self.fault
        if fault is None or fault.kind != "babble" or self._queues.get(BABBLER) or \
                math.isnan(self.run_offset) or (fault.count and self.faulted >= fault.count):
            return
        at = max(self._free_at, fault.start - self.run_offset)
        if at + self.run_offset >= fault.stop:
            return
        ident = min(fault.ids) if fault.ids else 0
        self.faulted += 1
        self._seq += 1
        self._queues.setdefault(BABBLER, deque()).append(_Pending(
            can.Message(arbitration_id=ident, data=bytes(8), is_extended_id=ident > 0x7FF),
            BABBLER, at, self._seq, at))

    def _bus_off(self, item: _Pending, start: float) -> bool:
        """Whether `item`'s sender is bus-off at bus time `start` (`bus_off` fault)."""
        fault = self.fault
        if fault is None or fault.kind != "bus_off" or item.sender == BABBLER:
            return False
        t = start + self.run_offset
        if not (fault.start <= t < fault.stop) or (fault.senders and
                                                   item.sender not in fault.senders):
            return False
        self.faulted += 1
        return True

    def leave(self, name: str) -> None:
        """`name` is gone; frames it submitted stay queued (they are on their way)."""
        self.members.discard(name)

    def drop(self, name: str) -> int:
        """Forget the frames `name` queued and not yet on the wire (a node that stopped); how
        many."""
        return len(self.take(name))

    def take(self, name: str) -> list[can.Message]:
        """The frames `name` queued and not yet on the wire, taken off the bus (in order)."""
        return [item.frame for item in self._queues.pop(name, ())]

    def pending(self, name: str) -> int:
        """Frames of `name` not yet finished on the wire."""
        wire = self._on_wire is not None and self._on_wire[0].sender == name
        return len(self._queues.get(name, ())) + int(wire)

    def submit(self, sender: str, frame: can.Message, t: float,
               queued: float | None = None) -> str:
        """Queue `frame` of `sender` at bus time `t` [s], handed over at bus time `queued`
        (default `t`); '' or why it is refused (then a `bus_error` for the sender comes with
        the next `advance`)."""
        problem = frame_problem(frame, self.fd)
        if problem:
            self._now.append(BusEvent("bus_error", t, frame, sender, problem))
            return problem
        self._seq += 1
        self._queues.setdefault(sender, deque()).append(
            _Pending(frame, sender, t, self._seq, t if queued is None else queued))
        return ""

    def next_time(self) -> float | None:
        """Bus time of the next event (None: nothing pending)."""
        later = self._later[0].time if self._later else math.inf
        if self._now:
            return min(self._now[0].time, later)
        if self._on_wire is not None:
            return min(self._on_wire[1] + self._on_wire[2].to_eof, later)
        heads = [q[0].time for q in self._queues.values() if q]
        if heads:
            return min(max(self._free_at, min(heads)), later)
        return None if self._later == [] else later

    def advance(self, until: float) -> list[BusEvent]:
        """Every event up to bus time `until` [s], in time order."""
        events, self._now = self._now, []
        released = False
        while self._later and self._later[0].time <= until:
            events.append(self._later.pop(0))
            released = True
        while True:
            if self._on_wire is not None:
                item, start, timing = self._on_wire
                end = start + timing.to_eof
                if end > until:
                    break
                self._on_wire = None
                self._free_at = start + timing.to_free
                self.busy_time += timing.to_free
                if self._taken(item.frame, end, item.sender):
                    events += self._faulted(item, start, end)
                elif item.sender == BABBLER:
                    events.append(BusEvent("transmit", end, item.frame, item.sender,
                                           start=start))
                elif self.members - {item.sender}:
                    events.append(BusEvent("transmit", end, item.frame, item.sender,
                                           start=start))
                    events.append(BusEvent("confirm", end, item.frame, item.sender,
                                           start=start))
                elif not self.live:
                    events.append(BusEvent("unheard", end, item.frame, item.sender,
                                           "no one else on the bus yet, or any more",
                                           start=start))
                else:
                    events.append(BusEvent("bus_error", end, item.frame, item.sender,
                                           "ACK error: no other participant on the bus "
                                           "acknowledged it", start=start))
                continue
            self._babble()
            heads = [q[0] for q in self._queues.values() if q]
            if not heads:
                break
            start = max(self._free_at, min(h.time for h in heads))
            if start > until:
                break
            contenders = [h for h in heads if h.time <= start + SAME_INSTANT]
            winner = min(contenders, key=lambda h: (priority(h.frame), h.seq))
            if self._bus_off(winner, start):
                self._queues[winner.sender].popleft()
                events.append(BusEvent("bus_error", start, winner.frame, winner.sender,
                                       "bus-off: the node may not send (the bus's bus_off "
                                       "fault)", start=start))
                continue
            self.longest_wait = max(self.longest_wait, start - max(winner.time, winner.queued))
            self._queues[winner.sender].popleft()
            for lost in contenders:
                if lost is not winner:
                    if lost.sender in self.discarding:
                        self._queues[lost.sender].popleft()
                    events.append(BusEvent("arbitration_lost", start, lost.frame, lost.sender,
                                           f"lost to 0x{winner.frame.arbitration_id:x}"))
            self._on_wire = (winner, start, frame_timing(winner.frame, self.bitrate,
                                                         self.data_bitrate, self.stuffing))
        for head in (q[0] for q in self._queues.values() if q):  # waiting still
            self.longest_wait = max(self.longest_wait,
                                    self._free_at - max(head.time, head.queued))
        while self._later and self._later[0].time <= until:  # delayed within this advance
            events.append(self._later.pop(0))
            released = True
        if released:  # delayed deliveries in time order among the rest
            events.sort(key=lambda e: e.time)
        return events
