"""A CiA 402 drive emulator on a python-can bus: a canopen `LocalNode` with a real EDS (SDO server
for configuration), the power state machine driven by the controlword of its RPDOs, TPDOs sent on
each SYNC as configured by the host, heartbeat producer, EMCY on faults, and a motor model (applied
torque = target torque, wheel speed fed from outside or integrated from an inertia). A drive-side
watchdog faults the drive (EMCY 0x8130, lifeguard/heartbeat error) when no SYNC came for
`sync_timeout` while operation is enabled.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path

import canopen

from twmr.hw import cia402 as c
from twmr.hw.cia402 import State


class Cia402Emulator:
    """One emulated CiA 402 axis (node `node_id`) on `channel`; `close()` stops it."""

    def __init__(self, node_id: int, eds: str | Path, interface: str = "virtual",
                 channel: str = "twmr", gear: float = 1.0, rated_torque_mNm: int = 1000,
                 increments_per_rev: int = 4096, inertia: float = 0.05,
                 sync_timeout: float = 0.25, heartbeat_ms: int = 50):
        self.node_id, self.gear, self.inertia = node_id, gear, inertia
        self.increments_per_rev, self.sync_timeout = increments_per_rev, sync_timeout
        self.network = canopen.Network()
        self.network.connect(interface=interface, channel=channel)
        self.node = canopen.LocalNode(node_id, canopen.import_od(str(eds), node_id))
        self.network.add_node(self.node)
        self.node.sdo[c.MOTOR_RATED_TORQUE].raw = rated_torque_mNm
        self.lock = threading.Lock()
        self.state = State.SWITCH_ON_DISABLED
        self.control = 0
        self.torque = 0.0
        self.speed = 0.0
        self.angle = 0.0
        self.external_speed: float | None = None
        self.last_sync = time.monotonic()
        self.last_time = time.monotonic()
        self._publish_status()
        self.network.subscribe(0x000, self._on_nmt)
        self.network.subscribe(0x080, self._on_sync)
        self.node.nmt.start_heartbeat(heartbeat_ms)
        self._stop = threading.Event()
        self._watch = threading.Thread(target=self._watchdog, daemon=True)
        self._watch.start()

    def set_load_speed(self, wheel_speed: float) -> None:
        with self.lock:
            self.external_speed = wheel_speed

    def inject_fault(self, code: int = 0x2310) -> None:
        """A drive fault (default: overcurrent): FAULT state and an EMCY frame."""
        with self.lock:
            self.state = State.FAULT
            self._publish_status()
        self.node.emcy.send(code, 0x01)

    def _publish_status(self) -> None:
        self.node.sdo[c.STATUSWORD].raw = c.statusword(self.state)

    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if data and data[0] == 0x01 and data[1] in (0, self.node_id):  # start: PDO config is final
            self.node.rpdo.read()
            self.node.tpdo.read()
            for m in self.node.rpdo.map.values():
                if m.enabled:
                    m.add_callback(self._on_rpdo)
            self.node.rpdo.subscribe()

    def _on_rpdo(self, pdo: canopen.pdo.PdoMap) -> None:
        with self.lock:
            by_index = {v.index: v for v in pdo.map}
            if c.CONTROLWORD in by_index:
                word = int(by_index[c.CONTROLWORD].raw)
                self.state = c.drive_transition(self.state, word, self.control)
                self.control = word
                self._publish_status()
            if c.TARGET_TORQUE in by_index:
                rated = self.node.sdo[c.MOTOR_RATED_TORQUE].raw
                self.torque = c.permille_to_torque(int(by_index[c.TARGET_TORQUE].raw),
                                                   self.gear, rated)

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        now = time.monotonic()
        with self.lock:
            self.last_sync = now
            dt, self.last_time = now - self.last_time, now
            applied = self.torque if self.state == State.OPERATION_ENABLED else 0.0
            if self.external_speed is not None:
                self.speed = self.external_speed
            else:
                self.speed += applied / self.inertia * dt
            self.angle += self.speed * dt
            rpm = round(self.speed * self.gear * 60.0 / (2 * 3.141592653589793))
            inc = round(self.angle / (2 * 3.141592653589793) * self.gear * self.increments_per_rev)
            values = {c.STATUSWORD: c.statusword(self.state), c.VELOCITY_ACTUAL: rpm,
                      c.POSITION_ACTUAL: inc}
        for m in self.node.tpdo.map.values():
            if not m.enabled:
                continue
            for var in m.map:
                if var.index in values:
                    var.raw = values[var.index]
            m.transmit()

    def _watchdog(self) -> None:
        while not self._stop.wait(self.sync_timeout / 4):
            with self.lock:
                lost = (self.state == State.OPERATION_ENABLED and
                        time.monotonic() - self.last_sync > self.sync_timeout)
            if lost:
                self.inject_fault(0x8130)

    def close(self) -> None:
        self._stop.set()
        self._watch.join(timeout=1.0)
        self.node.nmt.stop_heartbeat()
        self.network.disconnect()
