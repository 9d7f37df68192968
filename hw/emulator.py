"""An ODrive (CAN Simple) drive emulator that answers on a python-can bus, with a motor behind it.

Per axis it keeps what the real firmware keeps: the axis state machine (IDLE <-> CLOSED_LOOP_CONTROL
on Set_Axis_State, refused while an error is latched; Estop -> IDLE with ESTOP_REQUESTED;
Clear_Errors), the controller mode (torque commands count only in TORQUE_CONTROL), the limits of
Set_Limits, and the torque command. It sends Heartbeat and Get_Encoder_Estimates cyclically
(`heartbeat_period`, `encoder_period`; 0 turns the encoder messages off) and answers them when asked
by a remote frame. With firmware 0.6.x it answers RxSdo for the endpoints of its table
(`endpoints`, a flat_endpoints.json; by default its own): writes set them, reads are answered by
TxSdo. Drive-side safety as on a real ODrive: once enabled (`axis0.config.enable_watchdog`, off
from the factory, or `watchdog_timeout` given here as if set with odrivetool), the axis watchdog
drops a closed-loop axis to IDLE with WATCHDOG_TIMER_EXPIRED and zero torque when no
Set_Input_Torque came for `watchdog_timeout` [s]; every state change is logged in `events`. The
motor torque
is limited to current_limit * torque_constant, and to zero when the speed is past the velocity
limit in the torque's direction (the torque-mode velocity limiter).

Motor model: the applied torque follows the command through a first-order current loop lag
`torque_tau` [s] (zero out of closed loop); the wheel speed is fed from outside
(`set_load_speeds`, in a co-simulation where the plant carries the inertia) or integrated from
J omega' = torque with wheel inertia `inertia` [kg.m2].
"""
from __future__ import annotations

import contextlib
import math
import struct
import threading
import time
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import can

from twmr.hw import protocol as p


@dataclass
class Axis:
    """The emulated state of one axis (wheel-side values in SI)."""

    node: int
    state: int = p.AXIS_IDLE
    error: int = 0
    control_mode: int = 0
    command: float = 0.0
    torque: float = 0.0
    speed: float = 0.0
    angle: float = 0.0
    speed_limit: float = math.inf  # wheel rad/s
    current_limit: float = 10.0  # A (the firmware's default)
    last_command: float = field(default_factory=time.monotonic)
    external_speed: float | None = None
    watchdog_enabled: bool = False
    watchdog_timeout: float = 0.0  # [s]


@dataclass(frozen=True)
class Event:
    """A state change of an emulated axis: when (monotonic [s]), the axis state and error after
    it, the torque applied [N.m], and when the last host input came before it."""

    time: float
    node: int
    state: int
    error: int
    torque: float
    last_command: float


