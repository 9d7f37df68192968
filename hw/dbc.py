"""A CAN database (DBC, ARXML, KCD or SYM, read by cantools) as typed ports.

`CanDatabase.load(path)` reads the file (its format from the suffix), strictly: a syntax error, or
signals that overlap, is a `DatabaseError` naming the file, line and column where the file says
them. `messages(...)` picks messages by name, by node (`senders`/`receivers`) or all (`*`).
`MessagePorts` holds what one message is as ports: one Real port per signal, named
`<message>.<signal>` (FMI's structured names), with its unit (`port_unit`), range and
enumeration; `pages` are the frames a multiplexed message needs (one per multiplexer value, or
combination of values when multiplexers are cascaded), `encode` and `decode` what goes over the
wire. Values outside the file's range are saturated to it before encoding, as a CAN pack block
does, and counted.
"""
from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

#: file suffixes cantools reads, by the format's name
FORMATS = {".dbc": "dbc", ".arxml": "arxml", ".kcd": "kcd", ".sym": "sym"}

#: DBC unit texts whose meaning differs from a Modelica unit of the same spelling, or that have
#: none: 'g' on a CAN signal is standard gravity, not the gram
_UNITS = {"°": "deg", "deg": "deg", "°/s": "deg/s", "deg/s": "deg/s", "°/s2": "deg/s2",
          "°/s²": "deg/s2", "%": "percent", "°C": "degC", "degC": "degC", "C": "degC",
          "m/s²": "m/s2", "m/s^2": "m/s2", "rad/s²": "rad/s2", "Nm": "N.m", "kph": "km/h",
          "km/h": "km/h", "rpm": "rpm", "1/min": "rpm", "U/min": "rpm", "Bar": "bar",
          "mph": "", "g": "", "-": "", "ASCII": "", "cm3": "cm3", "Ah": "A.h", "kWh": "kW.h",
          "mAh": "mA.h", "Wh": "W.h"}

#: per-message status ports, after the message's name
STATUS = ("age", "timed_out", "frames")


class DatabaseError(ValueError):
    """A CAN database that cannot be used, with the file (and line) in the text."""


def port_unit(text: str | None) -> str:
    """The port unit of a signal's unit text: a Modelica unit where the text means one (°/s ->
    deg/s, % -> percent, Nm -> N.m), '' (unspecified) where it means none or another thing than
    the Modelica unit of that spelling (g, mph, -)."""
    from twmr.core.units import known_unit

    text = (text or "").strip()
    if not text:
        return ""
    unit = _UNITS.get(text, text)
    if unit and known_unit(unit) is None:
        return ""
    return unit


def _syntax_place(text: str) -> str:
    """'line 5, column 22: near `...`' from a cantools parse error, or ''."""
    m = re.search(r"line (\d+), column (\d+): \"(.*)\"", text, re.S)
    if not m:
        return ""
    near = m.group(3).split(">>!<<")[0][-40:].strip()
    return f"line {m.group(1)}, column {m.group(2)}: the text stops making sense after `{near}`"


class CanDatabase:
    """A loaded CAN database and where it came from."""

    def __init__(self, db: Any, path: Path):
        self.db = db
        self.path = path

    @classmethod
    def load(cls, path: str | Path) -> CanDatabase:
        """Read `path` (format from the suffix; DatabaseError with the file and line when it
        cannot be used)."""
        import cantools

        path = Path(path)
        fmt = FORMATS.get(path.suffix.lower())
        if fmt is None:
            raise DatabaseError(f"{path}: '{path.suffix}' is no CAN database suffix cantools "
                                f"reads ({', '.join(FORMATS)})")
        if not path.is_file():
            raise DatabaseError(f"{path} does not exist")
        try:
            db = cantools.database.load_file(str(path), database_format=fmt, strict=True,
                                             encoding=None if fmt != "dbc" else "cp1252")
        except cantools.database.UnsupportedDatabaseFormatError as err:
            text = str(err)
            place = _syntax_place(text)
            raise DatabaseError(f"{path}: {place or text} (cantools reads it as {fmt.upper()})"
                                ) from None
        except (cantools.database.Error, ValueError, KeyError, UnicodeDecodeError) as err:
            raise DatabaseError(f"{path}: {type(err).__name__}: {err}") from None
        return cls(db, path)

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.db.messages]

    def messages(self, chosen: str, node: str, direction: str) -> list[Any]:
        """The messages `chosen` names ('Msg1, Msg2', '*' = all), or with `node` and `chosen`
        empty those the node sends (`direction` 'send') or receives ('receive'); DatabaseError
        naming an unknown message or node, with the closest name."""
        from twmr.registry import suggest

        text = chosen.strip()
        if not text:
            if not node:
                return []
            nodes = [n.name for n in self.db.nodes]
            if node not in nodes:
                raise DatabaseError(f"{self.path}: there is no node '{node}'"
                                    f"{suggest(node, nodes)} (nodes: {', '.join(nodes)})")
            plain = [m for m in self.db.messages if not m.is_container]
            if direction == "send":
                return [m for m in plain if node in m.senders]
            return [m for m in plain
                    if any(node in s.receivers for s in m.signals) and node not in m.senders]
        if text == "*":
            return [m for m in self.db.messages if not m.is_container]
        found = []
        for name in (p.strip() for p in text.replace(";", ",").split(",")):
            if not name:
                continue
            try:
                message = self.db.get_message_by_name(name)
            except KeyError:
                raise DatabaseError(f"{self.path}: there is no message '{name}'"
                                    f"{suggest(name, self.names)}") from None
            if message.is_container:
                raise DatabaseError(f"{self.path}: message '{name}' is an AUTOSAR container "
                                    f"PDU, which can_io does not pack; choose the messages it "
                                    f"contains")
            found.append(message)
        return found


