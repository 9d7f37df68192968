"""The 3D scene in result.mcap, decoded with mcap-protobuf-support (Foxglove's protobuf schemas
as the file carries them, not our code): the robot's frame at every recorded pose, its vehicle
from the plant's own dimensions, the reference path as recorded."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import twmr

pytest.importorskip("foxglove", reason="the Foxglove SDK is in the [foxglove] extra")
decoder = pytest.importorskip("mcap_protobuf.decoder", reason="mcap-protobuf-support is in "
                              "the [test] extra")
pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[2]


def test_the_robot_moves_in_the_scene_as_recorded(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    result = twmr.simulate(twmr.load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                                     ["experiment.stop=2", "plant.b=0.6", "plant.r=0.2"]),
                           tmp_path / "run", formats=("mcap",))
    with open(tmp_path / "run" / "result.mcap", "rb") as stream:
        reader = make_reader(stream, decoder_factories=[decoder.DecoderFactory()])
        got: dict[str, list] = {}
        for schema, channel, _, message in reader.iter_decoded_messages(
                topics=["/tf", "/scene/plant", "/scene/paths", "/scene/plant/vectors",
                        "/poses/plant.pose"]):
            got.setdefault(channel.topic, []).append((schema.name, message))
    tf = got["/tf"]
    assert {name for name, _ in tf} == {"foxglove.FrameTransform"}
    assert len(tf) == len(result)
    x = [m.translation.x for _, m in tf]
    y = [m.translation.y for _, m in tf]
    yaw = [2 * math.atan2(m.rotation.z, m.rotation.w) for _, m in tf]
    np.testing.assert_allclose(x, result["plant.pose[1]"], atol=1e-12)
    np.testing.assert_allclose(y, result["plant.pose[2]"], atol=1e-12)
    np.testing.assert_allclose(np.unwrap(yaw), np.unwrap(result["plant.pose[3]"]), atol=1e-9)
    assert {(m.parent_frame_id, m.child_frame_id) for _, m in tf} == {("world", "plant")}
    (name, scene), = got["/scene/plant"]
    assert name == "foxglove.SceneUpdate"
    vehicle, = scene.entities
    assert vehicle.frame_id == "plant" and vehicle.frame_locked
    wheels = sorted((c.pose.position.y, c.size.x) for c in vehicle.cylinders)
    assert wheels == [(-0.6, 0.4), (0.6, 0.4)]  # at +-b, diameter 2 r, as set
    (_, paths), = got["/scene/paths"]
    lines = {e.id: e.lines[0].points for e in paths.entities}
    reference = lines["path ref.position"]
    np.testing.assert_allclose([p.x for p in reference], result["ref.position[1]"], atol=1e-12)
    np.testing.assert_allclose([p.y for p in reference], result["ref.position[2]"], atol=1e-12)
    # the plant's recorded slip velocities and disturbance torques as arrows on the robot: at
    # each sample, each arrow as long as its value times its scale, pointing along its axis
    # in the robot's frame (reversed for a negative value)
    vectors = got["/scene/plant/vectors"]
    assert len(vectors) == len(result)
    drawn = {"slip mu_R'": ("plant.slip_rate[1]", -0.6, 0.25, (1, 0)),
             "slip delta'": ("plant.slip_rate[3]", 0.0, 0.25, (0, 1)),
             "tau_d L": ("plant.disturbance[2]", 0.6, 0.2, (1, 0))}
    for k in (0, len(result) // 2, len(result) - 1):
        arrows = {e.id: e.arrows[0] for _, m in [vectors[k]] for e in m.entities}
        for label, (column, y_at, scale, along) in drawn.items():
            a, value = arrows[f"plant {label}"], float(result[column][k])
            assert a.pose.position.y == pytest.approx(y_at)
            assert a.shaft_length + a.head_length == pytest.approx(abs(value) * scale)
            q = a.pose.orientation      # the arrow's +x axis rotated by q
            head = (1 - 2 * (q.y ** 2 + q.z ** 2), 2 * (q.x * q.y + q.w * q.z))
            sign = 1.0 if value >= 0 else -1.0
            assert head == pytest.approx((sign * along[0], sign * along[1]), abs=1e-12)
    # the robot's path so far with its headings (foxglove.PosesInFrame) at 0, 1 and 2 s
    poses = got["/poses/plant.pose"]
    assert {name for name, _ in poses} == {"foxglove.PosesInFrame"}
    assert [m.timestamp.ToNanoseconds() * 1e-9 for _, m in poses] == pytest.approx(
        [0.0, 1.0, 2.0])
    last = poses[-1][1].poses
    assert len(last) == len(result)  # 201 rows: under the 500 kept
    np.testing.assert_allclose([q.position.x for q in last], result["plant.pose[1]"],
                               atol=1e-12)
    heading = np.array([2 * math.atan2(q.orientation.z, q.orientation.w) for q in last])
    turned = heading - np.asarray(result["plant.pose[3]"])  # the same rotation: 2 pi k apart
    np.testing.assert_allclose(np.cos(turned), 1.0, atol=1e-12)
    assert len(poses[1][1].poses) == 101  # to t = 1 s
    # the result read back from the MCAP is the recorded one: the scene is beside it
    back = twmr.read_result(tmp_path / "run" / "result.mcap")
    np.testing.assert_array_equal(back.values, result.values)
