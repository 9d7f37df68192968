"""`Ros2Topic` (kind `ros2_topic`): one ROS 2 topic as ports, over DDS (docs/ros2.md).

`message: geometry_msgs/msg/Twist` (any type of rosbags' type store of `distro`), `topic:
/cmd_vel` (relative names under `namespace`), `direction: subscribe | publish`. The numeric
fields of the message (`fields:` a choice of them, else all; a fixed array is one vector port)
are output ports of a subscription, holding the last sample taken, and optional input ports of a
publication; a subscription also has `age` [s] (run time since a sample was last taken) and
`received` (samples taken). A publication writes one sample at every step, its Time field
(`header.stamp`, or `clock` of rosgraph_msgs/msg/Clock: `stamp:`) the run time, its string
fields from `constants:` ('header.frame_id=odom, child_frame_id=base_link').

`lockstep: true` (a subscription): a step taken after the run's ROS 2 blocks have written
something waits, at most `timeout` seconds, for a sample written after it (the controller's
answer), so a slow controller slows the run instead of missing steps; a peer that stops
answering stops the run with a message naming the topic. Without it, a step takes what has come.
`qos:` default | reliable | best_effort | sensor_data | clock (ROS 2's profiles);
`domain_id` the ROS_DOMAIN_ID.
"""
from __future__ import annotations

import math
import time
from typing import Any

from twmr.core import BOOLEAN, STRING, Component, Input, Output, Parameter
from twmr.core.errors import ComponentError
from twmr.core.run import RunContext
from twmr.ros2.messages import (
    MessageError,
    check_type,
    dds_struct,
    dds_topic_name,
    default_message,
    get_field,
    leaf_fields,
    sequence_fields,
    set_field,
    set_time,
    time_fields,
)
from twmr.ros2.participant import QOS_PROFILES, forget, participant, publications, qos

DIRECTIONS = ("subscribe", "publish")
#: how long a lockstep reader, its peer found, lets the run's writers find their subscribers [s]
MATCH_GRACE = 1.0


