"""A ROS 2 bag as measured samples for the `data` block: a bag folder (`metadata.yaml`), an
`.mcap` of profile `ros2` or a `.db3`, read with rosbags (its own CDR decoding, the bag's own
message definitions), columns `<topic>.<field>` — `/odom.twist.twist.linear.x`,
`/joint_states.velocity[1]` (1-based, as twmr names elements) — each held from its topic's last
message (sample and hold, as a CAN log plays), on the times of the messages of the topics asked
for, in seconds since the bag's first message (a bag twmr wrote starts at its run's start). The
samples start once every column has a value. ROS 2 messages carry no units: give the data
block's `unit` (ROS uses SI: m, rad, m/s).
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.errors import CosimError

_ELEMENT = re.compile(r"^(?P<name>\w+)\[(?P<index>\d+)\]$")


def is_bag(path: Path) -> bool:
    """Whether `path` is a ROS 2 bag: a folder with metadata.yaml, a .db3, or an .mcap whose
    profile is ros2."""
    if path.is_dir():
        return (path / "metadata.yaml").is_file()
    if path.suffix.lower() == ".db3":
        return True
    if path.suffix.lower() == ".mcap" and path.is_file():
        try:
            from mcap.reader import make_reader

            with open(path, "rb") as stream:
                return make_reader(stream).get_header().profile == "ros2"
        except Exception:  # noqa: BLE001 - not an MCAP the reader knows: not a bag
            return False
    return False


def read_bag(path: Path, columns: tuple[str, ...]) -> tuple[list[str], list[str], np.ndarray]:
    """(['time', *columns], their units (''), the samples) of the bag `path`; CosimError
    naming the bag, the column and the fix."""
    from twmr.core.extras import require

    require("rosbags", "a ROS 2 bag as data")
    from rosbags.highlevel import AnyReader

    try:
        reader = AnyReader([path])
        reader.open()
    except Exception as err:  # noqa: BLE001 - rosbags raises many kinds
        raise CosimError(f"{path}: cannot read it as a ROS 2 bag ({type(err).__name__}: "
                         f"{err}). Fix: give a bag folder, its .mcap or .db3.") from None
    try:
        topics = sorted(c.topic for c in reader.connections)
        wanted = [_split(path, c, topics) for c in columns]
        by_topic = {t for t, _ in wanted}
        chosen = [c for c in reader.connections if c.topic in by_topic]
        last: dict[str, float] = {}
        rows: list[list[float]] = []
        t0: int | None = None
        for connection, stamp, raw in reader.messages(connections=chosen):
            t0 = stamp if t0 is None else t0
            message = reader.deserialize(raw, connection.msgtype)
            for column, (topic, field) in zip(columns, wanted, strict=True):
                if topic == connection.topic:
                    last[column] = _field(path, column, message, field)
            if len(last) == len(columns):
                rows.append([(stamp - t0) * 1e-9, *(last[c] for c in columns)])
    finally:
        reader.close()
    if not rows:
        missing = [c for c in columns if c not in last]
        raise CosimError(f"{path}: no message gives {', '.join(missing or columns)}. Fix: name "
                         f"topics the bag holds ({', '.join(topics[:12])}).")
    return ["time", *columns], ["s", *([""] * len(columns))], np.array(rows, dtype=float)


def _split(path: Path, column: str, topics: list[str]) -> tuple[str, list[str]]:
    """(topic, field path) of '<topic>.<field>': the longest topic of the bag it starts with."""
    from twmr.registry import suggest

    for topic in sorted(topics, key=len, reverse=True):
        if column.startswith(topic + ".") and len(column) > len(topic) + 1:
            return topic, column[len(topic) + 1:].split(".")
    head = column.split(".")[0]
    raise CosimError(f"{path}: column '{column}' names no topic of the bag"
                     f"{suggest(head, topics)} (its topics: {', '.join(topics[:12])}). Fix: "
                     f"name columns '<topic>.<field>', e.g. {topics[0] if topics else '/odom'}"
                     f".data.")


def _field(path: Path, column: str, message: Any, field: list[str]) -> float:
    """The number at `field` (names, `name[i]` 1-based) of a deserialized message."""
    value = message
    for part in field:
        found = _ELEMENT.match(part)
        name = found["name"] if found else part
        if not hasattr(value, name):
            fields = [f for f in getattr(value, "__dataclass_fields__", {}) if f != "__msgtype__"]
            raise CosimError(f"{path}: column '{column}': {type(value).__name__} has no field "
                             f"'{name}' (its fields: {', '.join(fields)}). Fix: name a field "
                             f"of the message's type.")
        value = getattr(value, name)
        if found:
            index = int(found["index"])
            if not 1 <= index <= len(value):
                raise CosimError(f"{path}: column '{column}': '{name}' has {len(value)} "
                                 f"elements; element {index} does not exist. Fix: index from "
                                 f"1 to {len(value)}.")
            value = value[index - 1]
    try:
        return float(value)
    except (TypeError, ValueError):
        raise CosimError(f"{path}: column '{column}' is a {type(value).__name__}, not a "
                         f"number. Fix: name a numeric field (or an element of an array: "
                         f"field[1]).") from None
