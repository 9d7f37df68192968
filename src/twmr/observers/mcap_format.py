"""MCAP export (`--format mcap`, `result.mcap`): the robotics log format Foxglove, PlotJuggler,
rerun and rosbag2 read.

- One channel per component, topic `/<component>` (a subsystem's `robot.plant` is
  `/robot/plant`), JSON messages (`message_encoding: json`) described by a JSON Schema
  (`encoding: jsonschema`) whose properties are the component's recorded ports: a scalar is a
  number, a vector an array of numbers, each with its unit in `unit` and `description`.
- One message per recorded sample on every channel; log and publish times are the simulated time
  in integer nanoseconds (`round(t * 1e9)`), so a run from t = 0 starts at 0 ns; the field
  `time_s` holds that time [s] exactly.
- A vector recorded whole is an array; elements recorded alone are fields `pose[2]`.
- Non-finite values, which JSON has no number for, are the strings "NaN", "Infinity" and
  "-Infinity" (each property's schema admits them).
- A paced CAN run's frame logs (`<drive>_frames.blf` or `.asc` beside the results, read by the
  `twmr.frame_logs` plug-in of their suffix, `twmr.hw.frame_channel`) are one more channel
  each, topic `/can/<log name>`: one message per frame (`id`, `extended`, `dlc`, `data` as a
  list of bytes, `direction` rx/tx, `remote`, `error_frame`), its log time the frame's
  wall-clock time put on the run's time axis through the pacer's `start_unix_s` in
  `summary.json` (`time_s` the same in seconds; frames of the set-up, before the start, have a
  negative `time_s` and log time 0).
- Recorded Binary ports are left out (a note; they stay in `ticks.arrows`).
- The 3D scene, in Foxglove's own schemas (`twmr.observers.mcap_scene`): `/tf`, the vehicle of
  each recorded pose whose block describes it, and the recorded paths.
- A `twmr.columns` metadata record holds the recorded column names and units in their order, so
  `read` gives back the columns of `result.arrows` exactly (JSON numbers round-trip float64).
"""
from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from twmr.core.jsonvalues import NON_FINITE, number
from twmr.observers.mcap_scene import add_scene
from twmr.observers.writers import ResultFormat

_ELEMENT = re.compile(r"^(?P<port>.+)\[(?P<index>\d+)\]$")
METADATA = "twmr.columns"
#: the `kind` metadata of the 3D scene's channels
SCENE = "scene"
#: the `kind` metadata of a frame log's channel
FRAMES = "can_frames"


def _split(column: str) -> tuple[str, str, int | None]:
    """'robot.plant.pose[2]' -> ('robot.plant', 'pose', 1); 'ctrl.k' -> ('ctrl', 'k', None)."""
    owner, _, port = column.rpartition(".")
    match = _ELEMENT.match(port)
    if match:
        return owner, match["port"], int(match["index"]) - 1
    return owner, port, None


def _value(v: Any) -> float:
    return NON_FINITE[v] if isinstance(v, str) else float(v)


@dataclass(frozen=True)
class ComponentChannel:
    """One component's channel: its topic, the JSON Schema of its messages, and per port the
    (column index, element index or None) it is read from."""

    owner: str
    topic: str
    schema: dict[str, Any]
    ports: dict[str, list[tuple[int, int | None]]]

    def message(self, row: np.ndarray) -> dict[str, Any]:
        """The message of one recorded row (time first): `time_s` and each port's value."""
        message: dict[str, Any] = {"time_s": float(row[0])}
        for port, elements in self.ports.items():
            sample = [number(float(row[j])) for j, _ in elements]
            message[port] = sample[0] if elements[0][1] is None else sample
        return message


def component_channels(columns: list[str], units: list[str]) -> list[ComponentChannel]:
    """The channels of a result's columns (time first), one per component (module docstring);
    shared by the MCAP file and the live Foxglove server."""
    # component -> port -> [(column index, element index or None)]
    layout: dict[str, dict[str, list[tuple[int, int | None]]]] = {}
    unit_of: dict[tuple[str, str], str] = {}
    for j, column in enumerate(columns[1:], start=1):
        owner, port, index = _split(column)
        layout.setdefault(owner, {}).setdefault(port, []).append((j, index))
        unit_of.setdefault((owner, port), units[j])
    for ports in layout.values():  # a vector not recorded whole: its elements one by one
        for port, elements in list(ports.items()):
            if elements[0][1] is not None and [i for _, i in elements] != list(
                    range(len(elements))):
                del ports[port]
                ports.update({f"{port}[{(i or 0) + 1}]": [(j, None)] for j, i in elements})
    a_number = {"type": ["number", "string"], "description": "a number; non-finite values "
              "are the strings NaN, Infinity, -Infinity"}
    channels = []
    for owner, ports in layout.items():
        properties: dict[str, Any] = {"time_s": {"type": "number", "unit": "s",
                                                 "description": "simulated time [s]"}}
        for port, elements in ports.items():
            unit = unit_of[(owner, _ELEMENT.sub(r"\g<port>", port))]
            text = f"{owner}.{port}" + (f" [{unit}]" if unit else "")
            if elements[0][1] is None:
                properties[port] = {**a_number, "unit": unit, "description": text}
            else:
                properties[port] = {"type": "array", "items": a_number, "unit": unit,
                                    "description": text}
        schema = {"title": owner, "type": "object", "properties": properties}
        channels.append(ComponentChannel(owner, f"/{owner.replace('.', '/')}", schema, ports))
    return channels