class Ros2Topic(Component):
    """A ROS 2 topic's message fields as ports, subscribed or published over DDS."""

    kind = "ros2_topic"
    can_get_and_set_state = False  # what went over the network cannot be taken back
    construction_parameters = ("message", "direction", "fields", "distro")

    topic = Parameter("", type=STRING, description="ROS 2 topic name, e.g. /cmd_vel")
    message = Parameter("", type=STRING, description="message type, e.g. "
                        "geometry_msgs/msg/Twist")
    direction = Parameter("subscribe", type=STRING, description="subscribe | publish")
    fields = Parameter("", type=STRING, description="the numeric fields as ports: "
                       "'linear.x, angular.z' ('' = all)")
    distro = Parameter("humble", type=STRING, description="ROS 2 distribution of the message "
                       "definitions (rosbags' type stores)")
    namespace = Parameter("", type=STRING, description="ROS 2 namespace of relative names")
    domain_id = Parameter(0, type="Integer", min=0, max=232, description="ROS_DOMAIN_ID")
    qos = Parameter("default", type=STRING, description=" | ".join(QOS_PROFILES))
    lockstep = Parameter(False, type=BOOLEAN, description="subscribe: wait each step for the "
                         "answer to what the run wrote")
    timeout = Parameter(5.0, unit="s", min=0.0, description="lockstep: longest wait")
    stamp = Parameter("auto", type=STRING, description="publish: the Time field set to the "
                      "run time ('auto': header.stamp or the first Time field; '' none)")
    constants = Parameter("", type=STRING, description="publish: fields set once, "
                          "'header.frame_id=odom, ...'")

    def __init__(self, name: str = "", **parameters: Any):
        construction = {k: parameters.pop(k) for k in self.construction_parameters
                        if k in parameters}
        super().__init__(name)
        for key, value in construction.items():
            self.set_parameter(key, value)
        self.problem = ""
        self.paths: list[tuple[str, int]] = []
        if self.message:
            self._ports()
        for key, value in parameters.items():
            self.set_parameter(key, value)

    def _ports(self) -> None:
        try:
            check_type(self.message, self.distro)
            known = leaf_fields(self.message, self.distro)
        except MessageError as err:
            self.problem = str(err)
            return
        except ImportError as err:
            from twmr.core.extras import missing

            self.problem = str(missing(err, "kind: ros2_topic") or err).split(". Fix:")[0]
            self._needs_extra = True
            return
        chosen = [p.strip() for p in self.fields.split(",") if p.strip()]
        sizes = dict(known)
        sequences = sequence_fields(self.message, self.distro)
        for i, entry in enumerate(chosen):
            path, sep, count = entry.partition(":")
            path = path.strip()
            if sep and path in sequences and count.strip().isdigit() and int(count) > 0:
                sizes[path] = int(count)
                chosen[i] = path
            elif sep or path in sequences:
                self.problem = (f"'{entry}': a sequence field of '{self.message}' is given "
                                f"with the number of elements its port has, e.g. "
                                f"'{path}:2' (sequences: {', '.join(sequences) or 'none'})")
                return
        for path in chosen:
            if path not in sizes:
                from twmr.registry import suggest

                more = ", ..." if len(sizes) > 12 else ""
                self.problem = (f"'{self.message}' has no numeric field '{path}'"
                                f"{suggest(path, list(sizes))} (fields: "
                                f"{', '.join(list(sizes)[:12])}{more})")
                return
        outputs = self.direction == "subscribe"
        stamped = "" if outputs else self._stamp_field()
        self.paths = [(p, sizes[p]) for p in chosen] if chosen else \
            [(p, n) for p, n in known if not (stamped and p.startswith(stamped + "."))]
        for path, size in self.paths:
            shape: dict[str, Any] = {"start": 0.0} if size == 1 else \
                {"start": (0.0,) * size, "size": size}
            var = Output(**shape) if outputs else Input(optional=True, **shape)
            self._add(var, path)
        if outputs:
            self._add(Output(unit="s", description="run time since a sample was taken"), "age")
            self._add(Output(type="Integer", description="samples taken"), "received")

    def _stamp_field(self) -> str:
        """The Time field a publication sets to the run time ('' none)."""
        if self.stamp != "auto":
            return str(self.stamp)
        times = time_fields(self.message, self.distro)
        return times[0] if times else ""

    def _add(self, var: Any, name: str) -> None:
        var.name = name
        if var.description == "":
            var.description = f"{self.message} field {name}"
        self.variables[name] = var
        self.__dict__[name] = var.start

    # -- checks --------------------------------------------------------------------------------
    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        if not self.message:
            return [("message", "no message type is given.", "give message: pkg/msg/Name, "
                     "e.g. geometry_msgs/msg/Twist.")]
        if self.problem and getattr(self, "_needs_extra", False):
            return [("message", self.problem + ".", "pip install 'twmr-cosim[ros2]' (or "
                     "'.[ros2]' in a checkout).")]
        if self.problem:
            key = "fields" if "field" in self.problem else "message"
            return [(key, self.problem + ".", "give a type and fields that rosbags' type store "
                     "has (the closest are named above).")]
        problems: list[tuple[str, str, str]] = []
        if self.direction not in DIRECTIONS:
            problems.append(("direction", f"direction '{self.direction}' is neither subscribe "
                             f"nor publish.", "write direction: subscribe or publish."))
        if self.qos not in QOS_PROFILES:
            from twmr.registry import suggest

            problems.append(("qos", f"qos '{self.qos}' is no ROS 2 profile"
                             f"{suggest(self.qos, list(QOS_PROFILES))}.",
                             f"use one of: {', '.join(QOS_PROFILES)}."))
        try:
            dds_topic_name(self.topic or "", self.namespace)
        except MessageError as err:
            problems.append(("topic", f"topic '{self.topic}': {err}.", "give a ROS 2 topic "
                             "name such as /cmd_vel."))
        if self.direction == "publish":
            problems += self._constant_problems()
            times = time_fields(self.message, self.distro)
            if self.stamp not in ("auto", "") and self.stamp not in times:
                problems.append(("stamp", f"'{self.message}' has no Time field "
                                 f"'{self.stamp}' (it has: {', '.join(times) or 'none'}).",
                                 "give one of them, 'auto' or ''."))
        elif self.lockstep and self.timeout <= 0:
            problems.append(("timeout", "lockstep needs a timeout above 0 s.",
                             "give the longest wait for the peer's answer, e.g. 5."))
        return problems

    def _constant_problems(self) -> list[tuple[str, str, str]]:
        try:
            self._constants()
            message = default_message(self.message, self.distro)
            for path, value in self._constants().items():
                set_field(message, path, value)
        except (AttributeError, ValueError, TypeError) as err:
            return [("constants", f"constants '{self.constants}': {err}.",
                     "give 'field=value, ...' with fields of the message.")]
        return []

    def _constants(self) -> dict[str, str]:
        out = {}
        for part in (p.strip() for p in self.constants.split(",") if p.strip()):
            path, sep, value = part.partition("=")
            if not sep:
                raise ValueError(f"'{part}' is not field=value")
            out[path.strip()] = value.strip()
        return out

    # -- life cycle ----------------------------------------------------------------------------
    def prepare(self, run: RunContext) -> None:
        self._run_id = id(run)
        self._published = publications(self._run_id)

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        from cyclonedds.pub import DataWriter
        from cyclonedds.sub import DataReader
        from cyclonedds.topic import Topic

        dp = participant(int(self.domain_id))
        kind = dds_struct(self.message, self.distro)
        topic = Topic(dp, dds_topic_name(self.topic, self.namespace), kind, qos=qos(self.qos))
        self._writer = self._reader = None
        if self.direction == "publish":
            self._writer = DataWriter(dp, topic, qos=qos(self.qos))
            self._published.writers.append(self._writer)
            self._template = default_message(self.message, self.distro)
            for path, value in self._constants().items():
                set_field(self._template, path, value)
            self._stamp = self._stamp_field()
        else:
            from cyclonedds.core import ReadCondition, SampleState, WaitSet

            self._reader = DataReader(dp, topic, qos=qos(self.qos))
            self._waitset = WaitSet(dp)
            self._waitset.attach(ReadCondition(self._reader, SampleState.Any))
        self._t_last = start
        self._answered = 0
        self._taken = 0

    def initialize(self) -> None:
        if self.direction == "subscribe":
            self.__dict__["age"] = 0.0
            self.__dict__["received"] = 0
            if self.lockstep:
                self._meet_the_peer()

    def _meet_the_peer(self) -> None:
        """Before the first step: the peer's writer of this topic has matched this reader
        (within `timeout`), and then the run's writers their subscribers (within MATCH_GRACE
        more): a sample written before its reader matched is lost, and lockstep would wait
        for an answer to it."""
        deadline = time.monotonic() + float(self.timeout)
        assert self._reader is not None
        while self._reader.get_subscription_matched_status().current_count == 0:
            if time.monotonic() > deadline:
                raise ComponentError(self.name, self.start_time, (
                    f"lockstep: no publisher of {self.topic} ({self.message}) appeared on ROS 2 "
                    f"domain {self.domain_id} within {self.timeout:g} s. Fix: start the "
                    f"controller first, check its topic name, type and QoS, or give a longer "
                    f"timeout"))
            time.sleep(0.01)
        grace = time.monotonic() + MATCH_GRACE
        while time.monotonic() < grace and any(
                w.get_publication_matched_status().current_count == 0
                for w in self._published.writers):
            time.sleep(0.01)

    def do_step(self, t: float, h: float) -> None:
        """A publication writes the inputs at t; a subscription takes what came (in lockstep,
        waiting for the answer to the run's last writes), its outputs holding at t + h."""
        if self._writer is not None:
            self._write(t)
            return
        target = self._published.count
        samples = self._take()
        if self.lockstep and target > self._answered:
            deadline = time.monotonic() + float(self.timeout)
            while not samples:
                left = deadline - time.monotonic()
                if left <= 0:
                    raise ComponentError(self.name, t, (
                        f"lockstep: no sample on {self.topic} ({self.message}) within "
                        f"{self.timeout:g} s of the run's writes at t = {t:g} s: the peer "
                        f"stopped answering. Fix: start the controller (ROS 2 domain "
                        f"{self.domain_id}), check its topic names and QoS, or give a longer "
                        f"timeout"))
                from cyclonedds.util import duration

                self._waitset.wait(duration(seconds=min(left, 0.1)))
                samples = self._take()
            self._answered = target
        if samples:
            last = samples[-1]
            d = self.__dict__
            for path, size in self.paths:
                value = get_field(last, path)
                if size > 1:  # a sequence: its first elements, NaN for those it lacks
                    got = tuple(value) if isinstance(value, tuple) else (value,)
                    value = (got + (math.nan,) * size)[:size]
                d[path] = value
            self._taken += len(samples)
            d["received"] = self._taken
            self._t_last = t + h
        self.__dict__["age"] = t + h - self._t_last

    def _take(self) -> list[Any]:
        assert self._reader is not None
        taken = []
        for sample in self._reader.take(N=256):
            info = getattr(sample, "sample_info", None)
            if info is None or info.valid_data:
                taken.append(sample)
        return taken

    def _write(self, t: float) -> None:
        import copy

        message = copy.deepcopy(self._template)
        d = self.__dict__
        for path, size in self.paths:
            value = d[path]
            if size == 1 and not math.isfinite(float(value)):
                continue
            set_field(message, path, value)
        if self._stamp:
            set_time(message, self._stamp, t)
        assert self._writer is not None
        self._writer.write(message)
        self._published.wrote()

    def terminate(self) -> None:
        self._writer = self._reader = None
        forget(getattr(self, "_run_id", 0))
