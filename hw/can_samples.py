"""A CAN frame log as measured samples for the `data` block (`database:` given): the frames of a
log python-can reads (.blf, .asc, .log of candump, .trc, ...) or of a bus block's own log
(`<bus>_frames.arrows`), decoded with a CAN database (DBC, ARXML, KCD; cantools, as `can_io`
reads it) into the signals asked for as `Message.Signal` columns, in the units `can_io` gives
their ports.

A signal holds the value of its message's last frame (CAN is sample and hold), on the times of
the frames of the messages asked for; the samples start at the first frame after which every
column has a value. Times are seconds since the log's first frame, rounded to the microsecond
(python-can's logs carry wall clock stamps, a float of which resolves 0.2 us at today's
dates; the formats record microseconds), or the run times of a bus block's log. Frames the
database cannot decode (a short frame, a multiplexer value it lacks) are skipped, and counted
in the error when nothing is left."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from twmr.core.errors import CosimError


def read_can_log(path: Path, database: Path, columns: tuple[str, ...]
                 ) -> tuple[list[str], list[str], np.ndarray]:
    """(['time', *columns], their units, the samples) of the frame log `path` decoded with
    `database`; CosimError naming the file, the message or the signal at fault."""
    from twmr.hw.dbc import CanDatabase, DatabaseError, MessagePorts, port_unit
    from twmr.registry import suggest

    try:
        db = CanDatabase.load(database)
    except DatabaseError as err:
        raise CosimError(f"{err}. Fix: give a DBC, ARXML or KCD file, relative to the "
                         f"scenario's folder.") from None
    wanted: dict[str, MessagePorts] = {}
    units: list[str] = []
    for column in columns:
        name, _, signal = column.partition(".")
        if name not in db.names:
            raise CosimError(f"{path}: column '{column}': no message '{name}' in {database.name}"
                             f"{suggest(name, db.names)}. Fix: name columns Message.Signal.")
        message = db.db.get_message_by_name(name)
        signals = [s.name for s in message.signals]
        if signal not in signals:
            raise CosimError(f"{path}: column '{column}': message {name} has no signal "
                             f"'{signal}'{suggest(signal, signals)} (its signals: "
                             f"{', '.join(signals)}). Fix: name columns Message.Signal.")
        wanted.setdefault(name, MessagePorts.of(message))
        units.append(port_unit(message.get_signal_by_name(signal).unit))
    by_id = {m.key: m for m in wanted.values()}
    frames = _frames(path)
    t0 = frames[0][0] if frames and path.suffix.lower() != ".arrows" else 0.0
    last: dict[str, float] = {}
    rows: list[list[float]] = []
    skipped = 0
    for t, ident, extended, data in frames:
        message = by_id.get((ident, extended))
        if message is None:
            continue
        try:
            decoded = message.decode(data)
        except Exception:  # noqa: BLE001 - a frame its database cannot decode is skipped
            skipped += 1
            continue
        for key, value in decoded.items():
            last[f"{message.name}.{key}"] = float(value)
        if all(c in last for c in columns):
            rows.append([round(t - t0, 6) if t0 else t, *(last[c] for c in columns)])
    if not rows:
        missing = [c for c in columns if c not in last]
        undecoded = f", {skipped} of the messages asked for not decodable" if skipped else ""
        raise CosimError(f"{path}: no frame gives {', '.join(missing or columns)} "
                         f"({len(frames)} frames in the log{undecoded}). Fix: check that the "
                         f"log holds these messages and that {database.name} describes them.")
    return ["time", *columns], ["s", *units], np.array(rows, dtype=float)


def _frames(path: Path) -> list[tuple[float, int, bool, bytes]]:
    """(time [s], identifier, extended, data) of every frame on the wire in the log."""
    if not path.is_file():
        raise CosimError(f"{path}: no such frame log. Fix: give a .blf, .asc, .log (candump) or "
                         f".trc file, or a run's <bus>_frames.arrows, relative to the scenario.")
    try:
        if path.suffix.lower() == ".arrows":
            from twmr.hw.canbus import read_log

            log = read_log(path)
            sent = log[log.event == "transmit"]
            return [(float(t), int(i), bool(x), bytes(d)) for t, i, x, d in
                    zip(sent.time, sent.id, sent.extended, sent.data, strict=True)]
        import can

        return [(float(m.timestamp), int(m.arbitration_id), bool(m.is_extended_id),
                 bytes(m.data)) for m in can.LogReader(str(path))
                if not (m.is_error_frame or m.is_remote_frame)]
    except CosimError:
        raise
    except Exception as err:  # noqa: BLE001 - python-can's readers raise many kinds
        raise CosimError(f"{path}: cannot read it as a frame log ({type(err).__name__}: {err})."
                         f" Fix: give a .blf, .asc, .log (candump) or .trc file, or a run's "
                         f"<bus>_frames.arrows.") from None