def _add_frame_logs(writer: Any, folder: Path, start: float) -> None:
    """A channel per frame log in `folder` that a `twmr.frame_logs` reader takes (by its
    suffix; module docstring); `start` [s] is the run's start."""
    from twmr.registry import FRAME_LOGS, plugin, plugins

    readers = plugins(FRAME_LOGS)
    logs = sorted(p for p in folder.iterdir()
                  if p.suffix.lower()[1:] in readers and not p.name.startswith("."))
    if not logs:
        return
    summary = folder / "summary.json"
    pacing = json.loads(summary.read_text()).get("pacing", {}) if summary.exists() else {}
    epoch = pacing.get("start_unix_s")
    schemas: dict[str, int] = {}
    for log in logs:
        schema, messages = plugin(FRAME_LOGS, log.suffix.lower()[1:], "frame log reader")(log)
        text = json.dumps(schema)
        if text not in schemas:
            schemas[text] = writer.register_schema(str(schema.get("title", "frame")),
                                                   "jsonschema", text.encode())
        channel = writer.register_channel(f"/can/{log.stem}", "json", schemas[text],
                                          {"kind": FRAMES, "file": log.name})
        zero = float(epoch) if isinstance(epoch, int | float) else \
            (messages[0][0] if messages else 0.0)
        for sequence, (wall, fields) in enumerate(messages):
            t = start + wall - zero
            stamp = max(0, log_time_ns(t))
            writer.add_message(channel, log_time=stamp, publish_time=stamp, sequence=sequence,
                               data=json.dumps({"time_s": t, **fields}).encode())


def _ports(folder: Path) -> dict[str, Any]:
    """The recorded ports' descriptions of the run in `folder` (its summary), {} without one."""
    try:
        summary = json.loads((folder / "summary.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    ports = summary.get("ports") if isinstance(summary, dict) else None
    return ports if isinstance(ports, dict) else {}


def log_time_ns(t: float) -> int:
    """A simulated time [s] as the integer nanoseconds of a log time."""
    return round(t * 1e9)


class Mcap(ResultFormat):
    """`result.mcap`: one JSON channel per component (see the module's docstring)."""

    suffix = ".mcap"

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        from mcap.writer import Writer

        with open(path, "wb") as stream:
            writer = Writer(stream)
            writer.start(profile="", library="twmr-cosim")
            writer.add_metadata(METADATA, {"columns": json.dumps(columns),
                                           "units": json.dumps(units)})
            channels = []
            for channel in component_channels(columns, units):
                schema_id = writer.register_schema(channel.owner, "jsonschema",
                                                   json.dumps(channel.schema).encode())
                channels.append((writer.register_channel(channel.topic, "json", schema_id,
                                                         {"component": channel.owner}),
                                 channel))
            for sequence, row in enumerate(values):
                stamp = log_time_ns(float(row[0]))
                for channel_id, channel in channels:
                    writer.add_message(channel_id, log_time=stamp, publish_time=stamp,
                                       sequence=sequence,
                                       data=json.dumps(channel.message(row)).encode())
            _add_frame_logs(writer, path.parent, float(values[0, 0]) if len(values) else 0.0)
            add_scene(writer, columns, units, values, _ports(path.parent))
            writer.finish()
        return []

    def read(self, path: Path) -> tuple[list[str], list[str], np.ndarray]:
        from mcap.reader import make_reader

        with open(path, "rb") as stream:
            reader = make_reader(stream)
            meta = next((m for m in reader.iter_metadata() if m.name == METADATA), None)
            if meta is None and reader.get_header().profile == "ros2":
                raise ValueError(f"{path}: a ROS 2 bag (--format rosbag), an export for ROS 2 "
                                 f"tools: read the run's signals from its result.arrows")
            if meta is None:
                raise ValueError(f"{path}: no '{METADATA}' metadata record: not an MCAP file "
                                 f"written by twmr")
            columns, units = json.loads(meta.metadata["columns"]), json.loads(
                meta.metadata["units"])
            where = {c: j for j, c in enumerate(columns)}
            rows: dict[int, np.ndarray] = {}
            for _schema, channel, message in reader.iter_messages(log_time_order=False):
                if channel.metadata.get("kind") in (FRAMES, SCENE):
                    continue
                owner = channel.metadata.get("component", channel.topic.lstrip("/"))
                row = rows.setdefault(message.sequence, np.full(len(columns), np.nan))
                fields = json.loads(message.data)
                row[0] = fields.pop("time_s", message.log_time / 1e9)
                for port, value in fields.items():
                    if isinstance(value, list):
                        for i, v in enumerate(value):
                            row[where[f"{owner}.{port}[{i + 1}]"]] = _value(v)
                    else:
                        row[where[f"{owner}.{port}"]] = _value(value)
        values = np.array([rows[k] for k in sorted(rows)]) if rows \
            else np.zeros((0, len(columns)))
        return columns, units, values
