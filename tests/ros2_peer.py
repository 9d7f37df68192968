"""A ROS 2 controller stand-in for tests/integration/test_ros2_bridge.py: another DDS participant,
its types written by hand after ROS 2's IDL (not twmr's code), with ROS 2's mangled topic and type
names. On each Odometry it answers one Twist (linear.x = 0.1 k, angular.z = -0.05 k for the k-th);
at the end it writes what it received, decoded by rosbags' CDR deserializer, as JSON.

    python ros2_peer.py DOMAIN REPLIES OUT.json [joints]

With `joints` it is a ros2_control topic-based controller instead: on each JointState of
/robot_joint_states it answers a JointState of wheel velocities (2, 1) rad/s on
/robot_joint_commands, and keeps what it received.
"""
import json
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int32, sequence, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from rosbags.typesys import Stores, get_typestore


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32
@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str
@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: float64
    y: float64
    z: float64
@dataclass
class Twist(IdlStruct, typename="geometry_msgs::msg::dds_::Twist_"):
    linear: Vector3
    angular: Vector3
@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: float64
    y: float64
    z: float64
@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: float64
    y: float64
    z: float64
    w: float64
@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point
    orientation: Quaternion
@dataclass
class PoseWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::PoseWithCovariance_"):
    pose: Pose
    covariance: array[float64, 36]
@dataclass
class TwistWithCovariance(IdlStruct, typename="geometry_msgs::msg::dds_::TwistWithCovariance_"):
    twist: Twist
    covariance: array[float64, 36]
@dataclass
class Odometry(IdlStruct, typename="nav_msgs::msg::dds_::Odometry_"):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance
@dataclass
class Clock(IdlStruct, typename="rosgraph_msgs::msg::dds_::Clock_"):
    clock: Time


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]

STORE = get_typestore(Stores.ROS2_HUMBLE)


def decoded(sample, type_name):
    """The sample's CDR bytes decoded by rosbags (ROS 2's own message definitions)."""
    return STORE.deserialize_cdr(sample.serialize(), type_name)


def joints(dp, qos, replies, out):
    """The ros2_control side: a velocity command per joint state."""
    states = DataReader(dp, Topic(dp, "rt/robot_joint_states", JointState), qos=qos)
    commands = DataWriter(dp, Topic(dp, "rt/robot_joint_commands", JointState), qos=qos)
    print("ready", flush=True)
    got = []
    end = time.monotonic() + 120
    while len(got) < replies and time.monotonic() < end:
        for sample in states.take(N=100):
            if not hasattr(sample, "serialize"):
                continue
            got.append(decoded(sample, "sensor_msgs/msg/JointState"))
            commands.write(JointState(Header(Time(0, 0), ""), ["right_wheel_joint",
                                      "left_wheel_joint"], [], [2.0, 1.0], []))
        time.sleep(0.0002)
    with open(out, "w") as f:
        json.dump([{"name": list(m.name), "velocity": list(map(float, m.velocity)),
                    "position": list(map(float, m.position)),
                    "stamp": m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec} for m in got], f)


domain, replies, out = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
dp = DomainParticipant(domain)
qos = Qos(Policy.Reliability.Reliable(duration(milliseconds=100)), Policy.History.KeepLast(10))
if sys.argv[4:] == ["joints"]:
    joints(dp, qos, replies, out)
    sys.exit(0)
odom = DataReader(dp, Topic(dp, "rt/odom", Odometry), qos=qos)
clock = DataReader(dp, Topic(dp, "rt/clock", Clock), qos=qos)
cmd = DataWriter(dp, Topic(dp, "rt/cmd_vel", Twist), qos=qos)
print("ready", flush=True)
odoms, clocks = [], []


def take(reader, into, type_name):
    for s in reader.take(N=100):
        if hasattr(s, "serialize"):  # not an InvalidSample (a writer gone)
            into.append(decoded(s, type_name))


end = time.monotonic() + 60
while len(odoms) < replies and time.monotonic() < end:
    take(clock, clocks, "rosgraph_msgs/msg/Clock")
    n = len(odoms)
    take(odom, odoms, "nav_msgs/msg/Odometry")
    for k in range(n + 1, len(odoms) + 1):
        cmd.write(Twist(Vector3(0.1 * k, 0.0, 0.0), Vector3(0.0, 0.0, -0.05 * k)))
    time.sleep(0.0002)
time.sleep(0.3)
take(clock, clocks, "rosgraph_msgs/msg/Clock")
with open(out, "w") as f:
    json.dump({"clock": [c.clock.sec + 1e-9 * c.clock.nanosec for c in clocks],
               "odom": [{"stamp": o.header.stamp.sec + 1e-9 * o.header.stamp.nanosec,
                         "frame_id": o.header.frame_id, "child_frame_id": o.child_frame_id,
                         "x": o.pose.pose.position.x, "vx": o.twist.twist.linear.x}
                        for o in odoms]}, f)
