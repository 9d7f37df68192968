"""`--format rosbag` (`result.ros2.mcap`): the recorded signals as a ROS 2 bag in MCAP (profile
`ros2`, schemas `ros2msg` with the full message definitions, CDR messages from rosbags), so
rosbag2, Foxglove and every ROS 2 tool read them with their own types:

- a recorded pose (m, m, rad): `geometry_msgs/msg/PoseStamped` in frame `world` (the heading a
  rotation about z);
- a recorded planar position (m, m, named like a position): `geometry_msgs/msg/PointStamped`;
- any other scalar port: `std_msgs/msg/Float64`; a vector port: `std_msgs/msg/Float64MultiArray`.

Topic `/<component>/<port>` (a subsystem's `robot.plant` is `/robot/plant/...`; characters a
ROS 2 name cannot hold become `_`); one message per recorded row, log time the simulated time in
nanoseconds. It is an export only: read the signals back from `result.arrows`.
"""
from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from twmr.observers.writers import ResultFormat

WORLD = "world"


def topic_of(port: str) -> str:
    """'robot.plant.pose' -> '/robot/plant/pose', each token a valid ROS 2 name."""
    tokens = [re.sub(r"[^A-Za-z0-9_]", "_", t) for t in port.split(".")]
    return "/" + "/".join(t if t and not t[0].isdigit() else f"_{t}" for t in tokens)


class RosBag(ResultFormat):
    """`result.ros2.mcap`: the recorded ports as ROS 2 messages (the module's docstring)."""

    suffix = ".ros2.mcap"

    def write(self, path: Path, columns: list[str], units: list[str],
              values: np.ndarray) -> list[Path]:
        from mcap.writer import Writer

        from twmr.plots import group_ports, is_planar_position
        from twmr.ros2.messages import typestore

        store = typestore()
        unit = dict(zip(columns, units, strict=True))
        where = {c: j for j, c in enumerate(columns)}
        with open(path, "wb") as stream:
            writer = Writer(stream)
            writer.start(profile="ros2", library="twmr-cosim")
            schemas: dict[str, int] = {}
            channels: list[tuple[int, str, list[int]]] = []
            for port, cols in group_ports(columns).items():
                planar = is_planar_position(port, [unit[c] for c in cols])
                kind = ("geometry_msgs/msg/PoseStamped" if planar and len(cols) == 3 else
                        "geometry_msgs/msg/PointStamped" if planar else
                        "std_msgs/msg/Float64" if len(cols) == 1 and "[" not in cols[0] else
                        "std_msgs/msg/Float64MultiArray")
                if kind not in schemas:
                    text, _ = store.generate_msgdef(kind, ros_version=2)
                    schemas[kind] = writer.register_schema(kind, "ros2msg", text.encode())
                channel = writer.register_channel(topic_of(port), "cdr", schemas[kind],
                                                  {"unit": ", ".join(unit[c] for c in cols)})
                channels.append((channel, kind, [where[c] for c in cols]))
            for sequence, row in enumerate(values):
                stamp = round(float(row[0]) * 1e9)
                for channel, kind, at in channels:
                    message = _message(store, kind, stamp, row[at])
                    writer.add_message(channel, log_time=stamp, publish_time=stamp,
                                       sequence=sequence,
                                       data=bytes(store.serialize_cdr(message, kind)))
            writer.finish()
        return []


def _message(store: Any, kind: str, stamp: int, values: np.ndarray) -> Any:
    """The rosbags message of `kind` holding `values` at `stamp` [ns]."""
    t = store.types
    header = t["std_msgs/msg/Header"](
        stamp=t["builtin_interfaces/msg/Time"](sec=stamp // 1_000_000_000,
                                               nanosec=stamp % 1_000_000_000),
        frame_id=WORLD)
    if kind == "geometry_msgs/msg/PoseStamped":
        x, y, heading = (float(v) for v in values)
        pose = t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=x, y=y, z=0.0),
            orientation=t["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=math.sin(heading / 2), w=math.cos(heading / 2)))
        return t[kind](header=header, pose=pose)
    if kind == "geometry_msgs/msg/PointStamped":
        return t[kind](header=header, point=t["geometry_msgs/msg/Point"](
            x=float(values[0]), y=float(values[1]), z=0.0))
    if kind == "std_msgs/msg/Float64":
        return t[kind](data=float(values[0]))
    layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    return t[kind](layout=layout, data=np.asarray(values, dtype=np.float64))
