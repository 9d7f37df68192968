"""One DDS participant per domain for the process, the writers and readers of the run's ROS 2
blocks on it, QoS profiles by ROS 2's names, and the count of publications that lockstep
readers wait on."""
from __future__ import annotations

import functools
import threading
from typing import Any

#: ROS 2's QoS profiles by name: (reliable, depth)
QOS_PROFILES = {"default": (True, 10), "reliable": (True, 10), "sensor_data": (False, 5),
                "best_effort": (False, 10), "clock": (False, 1)}


@functools.cache
def participant(domain_id: int) -> Any:
    """The process's DDS participant on `domain_id` (made once)."""
    from cyclonedds.domain import DomainParticipant

    return DomainParticipant(domain_id)


def qos(profile: str) -> Any:
    """The cyclonedds QoS of a ROS 2 profile name (`QOS_PROFILES`)."""
    from cyclonedds.core import Policy
    from cyclonedds.qos import Qos
    from cyclonedds.util import duration

    reliable, depth = QOS_PROFILES[profile]
    return Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100))
               if reliable else
               Policy.Reliability.BestEffort, Policy.History.KeepLast(depth),
               Policy.Durability.Volatile)


class Publications:
    """How many samples the run's ROS 2 blocks have written: a lockstep reader waits for a
    sample that came after the last of them (the peer's answer to what it was sent)."""

    def __init__(self) -> None:
        self.count = 0
        #: the run's DDS writers (a lockstep reader waits for their subscribers to match)
        self.writers: list[Any] = []
        self._lock = threading.Lock()

    def wrote(self) -> None:
        with self._lock:
            self.count += 1


#: per run (the run's id) -> its publications
_RUNS: dict[int, Publications] = {}


def publications(run_id: int) -> Publications:
    """The publications of the run `run_id` (made at first use)."""
    return _RUNS.setdefault(run_id, Publications())


def forget(run_id: int) -> None:
    """The run has ended."""
    _RUNS.pop(run_id, None)
