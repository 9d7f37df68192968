"""Host side of ODrive axes (CAN Simple) on one python-can bus.

Start-up: the firmware's DBC is checked against our frame layouts (cantools); each axis gets
Clear_Errors, Set_Limits, Set_Controller_Mode(torque, passthrough) and
Set_Axis_State(CLOSED_LOOP_CONTROL), and must report CLOSED_LOOP_CONTROL in its heartbeat with
an encoder frame within the start timeout (zero torque is sent meanwhile, which feeds the drives'
own watchdogs). Each period: Set_Input_Torque to every axis and, with `encoder: polled`, a remote
request of Get_Encoder_Estimates whose reply time is the round trip; with `encoder: cyclic` the
drives send their estimates at their own rate. The notifier thread keeps the latest estimates and
heartbeats, and latches the first fault (axis error, axis out of closed loop, error frame).
"""
from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Sequence
from typing import Any

import can

from twmr.hw import protocol as p
from twmr.hw.bus import FrameGuard, FrameLog, describe, frame_text
from twmr.hw.safety import Fault, LinkError


class OdriveLink:
    """ODrive axes `nodes` (wheel order) on the bus given by python-can `options`."""

    def __init__(self, nodes: Sequence[int], options: dict[str, Any], firmware: str,
                 gear: float, encoder: str = "cyclic", log: FrameLog | None = None):
        if encoder not in ("cyclic", "polled"):
            raise ValueError(f"encoder '{encoder}' is unknown; use cyclic or polled")
        self.nodes, self.firmware, self.gear = tuple(nodes), firmware, gear
        self.polled = encoder == "polled"
        p.check_layout(firmware)
        self.log = log
        self.lock = threading.Lock()
        self.estimates = {n: (0.0, 0.0, 0.0) for n in self.nodes}  # angle, speed, stamp
        self.beats = {n: 0.0 for n in self.nodes}
        self.states = {n: p.Heartbeat(0, 0) for n in self.nodes}
        self.fault: Fault | None = None
        self.running = False  # closed loop reached: leaving it is a fault
        self.rtt_ns: list[int] = []
        self._asked: dict[int, int] = {}
        self._replied = threading.Event()
        self._rtr = {n: can.Message(arbitration_id=p.can_id(n, p.GET_ENCODER_ESTIMATES),
                                    is_remote_frame=True, is_extended_id=False, dlc=8)
                     for n in self.nodes}
        try:
            self.bus = can.Bus(**options)
        except (can.CanError, OSError, ValueError, ImportError) as err:
            raise LinkError(Fault(None, f"cannot open {describe(options)} ({err})",
                                  "check the adapter and the interface/channel/bitrate or "
                                  "can_config parameters")) from err
        self.guard = FrameGuard(self._malformed)
        listeners: list[Any] = [self.guard, self._on_frame] + ([log.received] if log else [])
        self.notifier = can.Notifier(self.bus, listeners, timeout=0.01)

    # -- bus -----------------------------------------------------------------------------------
    def _send(self, ident: int, data: bytes) -> None:
        msg = can.Message(arbitration_id=ident, data=data, is_extended_id=False)
        self._transmit(msg)

    def _transmit(self, msg: can.Message) -> None:
        try:
            self.bus.send(msg)
        except can.CanError as err:
            raise LinkError(Fault(None, f"send failed ({err}): bus-off or adapter lost",
                                  "check wiring, termination and bitrate")) from err
        if self.log is not None:
            self.log.sent(msg)

    def _on_frame(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            self._latch(Fault(None, f"error frame received ({msg.data.hex() or 'no data'})",
                              "check termination, bitrate and wiring"))
            return
        node, cmd = p.split_id(msg.arbitration_id)
        if node not in self.beats or msg.is_remote_frame:
            return
        now = time.monotonic()
        if cmd == p.GET_ENCODER_ESTIMATES:
            angle, speed = p.decode_encoder(msg.data, self.gear)
            if not (math.isfinite(angle) and math.isfinite(speed)):
                self._latch(Fault(node, f"encoder estimates not finite in frame "
                                  f"{frame_text(msg)} (position {angle}, speed {speed})",
                                  "check the drive's encoder and its calibration"))
                return
            with self.lock:
                self.estimates[node] = (angle, speed, now)
                sent = self._asked.pop(node, None)
                if sent is not None:
                    self.rtt_ns.append(time.perf_counter_ns() - sent)
                    if not self._asked:
                        self._replied.set()
        elif cmd == p.HEARTBEAT:
            beat = p.decode_heartbeat(msg.data, self.firmware)
            with self.lock:
                self.beats[node], self.states[node] = now, beat
            if self.running and (beat.axis_error or beat.axis_state != p.AXIS_CLOSED_LOOP):
                self._latch(Fault(node, f"axis error 0x{beat.axis_error:x}, state "
                                  f"{beat.axis_state} (heartbeat)",
                                  "read the drive's errors, then Clear_Errors"))

    def _malformed(self, msg: can.Message | None, exc: Exception) -> None:
        """A frame that cannot be decoded: a fault of the drive that sent it."""
        node = p.split_id(msg.arbitration_id)[0] if msg is not None else None
        self._latch(Fault(node if node in self.beats else None,
                          f"malformed frame {frame_text(msg)} ({type(exc).__name__}: {exc})",
                          "check the drive's firmware line (firmware: parameter) and that no "
                          "other device uses this node id"))

    def _latch(self, fault: Fault) -> None:
        with self.lock:
            if self.fault is None:
                self.fault = fault

    # -- life cycle ------------------------------------------------------------------------------
    def start(self, timeout: float, wheel_speed_limit: float, current_limit: float) -> None:
        """Every axis to closed-loop torque control; `LinkError` when one is not there in time."""
        for n in self.nodes:
            self._send(*p.encode_clear_errors(n, self.firmware))
            self._send(*p.encode_limits(n, wheel_speed_limit, current_limit, self.gear))
            self._send(*p.encode_controller_mode(n))
            self._send(*p.encode_axis_state(n, p.AXIS_CLOSED_LOOP))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.command((0.0,) * len(self.nodes))
            with self.lock:
                ready = [n for n in self.nodes if self.states[n].axis_state == p.AXIS_CLOSED_LOOP
                         and self.estimates[n][2] > 0]
            if len(ready) == len(self.nodes):
                self.running = True
                return
            time.sleep(0.002)
        late = next(n for n in self.nodes if n not in ready)
        raise LinkError(Fault(late, f"not in closed loop after {timeout} s (heartbeat "
                              f"{self.states[late]})",
                              "check power, node ids, firmware version and the axis errors"))

    def command(self, torques: Sequence[float]) -> tuple[float, ...]:
        """Send wheel torques [N.m] (and the encoder requests); the torques the drives receive."""
        for n, tau in zip(self.nodes, torques, strict=False):
            self._send(*p.encode_torque(n, tau, self.gear))
        if self.polled:
            with self.lock:
                self._replied.clear()
                for n in self.nodes:
                    self._asked[n] = time.perf_counter_ns()
            for n in self.nodes:
                self._transmit(self._rtr[n])
        return tuple(p.decode_torque(p.encode_torque(0, t, self.gear)[1], self.gear)
                     for t in torques)  # float32 on the wire

    def wait_feedback(self, timeout: float) -> bool:
        """Polled: wait up to `timeout` [s] for this period's replies (True when all came)."""
        return self._replied.wait(timeout) if self.polled else True

    def feedback(self) -> list[tuple[float, float, float]]:
        """(wheel angle [rad], wheel speed [rad/s], monotonic time of the frame) per axis."""
        with self.lock:
            return [self.estimates[n] for n in self.nodes]

    def heartbeats(self) -> dict[int, float]:
        with self.lock:
            return dict(self.beats)

    def disable(self, emergency: bool = False) -> None:
        """Zero torque, then IDLE (or Estop when `emergency`) to every axis; errors ignored."""
        self.running = False
        for n in self.nodes:
            for ident, data in (p.encode_torque(n, 0.0, self.gear),
                                p.encode_estop(n) if emergency else
                                p.encode_axis_state(n, p.AXIS_IDLE)):
                with contextlib.suppress(LinkError):
                    self._send(ident, data)

    def close(self) -> None:
        self.notifier.stop()
        self.bus.shutdown()
