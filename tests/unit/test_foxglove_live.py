"""The live Foxglove server (`twmr run --foxglove`): a client speaking Foxglove's WebSocket
protocol (subprotocol foxglove.sdk.v1) is advertised one channel per component with the MCAP
export's JSON Schema, and receives each recorded row on it: log time in ns, JSON fields equal to
the row (non-finite values as strings)."""
from __future__ import annotations

import json
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from websockets.sync.client import connect

pytest.importorskip("foxglove")

from twmr.observers.base import RunStart
from twmr.observers.foxglove_live import FoxgloveServer

RUN = RunStart(("time", "robot.plant.pose[1]", "robot.plant.pose[2]", "g.y"), ("s", "m", "m", ""),
               1e-3, 10)
ROWS = np.array([[0.0, 1.0, 2.0, 3.0], [0.001, 1.5, 2.5, np.inf], [0.002, -1.0, 0.25, 7.0]])


def _advertised(ws) -> list[dict]:
    while True:
        message = json.loads(ws.recv(timeout=10))
        if message["op"] == "advertise":
            return message["channels"]


def test_a_client_gets_every_row_on_its_components_channel() -> None:
    server = FoxgloveServer("0")
    url = server.start()
    assert url.startswith("ws://127.0.0.1:")
    try:
        server.started(RUN)
        with connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:
            channels = {c["topic"]: c for c in _advertised(ws)}
            assert set(channels) == {"/robot/plant", "/g"}
            schema = json.loads(channels["/robot/plant"]["schema"])
            assert schema["properties"]["pose"]["unit"] == "m"
            assert channels["/g"]["encoding"] == "json"
            topic_of = {i: topic for i, topic in enumerate(channels)}
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[t]["id"]} for i, t in topic_of.items()]}))
            # the subscription is the server's once it answers a ping sent after it
            ws.ping().wait(10)
            server.rows(ROWS, len(ROWS))
            got: dict[str, list[tuple[int, dict]]] = {t: [] for t in channels}
            for _ in range(2 * len(ROWS)):
                frame = ws.recv(timeout=10)
                assert isinstance(frame, bytes) and frame[0] == 0x01  # message data
                sub, stamp = struct.unpack_from("<IQ", frame, 1)
                got[topic_of[sub]].append((stamp, json.loads(frame[13:])))
    finally:
        server.close()
    assert [s for s, _ in got["/robot/plant"]] == [0, 1_000_000, 2_000_000]
    assert [m["pose"] for _, m in got["/robot/plant"]] == [[1.0, 2.0], [1.5, 2.5], [-1.0, 0.25]]
    assert [m["y"] for _, m in got["/g"]] == [3.0, "Infinity", 7.0]
    assert [m["time_s"] for _, m in got["/g"]] == [0.0, 0.001, 0.002]


def test_twmr_run_foxglove_serves_on_loopback_and_ends_cleanly(tmp_path) -> None:
    fixture = Path(__file__).parent.parent / "fixtures" / "scenarios" / "loop.yaml"
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(fixture), "--foxglove",
                           "0", "--out", str(tmp_path / "run"), "-q"],
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr
    assert "foxglove: open connection ws://127.0.0.1:" in done.stderr


def test_a_bad_address_is_one_line_naming_the_option() -> None:
    from twmr.observers.live import LiveAddressError

    with pytest.raises(LiveAddressError, match=r"--foxglove 'x:y'.*Fix: e\.g\. --foxglove 8765"):
        FoxgloveServer("x:y")


def _decoder(channel: dict):
    """A decoder of the protobuf messages of an advertised channel, built from the schema it
    carries (a FileDescriptorSet), with google.protobuf: not the SDK that encoded them."""
    import base64

    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    files = descriptor_pb2.FileDescriptorSet.FromString(base64.b64decode(channel["schema"]))
    pool = descriptor_pool.DescriptorPool()
    for proto in files.file:
        pool.Add(proto)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(channel["schemaName"]))


def test_a_client_gets_the_robots_frame_and_vehicle() -> None:
    pytest.importorskip("google.protobuf")
    body = {"wheel_radius": 0.15, "half_track": 0.75, "length": 0.6, "width": 1.3,
            "height": 0.075, "ahead": 0.15}
    slip = {"label": "slip delta'", "column": "plant.slip_rate[3]", "at": [0.0, 0.0, 0.0],
            "along": [0.0, 1.0, 0.0], "scale": 0.25, "colour": "#CC00CC"}
    run = RunStart(("time", "plant.pose[1]", "plant.pose[2]", "plant.pose[3]",
                    "plant.slip_rate[3]"), ("s", "m", "m", "rad", "m/s"), 1e-3, 10,
                   metadata={"ports": {"plant.pose": {"body": body, "vectors": [slip]}}})
    rows = np.array([[0.0, 0.5, 0.0, -0.785, 0.4], [0.001, 0.6, 0.1, -0.5, -0.8]])
    server = FoxgloveServer("0")
    url = server.start()
    try:
        server.started(run)
        with connect(url, subprotocols=["foxglove.sdk.v1"]) as ws:
            channels = {c["topic"]: c for c in _advertised(ws)}
            assert {"/tf", "/scene/plant"} <= set(channels)
            assert channels["/tf"]["schemaName"] == "foxglove.FrameTransform"
            assert channels["/tf"]["encoding"] == "protobuf"
            wanted = ["/tf", "/scene/plant", "/scene/plant/vectors"]
            ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": channels[t]["id"]} for i, t in enumerate(wanted)]}))
            ws.ping().wait(10)
            server.rows(rows, len(rows))
            got: dict[str, list] = {t: [] for t in wanted}
            for _ in range(2 * len(rows) + 1):
                frame = ws.recv(timeout=10)
                sub, _stamp = struct.unpack_from("<IQ", frame, 1)
                topic = wanted[sub]
                got[topic].append(_decoder(channels[topic]).FromString(frame[13:]))
    finally:
        server.close()
    tf = got["/tf"]
    assert [(m.translation.x, m.translation.y) for m in tf] == [(0.5, 0.0), (0.6, 0.1)]
    assert [2 * np.arctan2(m.rotation.z, m.rotation.w) for m in tf] == pytest.approx(
        [-0.785, -0.5])
    (scene,) = got["/scene/plant"]
    wheels = sorted(c.pose.position.y for c in scene.entities[0].cylinders)
    assert wheels == [-0.75, 0.75]
    arrows = [m.entities[0].arrows[0] for m in got["/scene/plant/vectors"]]
    assert [a.shaft_length + a.head_length for a in arrows] == pytest.approx([0.1, 0.2])
    # along +y for 0.4 m/s, along -y for -0.8: the arrow's +x axis turned by +-90 deg about z
    assert [2 * np.arctan2(a.pose.orientation.z, a.pose.orientation.w) for a in arrows] == \
        pytest.approx([np.pi / 2, -np.pi / 2])
