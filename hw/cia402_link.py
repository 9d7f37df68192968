"""Host side of CiA 402 drives through the `canopen` package: one network, one RemoteNode per axis
with the object dictionary of its EDS/DCF.

Configuration (SDO, pre-operational): modes of operation 0x6060 = 10 (cyclic synchronous torque),
motor rated torque 0x6076 read back, RPDO1 = controlword 0x6040 + target torque 0x6071 (applied at
once), TPDO1 = statusword 0x6041 + velocity actual 0x606C and TPDO2 = position actual 0x6064 (both
on every SYNC); then NMT start. Each period: RPDO1 per axis, then one SYNC from the host. The
heartbeat of each node is consumed and EMCY frames are collected.
"""
from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import canopen

from twmr.hw import cia402 as c
from twmr.hw.cia402 import State


class Cia402Link:
    """CiA 402 axes on one CANopen network (python-can bus underneath)."""

    def __init__(self, node_ids: tuple[int, ...], eds: str | Path, interface: str, channel: str,
                 bitrate: int, gear: float, increments_per_rev: int, rated_torque_mNm: int):
        self.gear, self.increments_per_rev = gear, increments_per_rev
        self.default_rated = rated_torque_mNm
        self.network = canopen.Network()
        self.network.connect(interface=interface, channel=channel, bitrate=bitrate)
        self.lock = threading.Lock()
        self.nodes: dict[int, Any] = {}
        self.feedback = {n: {"status": 0, "rpm": 0, "inc": 0, "stamp": 0.0} for n in node_ids}
        self.beats = {n: time.monotonic() for n in node_ids}  # grace until the first one
        self.emcy: list[tuple[int, int]] = []
        for n in node_ids:
            node = canopen.RemoteNode(n, canopen.import_od(str(eds), n))
            self.network.add_node(node)
            node.emcy.add_callback(lambda e, n=n: self.emcy.append((n, e.code)))
            node.nmt.add_heartbeat_callback(lambda state, n=n: self.beats.__setitem__(
                n, time.monotonic()))
            self.nodes[n] = node

    def configure(self) -> None:
        self.rx: dict[int, tuple[Any, Any, Any]] = {}
        self.rated: dict[int, int] = {}
        for n, node in self.nodes.items():
            node.nmt.state = "PRE-OPERATIONAL"
            node.sdo[c.MODES_OF_OPERATION].raw = c.CYCLIC_SYNC_TORQUE
            self.rated[n] = int(node.sdo[c.MOTOR_RATED_TORQUE].raw) or self.default_rated
            node.rpdo.read(from_od=True)
            node.tpdo.read(from_od=True)
            for maps in (node.rpdo, node.tpdo):
                for m in maps.map.values():
                    m.enabled = False
            r = node.rpdo[1]
            r.clear()
            cw, tt = r.add_variable(c.CONTROLWORD), r.add_variable(c.TARGET_TORQUE)
            r.trans_type, r.enabled = 255, True
            t1, t2 = node.tpdo[1], node.tpdo[2]
            t1.clear()
            t1.add_variable(c.STATUSWORD)
            t1.add_variable(c.VELOCITY_ACTUAL)
            t2.clear()
            t2.add_variable(c.POSITION_ACTUAL)
            for t in (t1, t2):
                t.trans_type, t.enabled = 1, True
            node.rpdo.save()
            node.tpdo.save()
            t1.add_callback(lambda m, n=n: self._on_tpdo(n, m))
            t2.add_callback(lambda m, n=n: self._on_tpdo(n, m))
            self.rx[n] = (r, cw, tt)
        for node in self.nodes.values():
            node.nmt.state = "OPERATIONAL"

    def _on_tpdo(self, n: int, pdo: Any) -> None:
        with self.lock:
            fb = self.feedback[n]
            for var in pdo.map:
                key = {c.STATUSWORD: "status", c.VELOCITY_ACTUAL: "rpm",
                       c.POSITION_ACTUAL: "inc"}.get(var.index)
                if key:
                    fb[key] = int(var.raw)
            fb["stamp"] = time.monotonic()

    def states(self) -> dict[int, State]:
        with self.lock:
            return {n: c.decode_statusword(fb["status"]) for n, fb in self.feedback.items()}

    def send(self, controls: dict[int, int], torques: dict[int, float]) -> None:
        """RPDO1 to every axis, then one SYNC."""
        for n, (pdo, cw, tt) in self.rx.items():
            cw.raw = controls[n]
            tt.raw = c.torque_to_permille(torques.get(n, 0.0), self.gear, self.rated[n])
            pdo.transmit()
        self.network.sync.transmit()

    def enable(self, timeout: float) -> bool:
        """Walk every axis to OPERATION ENABLED (fault reset first if needed)."""
        deadline = time.monotonic() + timeout
        previous: dict[int, int] = {n: 0 for n in self.nodes}
        while time.monotonic() < deadline:
            states = self.states()
            if all(s == State.OPERATION_ENABLED for s in states.values()):
                return True
            words = {n: c.next_controlword(s) for n, s in states.items()}
            # fault reset acts on a rising edge: send 0 first when it was already high
            words = {n: (0 if w == c.FAULT_RESET and previous[n] == c.FAULT_RESET else w)
                     for n, w in words.items()}
            self.send(words, {})
            previous = words
            time.sleep(0.003)
        return False

    def read(self, n: int) -> tuple[float, float, float, State]:
        """(wheel angle [rad], wheel speed [rad/s], time of the last TPDO, state) of axis n."""
        with self.lock:
            fb = dict(self.feedback[n])
        return (c.position_to_si(fb["inc"], self.gear, self.increments_per_rev),
                c.velocity_to_si(fb["rpm"], self.gear), fb["stamp"],
                c.decode_statusword(fb["status"]))

    def stop(self) -> None:
        """Zero torque with SHUTDOWN (power stage off) to every axis."""
        self.send({n: c.SHUTDOWN for n in self.nodes}, {})

    def close(self) -> None:
        self.network.disconnect()
