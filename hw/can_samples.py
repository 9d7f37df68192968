"""A CAN frame log as measured samples for the `data` block: the frames of a log python-can reads
(.blf, .asc, .log of candump, .trc, ...) or of a bus block's own log (`<bus>_frames.arrows`),
decoded with a CAN database (`database:`; DBC, ARXML, KCD; cantools, as `can_io` reads it) into
the signals asked for as `Message.Signal` columns, in the units `can_io` gives their ports, or by
a drive protocol (`protocol:`, as `twmr replay` decodes it) into `<node>.<signal>` columns.

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


def read_drive_log(path: Path, protocol: str, columns: tuple[str, ...]
                   ) -> tuple[list[str], list[str], np.ndarray]:
    """(['time', *columns], their units, the samples) of the frame log `path` decoded by the
    drive protocol `protocol` as `twmr replay` decodes it (`Link.decode`, at the wheel with
    gear 1), its columns '<node>.<signal>' ('0.speed', '1.torque_command'); CosimError naming
    the file, the column and the fix."""
    import can

    from twmr.hw.link import protocols
    from twmr.hw.replay import Decoder
    from twmr.registry import suggest

    known = sorted(protocols())
    if protocol not in known:
        raise CosimError(f"{path}: protocol '{protocol}' is not a CAN protocol here"
                         f"{suggest(protocol, known)} (known: {', '.join(known)}). Fix: give "
                         f"protocol: one of them, or database: a DBC for other frames.")
    decoder = Decoder(protocol)
    units_of = decoder._link.signal_units
    wanted: list[tuple[int, str]] = []
    units: list[str] = []
    for column in columns:
        node, _, signal = column.partition(".")
        if not node.isdigit() or not signal:
            raise CosimError(f"{path}: column '{column}' is not '<node>.<signal>'. Fix: name "
                             f"columns as the {protocol} frames decode, e.g. 0.speed, "
                             f"1.torque_command (signals: {', '.join(units_of)}).")
        wanted.append((int(node), signal))
        units.append(units_of.get(signal, ""))
    frames = _frames(path)
    t0 = frames[0][0] if frames and path.suffix.lower() != ".arrows" else 0.0
    last: dict[tuple[int, str], float] = {}
    seen: set[tuple[int | None, str]] = set()
    rows: list[list[float]] = []
    for t, ident, extended, data in frames:
        msg = can.Message(arbitration_id=ident, is_extended_id=extended, data=data)
        try:
            signals = decoder(msg)
        except (ValueError, IndexError, TypeError):
            continue
        hit = False
        for node, signal, value in signals:
            seen.add((node, signal))
            if node is not None and (node, signal) in wanted:
                last[(node, signal)] = float(value)
                hit = True
        if hit and all(w in last for w in wanted):
            rows.append([round(t - t0, 6) if t0 else t, *(last[w] for w in wanted)])
    if not rows:
        missing = [f"{n}.{s}" for n, s in wanted if (n, s) not in last]
        there = sorted(f"{n}.{s}" for n, s in seen if n is not None)
        hint = suggest(missing[0], there) if missing else ""
        raise CosimError(f"{path}: no frame gives {', '.join(missing or columns)} as "
                         f"{protocol} decodes the log{hint} (it holds: "
                         f"{', '.join(there[:12]) or 'nothing of ' + protocol}). Fix: name "
                         f"columns the log holds, or give the right protocol.")
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
