"""`--format rosbag`: the recorded signals as a ROS 2 bag in MCAP, read back with
mcap-ros2-support's decoder (ROS 2's message definitions as the file carries them, not our
code): a pose as PoseStamped, a planar position as PointStamped, vectors as Float64MultiArray,
each row at its simulated time."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import twmr

pytest.importorskip("rosbags", reason="rosbags is in the [ros2] extra")
decoder = pytest.importorskip("mcap_ros2.decoder", reason="mcap-ros2-support is in [test]")
pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[2]


def test_a_ros2_tool_reads_the_recorded_rows(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    result = twmr.simulate(twmr.load(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                                     ["experiment.stop=1"]), tmp_path / "run",
                           formats=("rosbag",))
    with open(tmp_path / "run" / "result.ros2.mcap", "rb") as stream:
        reader = make_reader(stream, decoder_factories=[decoder.DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        got: dict[str, list] = {}
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            got.setdefault(channel.topic, []).append((schema.name, message.log_time, decoded))
    assert set(got) == {"/ref/position", "/plant/pose", "/plant/wheel_speed", "/ctrl/torque",
                        "/motor/torque", "/ctrl/error", "/ctrl/d_hat", "/plant/slip_rate",
                        "/plant/disturbance"}
    pose = got["/plant/pose"]
    assert {name for name, _, _ in pose} == {"geometry_msgs/msg/PoseStamped"}
    assert [t for _, t, _ in pose] == [round(t * 1e9) for t in result.time]
    np.testing.assert_array_equal([m.pose.position.x for _, _, m in pose], result["plant.pose[1]"])
    yaw = [2 * math.atan2(m.pose.orientation.z, m.pose.orientation.w) for _, _, m in pose]
    np.testing.assert_allclose(np.unwrap(yaw), np.unwrap(result["plant.pose[3]"]), atol=1e-12)
    ref = got["/ref/position"]
    assert {name for name, _, _ in ref} == {"geometry_msgs/msg/PointStamped"}
    np.testing.assert_array_equal([m.point.y for _, _, m in ref], result["ref.position[2]"])
    torque = got["/ctrl/torque"]
    assert {name for name, _, _ in torque} == {"std_msgs/msg/Float64MultiArray"}
    np.testing.assert_array_equal([list(m.data) for _, _, m in torque],
                                  np.stack([result["ctrl.torque[1]"], result["ctrl.torque[2]"]],
                                           axis=1))