class OdriveEmulator:
    """Emulated ODrive axes on the python-can bus `options` (a thread; `close()` stops it)."""

    def __init__(self, node_ids: tuple[int, ...] = (0, 1),
                 options: Mapping[str, Any] | None = None, firmware: str = "0.6.10",
                 gear: float = 1.0, encoder_period: float = 1e-3, heartbeat_period: float = 0.1,
                 torque_tau: float = 0.0, inertia: float = 0.05, watchdog_timeout: float = 0.0,
                 torque_constant: float = 0.04, endpoints: str | None = None):
        p.firmware_line(firmware)  # ValueError here, not in the thread
        self.sdo = p.has_sdo(firmware)
        table = p.load_endpoints(endpoints or p.emulated_endpoints())
        self.endpoints = {ident: (name, kind) for name, (ident, kind) in table.items()
                          if name in (p.WATCHDOG_TIMEOUT, p.ENABLE_WATCHDOG)}
        self.firmware, self.gear, self.torque_constant = firmware, gear, torque_constant
        self.encoder_period, self.heartbeat_period = encoder_period, heartbeat_period
        self.torque_tau, self.inertia = torque_tau, inertia
        self.axes = {n: Axis(n, watchdog_enabled=watchdog_timeout > 0,
                             watchdog_timeout=watchdog_timeout) for n in node_ids}
        self.events: deque[Event] = deque(maxlen=10_000)
        self.bus = can.Bus(**dict(options or {"interface": "virtual", "channel": "twmr"}))
        self.lock = threading.Lock()
        self.silent = False  # stops answering and sending (a dead drive) when set
        self.received: deque[can.Message] = deque(maxlen=1000)  # the latest frames, for tests
        self.malformed = 0  # frames dropped because they could not be decoded
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="odrive-emulator", daemon=True)
        self._thread.start()

    # -- outside world -----------------------------------------------------------------------
    def set_load_speeds(self, speeds: Mapping[int, float]) -> None:
        """Wheel speeds [rad/s] imposed by a simulated load (the plant), by node."""
        with self.lock:
            for node, w in speeds.items():
                self.axes[node].external_speed = w

    def applied(self) -> dict[int, float]:
        """The wheel torque [N.m] each axis applies now (after its limits), by node."""
        with self.lock:
            return {n: axis.torque for n, axis in self.axes.items()}

    def close(self) -> None:
        """Stop, after handling the frames already on its bus (a real drive gets the host's
        last zero torque and IDLE however soon the host closes) and sending each axis's next
        heartbeat (what the drive reports after them)."""
        self._stop.set()
        self._thread.join(timeout=1.0)
        if not self._thread.is_alive():
            for _ in range(1000):
                msg = self.bus.recv(timeout=0)
                if msg is None:
                    break
                try:
                    self._handle(msg)
                except (ValueError, IndexError, struct.error):
                    self.malformed += 1
            self._advance(0.0)
            for axis in self.axes.values():
                with contextlib.suppress(can.CanError):
                    self._heartbeat(axis)
        self.bus.shutdown()

    # -- the drive ---------------------------------------------------------------------------
    def _send(self, ident: tuple[int, bytes]) -> None:
        if not self.silent:
            self.bus.send(can.Message(arbitration_id=ident[0], data=ident[1],
                                      is_extended_id=False))

    def _heartbeat(self, axis: Axis) -> None:
        self._send(p.encode_heartbeat(axis.node, p.Heartbeat(axis.error, axis.state),
                                      self.firmware))

    def _log(self, axis: Axis) -> None:
        self.events.append(Event(time.monotonic(), axis.node, axis.state, axis.error,
                                 axis.torque, axis.last_command))

    def _endpoint(self, axis: Axis, msg: can.Message) -> None:
        """RxSdo: write one of the watchdog's endpoints, or answer a read with TxSdo."""
        opcode, ident, raw = p.decode_sdo(bytes(msg.data))
        if ident not in self.endpoints:
            return  # not in this build's table: no answer
        name, kind = self.endpoints[ident]
        if opcode == p.SDO_WRITE:
            value = p.sdo_value(raw, kind)
            if name == p.WATCHDOG_TIMEOUT:
                axis.watchdog_timeout = float(value)
            else:
                axis.watchdog_enabled = bool(value)
                axis.last_command = time.monotonic()  # enabling feeds it
        elif opcode == p.SDO_READ:
            held = axis.watchdog_timeout if name == p.WATCHDOG_TIMEOUT else axis.watchdog_enabled
            self._send(p.encode_tx_sdo(axis.node, ident, kind, held))

    def _handle(self, msg: can.Message) -> None:
        node, cmd = p.split_id(msg.arbitration_id)
        axis = self.axes.get(node)
        if axis is None or self.silent or msg.is_error_frame:
            return
        self.received.append(msg)
        with self.lock:
            if msg.is_remote_frame:
                if cmd == p.GET_ENCODER_ESTIMATES:
                    self._send(p.encode_encoder(node, axis.angle, axis.speed, self.gear))
                elif cmd == p.HEARTBEAT:
                    self._heartbeat(axis)
            elif cmd == p.SET_INPUT_TORQUE:
                if axis.control_mode == p.CONTROL_TORQUE:
                    axis.command = p.decode_torque(msg.data, self.gear)
                axis.last_command = time.monotonic()  # any input feeds the watchdog
            elif cmd == p.SET_AXIS_STATE:
                requested = int.from_bytes(msg.data[:4], "little")
                if requested == p.AXIS_CLOSED_LOOP and axis.error == 0:
                    axis.state = p.AXIS_CLOSED_LOOP
                    axis.last_command = time.monotonic()
                elif requested == p.AXIS_IDLE:
                    axis.state = p.AXIS_IDLE
                self._log(axis)
                self._heartbeat(axis)
            elif cmd == p.RX_SDO and self.sdo:
                self._endpoint(axis, msg)
            elif cmd == p.SET_CONTROLLER_MODE:
                axis.control_mode = int.from_bytes(msg.data[:4], "little")
            elif cmd == p.SET_LIMITS:
                axis.speed_limit, axis.current_limit = p.decode_limits(msg.data, self.gear)
            elif cmd == p.ESTOP:
                axis.state = p.AXIS_IDLE
                axis.command = 0.0
                axis.error |= p.error_bit("estop", self.firmware)
                self._log(axis)
            elif cmd == p.CLEAR_ERRORS:
                axis.error = 0

    def _target(self, axis: Axis) -> float:
        """Wheel torque [N.m] the current loop aims at: the command within the drive's limits."""
        if axis.state != p.AXIS_CLOSED_LOOP:
            return 0.0
        limit = axis.current_limit * self.torque_constant * self.gear
        tau = min(limit, max(-limit, axis.command))
        if abs(axis.speed) > axis.speed_limit and tau * axis.speed > 0:
            return 0.0
        return tau

    def _advance(self, dt: float) -> None:
        now = time.monotonic()
        with self.lock:
            for axis in self.axes.values():
                expired = axis.watchdog_enabled and \
                    now - axis.last_command > axis.watchdog_timeout
                if axis.state == p.AXIS_CLOSED_LOOP and expired:
                    axis.state = p.AXIS_IDLE
                    axis.error |= p.error_bit("watchdog", self.firmware)
                    axis.torque = 0.0
                    self._log(axis)
                target = self._target(axis)
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
        poll = min(x for x in (self.encoder_period, self.heartbeat_period, 4e-3) if x > 0) / 4
        while not self._stop.is_set():
            msg = self.bus.recv(timeout=poll)
            while msg is not None:
                try:
                    self._handle(msg)
                except (ValueError, IndexError, struct.error):
                    self.malformed += 1  # as the firmware, drop a frame it cannot decode
                msg = self.bus.recv(timeout=0)
            now = time.monotonic()
            self._advance(now - last)
            last = now
            if self.encoder_period > 0 and now >= next_tx:
                next_tx = now + self.encoder_period
                for axis in list(self.axes.values()):
                    self._send(p.encode_encoder(axis.node, axis.angle, axis.speed, self.gear))
            if now >= next_hb:
                next_hb = now + self.heartbeat_period
                for axis in list(self.axes.values()):
                    self._heartbeat(axis)
