"""ROS 2 topics over DDS against a participant we did not write: `tests/ros2_peer.py` (its types
written by hand after ROS 2's IDL, decoding with rosbags' CDR) gets `/clock` and odometry in
lockstep and answers with Twist commands; the commands move the run as the same values from a
table do (the same rows). A peer that stops answering stops the run with a clear message; bad
configuration fails at check."""
from __future__ import annotations

import json
import random
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from twmr.api import load, read_result, simulate
from twmr.core.errors import CosimError, ScenarioError

pytest.importorskip("cyclonedds", reason="cyclonedds is in the [ros2] extra")
pytest.importorskip("rosbags", reason="rosbags is in the [ros2] extra")
pytestmark = pytest.mark.timeout(180)

PEER = Path(__file__).resolve().parents[1] / "ros2_peer.py"
H, STEPS = 0.01, 20


def scenario(domain: int, commands: str = "", timeout: float = 20.0) -> str:
    cmd = commands or (f"cmd: {{kind: ros2_topic, parameters: {{topic: /cmd_vel, message: "
                       f"geometry_msgs/msg/Twist, fields: 'linear.x, angular.z', lockstep: true, "
                       f"timeout: {timeout}, domain_id: {domain}}}}}")
    return f"""
components:
  clock: {{kind: ros2_topic, parameters: {{topic: /clock, message: rosgraph_msgs/msg/Clock,
          direction: publish, domain_id: {domain}}}}}
  {cmd}
  lag: {{kind: first_order, parameters: {{T: 0.05}}}}
  odom: {{kind: ros2_topic, parameters: {{topic: odom, message: nav_msgs/msg/Odometry,
         direction: publish, fields: 'twist.twist.linear.x, pose.pose.position.x',
         constants: 'header.frame_id=odom, child_frame_id=base_link', domain_id: {domain}}}}}
connections:
  - cmd.linear.x -> lag.u
  - lag.y -> odom.twist.twist.linear.x
  - lag.y -> odom.pose.pose.position.x
experiment: {{stop: {STEPS * H}, step: {H}}}
record: {{signals: [cmd.linear.x, lag.y]}}
"""


