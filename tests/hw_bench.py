"""Helpers for the CAN bench tests: a drive pair started on a fresh virtual channel, a paced step
loop (each step at least one period of wall time, like the master's pacer), and a bus monitor."""
from __future__ import annotations

import gc
import time
import uuid
from collections.abc import Callable
from typing import Any

import can

from twmr.hw.drive import CanMotorDrive

H = 2e-3  # host period [s]
#: the host watchdog of the bench tests [host periods]: 100 ms, which a loaded machine (two busy
#: processes on two cores) keeps, where 5 periods (10 ms) tripped before any fault was made
WATCHDOG = 50
#: the heartbeat timeout of the bench tests [s] (a case that tests heartbeat loss gives its own):
#: heartbeats 0.54 s apart were seen at load 20
HEARTBEAT_TIMEOUT = 1.0


def eventually(check: Callable[[], bool], limit: float = 5.0) -> bool:
    """Whether `check()` holds within `limit` seconds of wall time, polled every millisecond: the
    emulated drives act on frames in their own thread, which a loaded machine runs late."""
    end = time.monotonic() + limit
    while not check():
        if time.monotonic() > end:
            return False
        time.sleep(1e-3)
    return True


def channel() -> str:
    return f"t-{uuid.uuid4().hex[:10]}"


def started(protocol: str = "odrive", **kw: Any) -> CanMotorDrive:
    """A drive pair set up and initialized on its own virtual channel (emulated drives), its host
    watchdog `WATCHDOG` periods and heartbeat timeout `HEARTBEAT_TIMEOUT` unless given."""
    kw.setdefault("channel", channel())
    kw.setdefault("log_file", "")
    kw.setdefault("watchdog_periods", WATCHDOG)
    kw.setdefault("heartbeat_timeout", HEARTBEAT_TIMEOUT)
    if protocol == "cia402":
        kw.setdefault("node_ids", (1, 2))
    d = CanMotorDrive("motor", protocol=protocol, **kw)
    gc.collect()  # as the master does before hardware starts: no full collection stalls
    gc.freeze()  # the paced steps (tens of ms on this machine)
    d.setup(0.0, None)
    d.initialize()
    return d


class Paced:
    """Steps a started drive at period H; `steps` counts the completed ones, `behind` the steps
    since `mark()` that started half a period or more late: run back to back to catch up, they leave
    the bus threads no time, so a reaction bound in periods is extended by them (0 on a machine
    that keeps the pace)."""

    def __init__(self, drive: CanMotorDrive):
        self.drive = drive
        self.steps = 0
        self.t0 = time.perf_counter()
        self.behind = 0
        self.starts: list[float] = []  # perf_counter() as each step began

    def mark(self) -> None:
        """Count `behind` from now."""
        self.behind = 0

    def run(self, n: int, torque: tuple[float, float] = (1.0, -1.0),
            speed: tuple[float, float] = (2.0, -3.0)) -> None:
        for _ in range(n):
            t = self.steps * H
            wait = self.t0 + t - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            elif wait <= -H / 2:
                self.behind += 1
            self.drive.torque_command, self.drive.wheel_speed = torque, speed
            self.starts.append(time.perf_counter())
            self.drive.evaluate(t)
            self.drive.do_step(t, H)
            self.steps += 1


class Monitor:
    """Every frame on a virtual channel from now on (python-can's virtual bus queues them)."""

    def __init__(self, ch: str):
        self.bus = can.Bus(interface="virtual", channel=ch)

    def frames(self) -> list[can.Message]:
        out = []
        msg = self.bus.recv(timeout=0.05)
        while msg is not None:
            out.append(msg)
            msg = self.bus.recv(timeout=0.05)
        self.bus.shutdown()
        return out
