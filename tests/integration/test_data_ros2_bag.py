"""The `data` block plays a ROS 2 bag: one written by rosbags' own writer (sqlite3 and MCAP
storage, nav_msgs/Odometry and std_msgs/Float64 at wall-clock stamps) gives at each step each
column's last message at or before it, in seconds since the bag's first message; twmr's own
`--format rosbag` export plays back equal to the run's result.arrows; a column that names no
topic, no field or no number is refused naming the bag, the column and the fix."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError

pytest.importorskip("rosbags", reason="rosbags is in the [ros2] extra")
pytestmark = pytest.mark.timeout(300)
T0 = 1_765_000_000_000_000_000  # [ns] a wall-clock start, as a robot's bag has


def write_bag(path: Path, storage: str) -> None:
    """/odom every 20 ms (x = 0.1 k m) and /speed every 10 ms from 5 ms (-0.5 k m/s)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    Odometry, Float64 = store.types["nav_msgs/msg/Odometry"], store.types["std_msgs/msg/Float64"]
    Header, Time = store.types["std_msgs/msg/Header"], store.types["builtin_interfaces/msg/Time"]
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=plugin) as writer:
        odom = writer.add_connection("/odom", Odometry.__msgtype__, typestore=store)
        speed = writer.add_connection("/speed", Float64.__msgtype__, typestore=store)
        messages = []
        for k in range(50):
            stamp = T0 + k * 20_000_000
            pose = store.types["geometry_msgs/msg/PoseWithCovariance"](
                pose=store.types["geometry_msgs/msg/Pose"](
                    position=store.types["geometry_msgs/msg/Point"](x=0.1 * k, y=0.0, z=0.0),
                    orientation=store.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0,
                                                                          z=0.0, w=1.0)),
                covariance=np.zeros(36))
            twist = store.types["geometry_msgs/msg/TwistWithCovariance"](
                twist=store.types["geometry_msgs/msg/Twist"](
                    linear=store.types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    angular=store.types["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)),
                covariance=np.zeros(36))
            msg = Odometry(header=Header(stamp=Time(sec=stamp // 10**9, nanosec=stamp % 10**9),
                                         frame_id="odom"), child_frame_id="base_link",
                           pose=pose, twist=twist)
            messages.append((stamp, odom, store.serialize_cdr(msg, Odometry.__msgtype__)))
        for k in range(100):
            stamp = T0 + 5_000_000 + k * 10_000_000
            messages.append((stamp, speed, store.serialize_cdr(Float64(data=-0.5 * k),
                                                               Float64.__msgtype__)))
        for stamp, connection, data in sorted(messages, key=lambda m: m[0]):
            writer.write(connection, stamp, data)


def scenario(tmp_path: Path, bag: str, columns: str, unit: str = "") -> Path:
    path = tmp_path / "play.yaml"
    path.write_text(f"""
components:
  m: {{kind: data, parameters: {{file: {bag}, interpolation: hold, columns: {columns}{unit}}}}}
experiment: {{stop: 0.9, step: 0.001}}
record: {{signals: [m.y]}}
""")
    return path


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_a_bag_plays_each_columns_last_message(tmp_path: Path, storage: str) -> None:
    write_bag(tmp_path / "bag", storage)
    result = twmr.simulate(twmr.load(scenario(
        tmp_path, "bag", "['/odom.pose.pose.position.x', '/speed.data']", ", unit: m")))
    t = np.asarray(result["time"])
    # both topics seen from 5 ms on (the samples' start): before it the first sample, held
    x = 0.1 * np.floor(np.maximum(t, 0.005) / 0.02 + 1e-9)
    v = -0.5 * np.floor((np.maximum(t, 0.005) - 0.005) / 0.01 + 1e-9)
    np.testing.assert_allclose(result["m.y[1]"], x, rtol=0, atol=1e-12)
    np.testing.assert_allclose(result["m.y[2]"], v, rtol=0, atol=1e-12)


def test_twmrs_own_bag_plays_back_as_its_run(tmp_path: Path) -> None:
    paper = Path(__file__).resolve().parents[2] / "scenarios" / "paper_trajectory1_asmc.yaml"
    run = twmr.simulate(twmr.load(paper, ["experiment.stop=1"]), tmp_path / "run",
                        formats=("rosbag",))
    played = twmr.simulate(twmr.load(scenario(
        tmp_path, str(tmp_path / "run" / "result.ros2.mcap"),
        "['/plant/pose.pose.position.x', '/plant/pose.pose.position.y']", ", unit: m").read_text()
        .replace("stop: 0.9, step: 0.001", "stop: 1.0, step: 0.01")))
    np.testing.assert_array_equal(played["m.y[1]"], run["plant.pose[1]"])
    np.testing.assert_array_equal(played["m.y[2]"], run["plant.pose[2]"])


@pytest.mark.parametrize(("columns", "said"), [
    ("['/odm.pose.pose.position.x']", "names no topic of the bag (did you mean '/odom'?)"),
    ("['/odom.pose.pose.position.q']", "Point has no field 'q' (its fields: x, y, z)"),
    ("['/odom.header.frame_id']", "is a str, not a number"),
    ("['/odom.pose.covariance[40]']", "element 40 does not exist"),
])
def test_a_column_that_cannot_be_played_is_refused(tmp_path: Path, columns: str,
                                                   said: str) -> None:
    write_bag(tmp_path / "bag", "sqlite3")
    with pytest.raises(CosimError, match="Fix:") as caught:
        twmr.load(scenario(tmp_path, "bag", columns))
    assert said in str(caught.value) and "bag" in str(caught.value), str(caught.value)