def test_a_ros2_peer_drives_the_run_in_lockstep_as_a_table_would(tmp_path: Path) -> None:
    domain = random.randint(1, 232)
    out = tmp_path / "peer.json"
    peer = subprocess.Popen([sys.executable, str(PEER), str(domain), str(STEPS), str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert peer.stdout is not None and peer.stdout.readline().strip() == "ready"
        time.sleep(1.0)  # discovery
        run = simulate(load(scenario(domain)), tmp_path / "run")
        peer.wait(timeout=60)
    finally:
        peer.kill()
    got = json.loads(out.read_text())
    t = np.arange(STEPS) * H
    # the peer read every /clock and every odometry, decoded with rosbags
    np.testing.assert_allclose(sorted(got["clock"]), t, atol=1e-9)
    odom = got["odom"]
    assert len(odom) == STEPS
    np.testing.assert_allclose([o["stamp"] for o in odom], t, atol=1e-9)
    assert {(o["frame_id"], o["child_frame_id"]) for o in odom} == {("odom", "base_link")}
    lag = run["lag.y"]
    np.testing.assert_array_equal([o["vx"] for o in odom], lag[:STEPS])
    np.testing.assert_array_equal([o["x"] for o in odom], lag[:STEPS])
    # in lockstep the answer to the odometry of step k (0.1 (k + 1)) is taken at step k + 1
    # and holds from t_(k+2) on: the same as a table holding those values
    values = ", ".join(f"{0.1 * max(k - 1, 0)!r}" for k in range(STEPS + 1))
    times = ", ".join(f"{max(k - 0.5, 0) * H!r}" for k in range(STEPS + 1))  # mid-step
    table = (f"cmd: {{kind: table, parameters: {{times: [{times}], values: [{values}], "
             f"interpolation: hold}}}}")
    text = scenario(domain, table).replace("cmd.linear.x -> lag.u", "cmd.y -> lag.u").replace(
        "signals: [cmd.linear.x, lag.y]", "signals: [cmd.y, lag.y]")
    again = simulate(load(text), tmp_path / "table")
    np.testing.assert_array_equal(again["lag.y"], lag)
    np.testing.assert_array_equal(run["cmd.linear.x"][1:], [0.1 * k for k in range(STEPS)])


def test_lockstep_stops_the_run_when_the_peer_is_absent_or_stops_answering(
        tmp_path: Path) -> None:
    domain = random.randint(1, 232)
    with pytest.raises(CosimError, match=r"lockstep: no publisher of /cmd_vel "
                       r"\(geometry_msgs/msg/Twist\) appeared on ROS 2 domain \d+ within 0\.5 s"):
        simulate(load(scenario(domain, timeout=0.5)), tmp_path / "absent")
    peer = subprocess.Popen([sys.executable, str(PEER), str(domain), "3",
                             str(tmp_path / "peer.json")], stdout=subprocess.PIPE, text=True)
    try:
        assert peer.stdout is not None and peer.stdout.readline().strip() == "ready"
        with pytest.raises(CosimError, match=r"lockstep: no sample on /cmd_vel "
                           r"\(geometry_msgs/msg/Twist\) within 8 s of the run's writes at "
                           r"t = 0\.04 s: the peer stopped answering"):
            simulate(load(scenario(domain, timeout=8.0)), tmp_path / "run")  # a busy peer
    finally:
        peer.kill()
    result = read_result(tmp_path / "run.incomplete")  # what was computed is kept
    np.testing.assert_array_equal(result["cmd.linear.x"], [0.0, 0.0] + [0.1 * k for k in (1, 2, 3)])


@pytest.mark.parametrize("change, key, text", [
    ("message: geometry_msgs/msg/Twist,", "message: geometry_msgs/msg/Twits,",
     "unknown message type 'geometry_msgs/msg/Twits' (did you mean "
     "'geometry_msgs/msg/Twist'?"),
    ("fields: 'linear.x, angular.z'", "fields: 'linear.x, angular.zz'",
     "has no numeric field 'angular.zz' (did you mean 'angular.z'?"),
    ("lockstep: true,", "lockstep: true, qos: sensor,",
     "qos 'sensor' is no ROS 2 profile (did you mean 'sensor_data'?"),
    ("topic: /cmd_vel,", "topic: /cmd vel,", "is not a ROS 2 topic name"),
])
def test_bad_configuration_fails_at_check(change: str, key: str, text: str) -> None:
    bad = scenario(7).replace(change, key)
    assert bad != scenario(7)
    with pytest.raises(ScenarioError) as info:
        load(bad)
    assert text in str(info.value)


def test_the_robot_as_a_ros2_control_topic_based_system(tmp_path: Path) -> None:
    """scenarios/ros2_control_robot.yaml with a controller that commands (2, 1) rad/s on
    /robot_joint_commands at each joint state: the wheels reach the command (PI loops), and the
    joint states the controller decoded (rosbags) name the joints and carry the wheel speeds
    the run recorded, stamped with run time."""
    domain = random.randint(1, 232)
    out, n = tmp_path / "joints.json", 300
    peer = subprocess.Popen([sys.executable, str(PEER), str(domain), str(n), str(out),
                             "joints"], stdout=subprocess.PIPE, text=True)
    scenario_path = Path(__file__).resolve().parents[2] / "scenarios" / "ros2_control_robot.yaml"
    text = scenario_path.read_text().replace("direction: publish}", f"direction: publish, "
                                             f"domain_id: {domain}}}").replace(
        "timeout: 10.0}", f"timeout: 10.0, domain_id: {domain}}}").replace(
        "constants: 'name=right_wheel_joint|left_wheel_joint'}",
        f"constants: 'name=right_wheel_joint|left_wheel_joint', domain_id: {domain}}}")
    assert text.count(f"domain_id: {domain}") == 4
    try:
        assert peer.stdout is not None and peer.stdout.readline().strip() == "ready"
        time.sleep(1.0)
        run = simulate(load(text, [f"experiment.stop={n * 0.01}"]), tmp_path / "run")
        peer.wait(timeout=60)
    finally:
        peer.kill()
    got = json.loads(out.read_text())
    assert len(got) == n
    assert {tuple(m["name"]) for m in got} == {("right_wheel_joint", "left_wheel_joint")}
    speed = np.stack([run["plant.wheel_speed[1]"], run["plant.wheel_speed[2]"]], axis=1)
    np.testing.assert_allclose([m["velocity"] for m in got], speed[:n], rtol=0, atol=1e-12)
    np.testing.assert_allclose([m["stamp"] for m in got], np.arange(n) * 0.01, atol=1e-9)
    np.testing.assert_allclose(speed[-1], [2.0, 1.0], atol=0.1)  # the PI loops track it


def test_a_boolean_constant_is_read_as_text() -> None:
    from twmr.ros2.messages import default_message, set_field

    for text, want in (("false", False), ("true", True), ("0", False), ("yes", True)):
        message = default_message("std_msgs/msg/Bool")
        set_field(message, "data", text)
        assert message.data is want, text
