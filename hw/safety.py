"""Host-side safety of a drive block, the same for every protocol.

A `Fault` is what a link (ODrive or CiA 402) latches from the bus: a heartbeat with an error, an
EMCY, an error frame, a failed send (bus-off, adapter lost). `stale` is the host watchdog: a drive
whose last feedback frame is older than `watchdog_periods` host periods, or whose last heartbeat
is older than `heartbeat_timeout`, is a fault too. Whatever the fault, the block sends zero torque
and disables every drive at once, then stops the run with a `HardwareError` naming the drive.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Fault:
    """What went wrong (`what`), on which node (None: the bus), and what to do (`fix`)."""

    node: int | None
    what: str
    fix: str

    def text(self) -> str:
        where = "the CAN bus" if self.node is None else f"drive node {self.node}"
        return f"{where}: {self.what}. Torque set to zero and drives disabled. Fix: {self.fix}"


class LinkError(Exception):
    """A link could not do what it was asked (open, configure, enable); carries a `Fault`."""

    def __init__(self, fault: Fault):
        super().__init__(fault.text())
        self.fault = fault


def clamp(torques: Sequence[float], limit: float) -> tuple[float, ...]:
    """Each torque limited to [-limit, limit] [N.m]."""
    return tuple(min(limit, max(-limit, float(v))) for v in torques)


def stale(now: float, feedback: Mapping[int, float], heartbeats: Mapping[int, float],
          feedback_timeout: float, heartbeat_timeout: float) -> Fault | None:
    """The first drive whose feedback (time of its last frame [s]) or heartbeat is too old."""
    for node, stamp in feedback.items():
        if now - stamp > feedback_timeout:
            return Fault(node, f"no feedback frame for {1e3 * (now - stamp):.1f} ms (host "
                         f"watchdog {1e3 * feedback_timeout:.1f} ms)",
                         "check the drive's power and the bus; raise watchdog_periods only if "
                         "the drive sends slower than the host steps")
    for node, stamp in heartbeats.items():
        if now - stamp > heartbeat_timeout:
            return Fault(node, f"heartbeat lost ({1e3 * (now - stamp):.0f} ms since the last, "
                         f"timeout {1e3 * heartbeat_timeout:.0f} ms)",
                         "check the drive's power, wiring and its heartbeat period")
    return None
