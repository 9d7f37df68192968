"""An ODrive (CAN Simple) drive emulator that answers on a python-can bus, with a motor behind it.

Per axis it keeps the axis state machine (IDLE <-> CLOSED_LOOP_CONTROL on Set_Axis_State, ESTOP
-> IDLE with an error, Clear_Errors), the controller mode, and the torque command. It sends the
Heartbeat and Get_Encoder_Estimates cyclically (and answers them when asked by RTR), like the real
drive's cyclic messages. Motor model: the applied torque follows the command through a first-order
lag `torque_tau` [s] (zero when not in closed loop); the wheel speed is either fed from outside
(`set_load_speed`, in a co-simulation where the plant carries the inertia) or integrated from
J omega' = torque with wheel inertia `inertia` [kg.m2]. A drive-side watchdog drops to IDLE with
the watchdog error bit when no torque command came for `command_timeout` [s], as a real ODrive
does with its axis watchdog enabled.
"""
from __future__ import annotations

import math
from collections import deque
import threading
import time
from dataclasses import dataclass, field

import can

from twmr.hw import protocol as p



@dataclass
class Axis:
    """The emulated state of one axis (wheel side values in SI)."""

    node: int
    state: int = p.AXIS_IDLE
    error: int = 0
    command: float = 0.0
    torque: float = 0.0
    speed: float = 0.0
    angle: float = 0.0
    last_command: float = field(default_factory=time.monotonic)
    external_speed: float | None = None


class OdriveEmulator:
    """Emulated ODrive axes on `channel` of python-can `interface` (a thread; `close()` stops it)."""

    def __init__(self, node_ids: tuple[int, ...] = (0, 1), interface: str = "virtual",
                 channel: str = "twmr", firmware: str = "0.6.10", gear: float = 1.0,
                 period: float = 1e-3, heartbeat_period: float = 0.1, torque_tau: float = 0.0,
                 inertia: float = 0.05, command_timeout: float = 0.1, bitrate: int = 1_000_000):
        self.firmware = firmware
        self.gear = gear
        self.period, self.heartbeat_period = period, heartbeat_period
        self.torque_tau, self.inertia, self.command_timeout = torque_tau, inertia, command_timeout
        self.axes = {n: Axis(n) for n in node_ids}
        self.bus = can.Bus(interface=interface, channel=channel, bitrate=bitrate)
        self.lock = threading.Lock()
        self.silent = False  # stops answering (a dead drive) when set
        self.received: deque[can.Message] = deque(maxlen=1000)  # the latest frames, for tests
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="odrive-emulator", daemon=True)
        self._thread.start()

    # -- outside world -----------------------------------------------------------------------
    def set_load_speed(self, node: int, wheel_speed: float) -> None:
        """Wheel speed [rad/s] imposed by a simulated load (plant) on axis `node`."""
        with self.lock:
            self.axes[node].external_speed = wheel_speed

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
        self.bus.shutdown()

    # -- the drive ---------------------------------------------------------------------------
    def _send(self, ident: tuple[int, bytes]) -> None:
        if not self.silent:
            self.bus.send(can.Message(arbitration_id=ident[0], data=ident[1],
                                      is_extended_id=False))

    def _handle(self, msg: can.Message) -> None:
        node, cmd = p.split_id(msg.arbitration_id)
        axis = self.axes.get(node)
        if axis is None or self.silent:
            return
        self.received.append(msg)
        with self.lock:
            if msg.is_remote_frame:
                if cmd == p.GET_ENCODER_ESTIMATES:
                    self._send(p.encode_encoder(node, axis.angle, axis.speed, self.gear))
                elif cmd == p.HEARTBEAT:
                    self._send(p.encode_heartbeat(node, p.Heartbeat(axis.error, axis.state),
                                                  self.firmware))
            elif cmd == p.SET_INPUT_TORQUE:
                axis.command = p.decode_torque(msg.data, self.gear)
                axis.last_command = time.monotonic()
            elif cmd == p.SET_AXIS_STATE:
                requested = int.from_bytes(msg.data[:4], "little")
                if requested == p.AXIS_CLOSED_LOOP and axis.error == 0:
                    axis.state = p.AXIS_CLOSED_LOOP
                    axis.last_command = time.monotonic()
                elif requested == p.AXIS_IDLE:
                    axis.state = p.AXIS_IDLE
                self._send(p.encode_heartbeat(node, p.Heartbeat(axis.error, axis.state),
                                              self.firmware))
            elif cmd == p.ESTOP:
                axis.state = p.AXIS_IDLE
                axis.error |= p.error_bit("estop", self.firmware)
            elif cmd == p.CLEAR_ERRORS:
                axis.error = 0

    def _advance(self, dt: float) -> None:
        now = time.monotonic()
        with self.lock:
            for axis in self.axes.values():
                if axis.state == p.AXIS_CLOSED_LOOP and now - axis.last_command > \
                        self.command_timeout:
                    axis.state = p.AXIS_IDLE
                    axis.error |= p.error_bit("watchdog", self.firmware)
                target = axis.command if axis.state == p.AXIS_CLOSED_LOOP else 0.0
                if self.torque_tau > 0:
                    axis.torque += (target - axis.torque) * (1 - math.exp(-dt / self.torque_tau))
                else:
                    axis.torque = target
                if axis.external_speed is not None:
                    axis.speed = axis.external_speed
                else:
                    axis.speed += axis.torque / self.inertia * dt
                axis.angle += axis.speed * dt

    def _run(self) -> None:
        last = next_tx = next_hb = time.monotonic()
        while not self._stop.is_set():
            msg = self.bus.recv(timeout=self.period / 4)
            while msg is not None:
                self._handle(msg)
                msg = self.bus.recv(timeout=0)
            now = time.monotonic()
            self._advance(now - last)
            last = now
            if now >= next_tx:
                next_tx = now + self.period
                for axis in list(self.axes.values()):
                    self._send(p.encode_encoder(axis.node, axis.angle, axis.speed, self.gear))
            if now >= next_hb:
                next_hb = now + self.heartbeat_period
                for axis in list(self.axes.values()):
                    self._send(p.encode_heartbeat(axis.node, p.Heartbeat(axis.error, axis.state),
                                                  self.firmware))
