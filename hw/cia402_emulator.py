"""CiA 402 drives emulated on a python-can bus: per node a canopen `LocalNode` with a real EDS/DCF
(SDO server for the host's configuration), the power state machine driven by the controlword of
its RPDOs, TPDOs sent on each SYNC as the host mapped them, a heartbeat producer, EMCY on faults,
and a motor model (applied torque = target torque, limited by max torque 0x6072 when the
dictionary has it, only in OPERATION ENABLED; wheel speed fed from outside or integrated from an
inertia). Drive-side watchdog: no SYNC for `sync_timeout` while operation is enabled faults the
drive with EMCY 0x8130 (heartbeat/life guard error), as a drive with a sync/heartbeat consumer does.
"""
from __future__ import annotations

import math
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import canopen

from twmr.hw import cia402 as c
from twmr.hw.bus import strict_canopen
from twmr.hw.cia402 import State


class Cia402Axis:
    """One emulated drive (node `node_id`) on `network`."""

    def __init__(self, network: canopen.Network, node_id: int, eds: str | Path, gear: float,
                 rated_torque_mNm: int, increments_per_rev: int, inertia: float):
        self.node_id, self.gear, self.inertia = node_id, gear, inertia
        self.increments_per_rev = increments_per_rev
        # canopen types its dictionary entries as a union; the EDS decides which each one is
        self.node: Any = cast(Any, canopen.LocalNode(node_id, canopen.import_od(str(eds),
                                                                               node_id)))
        network.add_node(self.node)
        self.node.sdo[c.MOTOR_RATED_TORQUE].raw = rated_torque_mNm
        self.has_max = c.MAX_TORQUE in self.node.object_dictionary
        if self.has_max:
            self.node.sdo[c.MAX_TORQUE].raw = 65535
        self.lock = threading.Lock()
        self.state = State.SWITCH_ON_DISABLED
        self.control = 0
        self.torque = 0.0
        self.speed = 0.0
        self.angle = 0.0
        self.external_speed: float | None = None
        self.malformed = 0  # RPDOs dropped for their length
        self.last_sync = self.last_time = time.monotonic()
        self._publish_status()

    def inject_fault(self, code: int = 0x2310) -> None:
        """A drive fault (default: overcurrent): an EMCY frame, then FAULT with zero torque."""
        self.node.emcy.send(code, 0x01)
        with self.lock:
            self.state = State.FAULT
            self.torque = 0.0
            self._publish_status()

    def _publish_status(self) -> None:
        self.node.sdo[c.STATUSWORD].raw = c.statusword(self.state)

    def start(self) -> None:
        """NMT start: the PDO configuration written by the host is final."""
        self.node.rpdo.read()
        self.node.tpdo.read()
        for m in self.node.rpdo.map.values():
            if m.enabled:
                m.add_callback(self._on_rpdo)
        self.node.rpdo.subscribe()

    def _on_rpdo(self, pdo: canopen.pdo.PdoMap) -> None:
        if len(pdo.data) < sum(v.length for v in pdo.map) // 8:
            self.malformed += 1  # CiA 301: a PDO shorter than its mapping is not processed
            return
        with self.lock:
            by_index = {v.index: v for v in pdo.map}
            if c.CONTROLWORD in by_index:
                word = int(by_index[c.CONTROLWORD].raw)
                self.state = c.drive_transition(self.state, word, self.control)
                self.control = word
                self._publish_status()
            if c.TARGET_TORQUE in by_index:
                rated = self.node.sdo[c.MOTOR_RATED_TORQUE].raw
                permille = int(by_index[c.TARGET_TORQUE].raw)
                if self.has_max:
                    top = int(self.node.sdo[c.MAX_TORQUE].raw)
                    permille = max(-top, min(top, permille))
                self.torque = c.permille_to_torque(permille, self.gear, rated)

    def on_sync(self, now: float) -> None:
        if self.node.nmt.state != "OPERATIONAL":
            return  # PDOs only in OPERATIONAL (NMT stop or pre-operational silences them)
        with self.lock:
            self.last_sync = now
            dt, self.last_time = now - self.last_time, now
            applied = self.torque if self.state == State.OPERATION_ENABLED else 0.0
            if self.external_speed is not None:
                self.speed = self.external_speed
            else:
                self.speed += applied / self.inertia * dt
            self.angle += self.speed * dt
            rpm = round(self.speed * self.gear * 60.0 / (2 * math.pi))
            inc = round(self.angle / (2 * math.pi) * self.gear * self.increments_per_rev)
            values = {c.STATUSWORD: c.statusword(self.state), c.VELOCITY_ACTUAL: rpm,
                      c.POSITION_ACTUAL: inc}
        for m in self.node.tpdo.map.values():
            if not m.enabled:
                continue
            for var in m.map:
                if var.index in values:
                    var.raw = values[var.index]
            m.transmit()

    def sync_lost(self, now: float, timeout: float) -> bool:
        with self.lock:
            return self.state == State.OPERATION_ENABLED and now - self.last_sync > timeout

    def host_lost(self, now: float, beats: Mapping[int, float]) -> bool:
        """The heartbeat consumer (0x1016 sub 1) with the abort option 0x6007 set to fault: the
        producer it watches has been heard once and is now silent for longer than its timeout."""
        od = self.node.object_dictionary
        if c.HEARTBEAT_CONSUMER not in od or c.ABORT_CONNECTION not in od:
            return False
        entry = int(self.node.sdo[c.HEARTBEAT_CONSUMER][1].raw)
        producer, ms = (entry >> 16) & 0x7F, entry & 0xFFFF
        if not ms or int(self.node.sdo[c.ABORT_CONNECTION].raw) != c.ABORT_FAULT:
            return False
        seen = beats.get(producer)
        with self.lock:
            return self.state == State.OPERATION_ENABLED and seen is not None and \
                now - seen > ms / 1e3


