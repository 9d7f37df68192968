"""The 3D scene of a result in MCAP, in Foxglove's well-known schemas (protobuf, through the
Foxglove SDK: the extra `foxglove`), so Foxglove's 3D panel draws the robot:

- `/tf` (`foxglove.FrameTransform`): for each recorded planar pose whose block describes its
  vehicle (`Component.bodies`: the paper's plant does), the frame `<component>` in `world` at
  every sample (x, y, 0; the heading as a rotation about z);
- `/scene/<component>` (`foxglove.SceneUpdate`, once, at the first sample): the vehicle in its
  frame — the platform as a box, each wheel as a cylinder, a caster as a sphere;
- `/scene/<component>/vectors` (`foxglove.SceneUpdate`, at every sample): the vehicle's
  recorded vectors (`Component.vectors`: the paper plant's slip velocities and disturbance
  torques) as labelled arrows in its frame;
- `/scene/paths` (`foxglove.SceneUpdate`, once): each recorded planar position (a reference
  path) and each pose's path as a line in `world`;
- `/poses/<port>` (`foxglove.PosesInFrame`): each recorded planar pose's path so far, with its
  headings, every `POSES_EVERY` s of simulated time and at the end.
"""
from __future__ import annotations

import logging
import math
from typing import Any, NamedTuple

import numpy as np

log = logging.getLogger("twmr.run")

#: the frame every path and vehicle frame is in
WORLD = "world"
#: simulated time between the messages of a pose's path so far [s], and their most poses
POSES_EVERY = 1.0
POSES_MOST = 500


def _planar(columns: list[str], units: list[str]) -> dict[str, list[int]]:
    """Port -> the column indices of its x, y (and heading) of each planar position or pose."""
    from twmr.plots import group_ports, is_planar_position

    unit = dict(zip(columns, units, strict=True))
    where = {c: j for j, c in enumerate(columns)}
    return {port: [where[c] for c in cols] for port, cols in group_ports(columns).items()
            if is_planar_position(port, [unit[c] for c in cols])}