#: the data lengths a CAN FD frame can have [bytes]
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


def wire_length(n: int) -> int:
    """The length of the frame that carries `n` bytes: `n` up to 8, else the next CAN FD
    length (a message of 9 bytes goes as 12, padded with zeros)."""
    return next((k for k in FD_LENGTHS if k >= n), n)


def _pages(tree: Sequence[Any]) -> list[tuple[dict[str, int], list[str]]]:
    """(multiplexer values, signals) of each frame a signal tree (cantools') can be sent as."""
    result: list[tuple[dict[str, int], list[str]]] = [({}, [])]
    for node in tree:
        if isinstance(node, str):
            result = [(m, [*s, node]) for m, s in result]
            continue
        grown = []
        for mux, branches in node.items():
            for m, s in result:
                for value, sub in branches.items():
                    for m2, s2 in _pages(sub):
                        grown.append(({**m, mux: int(value), **m2}, [*s, mux, *s2]))
        result = grown
    return result


def _range(signal: Any) -> tuple[float, float]:
    """The physical values `signal` can be sent with: the file's range within what its bits
    hold (a 64-bit signal's ends made floats that still fit)."""
    lo = -math.inf if signal.minimum is None else float(signal.minimum)
    hi = math.inf if signal.maximum is None else float(signal.maximum)
    if signal.is_float:
        return lo, hi
    n = int(signal.length)
    raw = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signal.is_signed else (0, (1 << n) - 1)
    ends = []
    for r, inward in ((raw[0], math.inf), (raw[1], -math.inf)):
        f = float(r)
        while f != int(f) or (int(f) > raw[1] or int(f) < raw[0]):
            f = math.nextafter(f, inward)
        ends.append(float(signal.conversion.raw_to_scaled(int(f), decode_choices=False)))
    bit_lo, bit_hi = min(ends), max(ends)
    return max(lo, bit_lo), min(hi, bit_hi)


@dataclass
class MessagePorts:
    """One message of the database as ports of a block, and its frames."""

    message: Any
    #: signal name -> port name
    ports: dict[str, str]
    #: each frame the message is sent as: (multiplexer values, signals in it)
    pages: list[tuple[dict[str, int], list[str]]]
    #: values saturated to the signal's range so far
    saturated: int = 0
    #: signals whose value was not finite, sent as their initial value
    not_finite: int = 0
    _ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    name: str = field(init=False)
    #: (identifier, extended) as on the wire
    key: tuple[int, bool] = field(init=False)
    #: sent as CAN FD frames: the file says so, or the message is longer than 8 bytes
    fd: bool = field(init=False)
    #: the file's cycle time [s] (0: none)
    cycle: float = field(init=False)

    @classmethod
    def of(cls, message: Any) -> MessagePorts:
        ports = {s.name: f"{message.name}.{s.name}" for s in message.signals}
        ranges = {s.name: _range(s) for s in message.signals}
        return cls(message, ports, _pages(message.signal_tree), _ranges=ranges)

    def __post_init__(self) -> None:
        message = self.message
        self.name = str(message.name)
        self.key = (int(message.frame_id), bool(message.is_extended_frame))
        self.fd = bool(message.is_fd) or int(message.length) > 8
        self.cycle = float(message.cycle_time or 0) / 1e3

    def initial(self, signal: Any) -> float:
        """The signal's initial value (physical): the file's, else 0 brought into its range."""
        value: Any = getattr(signal, "initial", None)
        if isinstance(value, (int, float)):
            return float(value)
        lo, hi = self._ranges[signal.name]
        return min(max(0.0, lo), hi)

    def encode(self, values: Mapping[str, float]) -> list[bytes]:
        """The frames' data for `values` (signal -> physical value; the multiplexers come from
        each page), saturated to the signals' ranges."""
        frames = []
        for mux, signals in self.pages:
            data: dict[str, float] = {}
            for name in signals:
                if name in mux:
                    data[name] = mux[name]
                    continue
                data[name] = self._fit(name, values.get(name))
            frame = bytes(self.message.encode(data, scaling=True, padding=True, strict=False))
            frames.append(frame + bytes(wire_length(len(frame)) - len(frame)))
        return frames

    def _fit(self, name: str, value: float | None) -> float:
        if value is None or not math.isfinite(value):
            if value is not None:
                self.not_finite += 1
            return self.initial(self.message.get_signal_by_name(name))
        lo, hi = self._ranges[name]
        if value < lo or value > hi:
            self.saturated += 1
            return min(max(value, lo), hi)
        return value

    def decode(self, data: bytes) -> dict[str, float]:
        """Signal -> physical value of the signals one frame carries (raw enumeration values)."""
        out = self.message.decode(bytes(data)[:self.message.length], decode_choices=False,
                                  scaling=True, allow_truncated=True)
        return {k: float(v) for k, v in out.items() if isinstance(v, (int, float))}

    def describe(self, signal: Any) -> str:
        """The port's description: the file's unit text where the port has no unit, the
        enumeration, the comment."""
        parts = []
        unit = signal.unit or ""
        if unit and not port_unit(unit):
            parts.append(f"[{unit}]")
        if signal.choices:
            parts.append("; ".join(f"{int(k)}={v}" for k, v in list(signal.choices.items())[:16]))
        if signal.comment:
            parts.append(str(signal.comment).strip())
        return " ".join(parts)


def status_collisions(messages: Iterable[MessagePorts]) -> list[str]:
    """Ports whose signal name is one of a message's status ports (age, timed_out, frames)."""
    return [p for m in messages for s, p in m.ports.items() if s in STATUS]