class Cia402Emulator:
    """CiA 402 drives `node_ids` on the python-can bus `options`; `close()` stops them."""

    def __init__(self, node_ids: tuple[int, ...], eds: str | Path,
                 options: Mapping[str, Any] | None = None, gear: float = 1.0,
                 rated_torque_mNm: int = 1000, increments_per_rev: int = 4096,
                 inertia: float = 0.05, sync_timeout: float = 0.25, heartbeat_ms: int = 50):
        self.sync_timeout = sync_timeout
        self.network = canopen.Network()
        self.network.connect(**dict(options or {"interface": "virtual", "channel": "twmr"}))
        self.malformed = 0  # frames dropped because they could not be decoded
        strict_canopen(self.network, self._drop)
        self.axes = {n: Cia402Axis(self.network, n, eds, gear, rated_torque_mNm,
                                   increments_per_rev, inertia) for n in node_ids}
        self.network.subscribe(0x000, self._on_nmt)
        self.network.subscribe(0x080, self._on_sync)
        self.host_beats: dict[int, float] = {}  # heartbeats of other nodes, by node id
        for other in set(range(1, 128)) - set(node_ids):
            self.network.subscribe(0x700 + other, self._on_heartbeat)
        for axis in self.axes.values():
            axis.node.nmt.start_heartbeat(heartbeat_ms)
        self._stop = threading.Event()
        self._watch = threading.Thread(target=self._watchdog, name="cia402-emulator",
                                       daemon=True)
        self._watch.start()

    def _drop(self, msg: Any, exc: Exception) -> None:
        self.malformed += 1

    def set_load_speeds(self, speeds: Mapping[int, float]) -> None:
        """Wheel speeds [rad/s] imposed by a simulated load (the plant), by node."""
        for node, w in speeds.items():
            with self.axes[node].lock:
                self.axes[node].external_speed = w

    def applied(self) -> dict[int, float]:
        """The wheel torque [N.m] each drive applies now (zero unless OPERATION ENABLED)."""
        out = {}
        for node, axis in self.axes.items():
            with axis.lock:
                out[node] = axis.torque if axis.state == State.OPERATION_ENABLED else 0.0
        return out

    def _on_nmt(self, can_id: int, data: bytearray, timestamp: float) -> None:
        if len(data) < 2:
            self.malformed += 1
            return
        for axis in self.axes.values():
            if data[1] not in (0, axis.node_id):
                continue
            if data[0] == 0x01:
                axis.start()
            elif data[0] in (0x02, 0x80):  # stop, enter pre-operational: no PDOs, torque off
                with axis.lock:
                    axis.state = State.SWITCH_ON_DISABLED
                    axis.torque = 0.0

    def _on_sync(self, can_id: int, data: bytearray, timestamp: float) -> None:
        now = time.monotonic()
        for axis in self.axes.values():
            axis.on_sync(now)

    def _on_heartbeat(self, can_id: int, data: bytearray, timestamp: float) -> None:
        self.host_beats[can_id - 0x700] = time.monotonic()

    def _watchdog(self) -> None:
        """Drive-side protection: SYNC lost, or a consumed heartbeat lost (EMCY 0x8130)."""
        while not self._stop.wait(0.01):
            now = time.monotonic()
            for axis in self.axes.values():
                if axis.sync_lost(now, self.sync_timeout) or axis.host_lost(now,
                                                                            self.host_beats):
                    axis.inject_fault(0x8130)

    def close(self) -> None:
        """Stop the drives, after they have handled the frames already on their bus (a real
        drive gets the host's last SHUTDOWN however soon the host closes)."""
        self._stop.set()
        self._watch.join(timeout=1.0)
        for axis in self.axes.values():
            axis.node.nmt.stop_heartbeat()
        pending = getattr(self.network.bus, "queue", None)  # python-can's virtual bus
        deadline = time.monotonic() + 2.0
        while pending is not None and not pending.empty() and time.monotonic() < deadline:
            time.sleep(0.001)
        self.network.disconnect()  # joins the notifier: the frame it holds is handled