def add_scene(writer: Any, columns: list[str], units: list[str], values: np.ndarray,
              ports: dict[str, Any]) -> list[str]:
    """Add the scene's channels and messages to an MCAP `writer`; the topics written ([] when
    the Foxglove SDK is missing, with a note)."""
    try:
        import foxglove.messages as fm
    except ImportError:
        log.info("note: result.mcap has no 3D scene channels: they need the Foxglove SDK "
                 "(pip install 'twmr-cosim[foxglove]')")
        return []
    planar = _planar(columns, units)
    if not planar or not len(values):
        return []

    def channel(topic: str, kind: Any) -> int:
        schema = kind.get_schema()
        schema_id = writer.register_schema(schema.name, schema.encoding, schema.data)
        return int(writer.register_channel(topic, "protobuf", schema_id, {"kind": "scene"}))

    t = values[:, 0]
    stamps = [round(float(x) * 1e9) for x in t]
    topics: list[str] = []
    paths = channel("/scene/paths", fm.SceneUpdate)
    topics.append("/scene/paths")
    lines = []
    for k, (port, cols) in enumerate(planar.items()):
        xy = values[:, cols[:2]]
        points = [fm.Point3(x=float(x), y=float(y), z=0.0) for x, y in xy[:: max(1, len(xy)
                                                                                 // 5000)]]
        colour = _colour(k)
        lines.append(fm.SceneEntity(
            frame_id=WORLD, id=f"path {port}", frame_locked=False,
            lines=[fm.LinePrimitive(type=fm.LinePrimitiveLineType.LineStrip, thickness=2.0,
                                    scale_invariant=True, points=points, color=colour)]))
    writer.add_message(paths, log_time=stamps[0], publish_time=stamps[0], sequence=0,
                       data=fm.SceneUpdate(entities=lines).encode())
    for port, cols in planar.items():
        if len(cols) == 3:
            poses = channel(f"/poses/{port}", fm.PosesInFrame)
            topics.append(f"/poses/{port}")
            for sequence, (k, stamp) in enumerate(path_samples(t)):
                writer.add_message(poses, log_time=stamp, publish_time=stamp, sequence=sequence,
                                   data=poses_so_far(values[: k + 1, cols], stamp).encode())
    moving = vehicles(columns, units, ports)
    if not moving:
        return topics
    tf = channel("/tf", fm.FrameTransform)
    topics.append("/tf")
    for frame, cols, body, drawn in moving:
        scene = channel(f"/scene/{frame}", fm.SceneUpdate)
        topics.append(f"/scene/{frame}")
        writer.add_message(scene, log_time=stamps[0], publish_time=stamps[0], sequence=0,
                           data=fm.SceneUpdate(entities=[vehicle(frame, body)]).encode())
        for sequence, (stamp, row) in enumerate(zip(stamps, values[:, cols], strict=True)):
            writer.add_message(tf, log_time=stamp, publish_time=stamp, sequence=sequence,
                               data=transform(frame, stamp, *row).encode())
        if drawn:
            arrows = channel(f"/scene/{frame}/vectors", fm.SceneUpdate)
            topics.append(f"/scene/{frame}/vectors")
            for sequence, (stamp, row) in enumerate(zip(stamps, values, strict=True)):
                writer.add_message(arrows, log_time=stamp, publish_time=stamp,
                                   sequence=sequence, data=vector_update(frame, drawn, row)
                                   .encode())
    return topics


def arrow(frame: str, vector: dict[str, Any], value: float) -> Any:
    """A vector of the vehicle (`Component.vectors`) at `value` as a `foxglove.SceneEntity`
    in the vehicle's frame: an arrow from `at` along `along` (reversed for a negative value),
    `scale` |value| long, in its colour, labelled with its value."""
    import foxglove.messages as fm

    length = abs(vector["scale"] * value)
    d = [c * (1.0 if value >= 0 else -1.0) for c in vector["along"]]
    w, qx, qy, qz = 1.0 + d[0], 0.0, -d[2], d[1]     # the rotation taking +x to d
    norm = math.sqrt(w * w + qx * qx + qy * qy + qz * qz)
    w, qx, qy, qz = (w / norm, qx / norm, qy / norm, qz / norm) if norm > 1e-9 else (
        0.0, 0.0, 0.0, 1.0)
    at = fm.Vector3(x=vector["at"][0], y=vector["at"][1], z=vector["at"][2])
    r, g, b = (int(vector["colour"][k:k + 2], 16) / 255 for k in (1, 3, 5))
    colour = fm.Color(r=r, g=g, b=b, a=1.0)
    head = min(0.3 * length, 0.08)
    return fm.SceneEntity(
        frame_id=frame, id=f"{frame} {vector['label']}", frame_locked=True,
        arrows=[fm.ArrowPrimitive(
            pose=fm.Pose(position=at, orientation=fm.Quaternion(x=qx, y=qy, z=qz, w=w)),
            shaft_length=length - head, shaft_diameter=0.02, head_length=head,
            head_diameter=0.06, color=colour)],
        texts=[fm.TextPrimitive(
            pose=fm.Pose(position=at, orientation=fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
            billboard=True, font_size=12.0, scale_invariant=True, color=colour,
            text=f"{vector['label']} {value:.3g}")])


def path_samples(t: np.ndarray) -> list[tuple[int, int]]:
    """(row, stamp [ns]) at which a pose's path so far is written: the first row, the first at
    or after each further `POSES_EVERY` s, and the last."""
    marks = np.floor((t - t[0]) / POSES_EVERY + 1e-9)
    rows = [0, *np.flatnonzero(np.diff(marks) > 0) + 1, len(t) - 1]
    return [(int(k), round(float(t[k]) * 1e9)) for k in dict.fromkeys(rows)]


def poses_so_far(xyh: np.ndarray, stamp: int) -> Any:
    """The `foxglove.PosesInFrame` of a planar pose's path to `stamp` [ns] in `world`, at most
    `POSES_MOST` poses (thinned by a stride, the last kept)."""
    import foxglove.messages as fm

    stride = max(1, -(-len(xyh) // POSES_MOST))
    kept = xyh[::-1][::stride][::-1]
    return fm.PosesInFrame(
        timestamp=fm.Timestamp(sec=stamp // 1_000_000_000, nsec=stamp % 1_000_000_000),
        frame_id=WORLD,
        poses=[fm.Pose(position=fm.Vector3(x=float(x), y=float(y), z=0.0),
                       orientation=fm.Quaternion(x=0.0, y=0.0, z=math.sin(float(h) / 2),
                                                 w=math.cos(float(h) / 2)))
               for x, y, h in kept])


class Vehicle(NamedTuple):
    """A recorded pose whose block describes its vehicle (`Component.bodies`)."""

    frame: str  #: the component's name
    cols: list[int]  #: the column indices of x, y and heading
    body: dict[str, float]
    vectors: list[tuple[dict[str, Any], int]]  #: each recorded vector and its column index


def vehicles(columns: list[str], units: list[str], ports: dict[str, Any]) -> list[Vehicle]:
    """Each recorded pose whose block describes its vehicle, with its recorded vectors."""
    where = {c: j for j, c in enumerate(columns)}
    return [Vehicle(port.rpartition(".")[0] or port, cols, ports[port]["body"],
                    [(v, where[v["column"]]) for v in ports[port].get("vectors", [])
                     if v["column"] in where])
            for port, cols in _planar(columns, units).items()
            if len(cols) == 3 and (ports.get(port) or {}).get("body")]


def vector_update(frame: str, drawn: list[tuple[dict[str, Any], int]], row: np.ndarray
                  ) -> Any:
    """The `foxglove.SceneUpdate` of the vehicle's vectors at a recorded row."""
    import foxglove.messages as fm

    return fm.SceneUpdate(entities=[arrow(frame, v, float(row[j])) for v, j in drawn])


def transform(frame: str, stamp: int, x: float, y: float, heading: float) -> Any:
    """The frame's `foxglove.FrameTransform` in `world` at `stamp` [ns]: (x, y, 0), the
    heading a rotation about z."""
    import foxglove.messages as fm

    return fm.FrameTransform(
        timestamp=fm.Timestamp(sec=stamp // 1_000_000_000, nsec=stamp % 1_000_000_000),
        parent_frame_id=WORLD, child_frame_id=frame,
        translation=fm.Vector3(x=float(x), y=float(y), z=0.0),
        rotation=fm.Quaternion(x=0.0, y=0.0, z=math.sin(float(heading) / 2),
                               w=math.cos(float(heading) / 2)))


def _colour(k: int) -> Any:
    import foxglove.messages as fm

    palette = ((0.0, 0.447, 0.698), (0.835, 0.369, 0.0), (0.0, 0.620, 0.451),
               (0.8, 0.475, 0.655))
    r, g, b = palette[k % len(palette)]
    return fm.Color(r=r, g=g, b=b, a=1.0)


def vehicle(frame: str, body: dict[str, float]) -> Any:
    """The vehicle as a `foxglove.SceneEntity` in its own frame: x ahead, y to the left, z up,
    the pose's point at 0."""
    import foxglove.messages as fm

    r, b = body["wheel_radius"], body["half_track"]
    upright = fm.Quaternion(x=math.sqrt(0.5), y=0.0, z=0.0, w=math.sqrt(0.5))  # axis along y
    level = fm.Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
    grey = fm.Color(r=0.55, g=0.55, b=0.6, a=0.9)
    black = fm.Color(r=0.1, g=0.1, b=0.1, a=1.0)
    wheels = [fm.CylinderPrimitive(
        pose=fm.Pose(position=fm.Vector3(x=0.0, y=side * b, z=r), orientation=upright),
        size=fm.Vector3(x=2 * r, y=2 * r, z=0.2 * r), bottom_scale=1.0, top_scale=1.0,
        color=black) for side in (-1.0, 1.0)]
    platform = fm.CubePrimitive(
        pose=fm.Pose(position=fm.Vector3(x=body["ahead"], y=0.0, z=r + body["height"] / 2),
                     orientation=level),
        size=fm.Vector3(x=body["length"], y=body["width"], z=body["height"]), color=grey)
    caster = fm.SpherePrimitive(
        pose=fm.Pose(position=fm.Vector3(x=body["ahead"] + body["length"] / 2, y=0.0,
                                         z=0.25 * r), orientation=level),
        size=fm.Vector3(x=0.5 * r, y=0.5 * r, z=0.5 * r), color=black)
    return fm.SceneEntity(frame_id=frame, id=f"vehicle {frame}", frame_locked=True,
                          cubes=[platform], cylinders=wheels, spheres=[caster])
