"""Host side of ODrive axes (CAN Simple) on one python-can bus: the `odrive` protocol.

Start-up: the firmware's DBC is checked against our frame layouts (cantools). Where the firmware
has RxSdo/TxSdo (0.6.x) and the endpoint ids are known (`endpoints`: the build's
flat_endpoints.json; the emulator's own table when emulated), each axis's own watchdog is set
(`axis0.config.watchdog_timeout` = `drive_watchdog`, `enable_watchdog` = true) and read back
through TxSdo: a drive whose values come back is protected by its own watchdog when the host
falls silent (bus-off, crash). Then each axis gets Clear_Errors, Set_Limits,
Set_Controller_Mode(torque, passthrough) and Set_Axis_State(CLOSED_LOOP_CONTROL), and must
report CLOSED_LOOP_CONTROL in its heartbeat with an encoder frame within the start timeout
(zero torque is sent meanwhile, which feeds the drives' own watchdogs). Each period:
Set_Input_Torque to every axis and, with `encoder: polled`, a remote request of
Get_Encoder_Estimates whose reply time is the round trip; with `encoder: cyclic` the drives send
their estimates at their own rate. The notifier thread keeps the latest estimates, heartbeats
and SDO answers, and latches the first fault (axis error, axis out of closed loop, error frame).
"""
from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any, ClassVar

import can

from twmr.hw import c_nodes
from twmr.hw import protocol as p
from twmr.hw.bus import FrameGuard, FrameLog, describe, discard_unsent, frame_text
from twmr.hw.link import STOP_CONFIRM_S, STOP_RESEND_S, DriveSpec, Emulator, Link, Signals
from twmr.hw.safety import Fault, LinkError

ENCODERS = ("cyclic", "polled")


class OdriveLink(Link):
    """ODrive axes `spec.nodes` (wheel order) on the bus given by python-can `options`."""

    node_range: ClassVar[range] = range(0, 64)  # 6 bits of node id in the 11-bit identifier
    default_nodes: ClassVar[tuple[int, int]] = (0, 1)
    Options: ClassVar[type] = p.OdriveOptions
    c_node: ClassVar[Any] = c_nodes.ODRIVE
    signal_units: ClassVar[dict[str, str]] = {
        "torque_command": "N.m", "angle": "rad", "speed": "rad/s", "speed_limit": "rad/s",
        "current_limit": "A", "axis_error": "", "axis_state": "", "requested_state": ""}

    def __init__(self, spec: DriveSpec, options: dict[str, Any], log: FrameLog | None = None):
        problems = self.check(spec)
        if problems:
            raise LinkError(Fault(None, problems[0][1].rstrip("."), problems[0][2]))
        self.spec, self.options = spec, options
        self.nodes, self.firmware, self.gear = tuple(spec.nodes), spec.options.firmware, spec.gear
        self.polled = spec.options.encoder == "polled"
        self.log = log
        self.lock = threading.Lock()
        self.estimates = {n: (0.0, 0.0, 0.0) for n in self.nodes}  # angle, speed, stamp
        self.beats = {n: 0.0 for n in self.nodes}
        self.states = {n: p.Heartbeat(0, 0) for n in self.nodes}
        self.fault: Fault | None = None
        self.fault_at = math.nan  # perf_counter() when the fault was latched
        self.running = False  # closed loop reached: leaving it is a fault
        self.rtt_ns: list[int] = []
        self.watchdog: dict[int, tuple[bool, str]] = {n: (False, "not started")
                                                      for n in self.nodes}
        self._sdo: dict[tuple[int, int], bytes] = {}  # (node, endpoint) -> value read back
        self._sdo_seen = threading.Condition(self.lock)
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

    @classmethod
    def check(cls, spec: DriveSpec) -> list[tuple[str, str, str]]:
        """Firmware line (and its DBC against our layouts), encoder mode, endpoint table."""
        try:
            p.check_layout(spec.options.firmware)
        except ValueError as err:
            return [("firmware", f"{err}.", "give the firmware the drives run, 0.5.x or 0.6.x "
                     "(e.g. 0.6.10), as odrivetool reports it.")]
        if spec.options.encoder not in ENCODERS:
            return [("encoder", f"encoder '{spec.options.encoder}' is unknown.",
                     f"use one of: {', '.join(ENCODERS)}.")]
        if spec.options.endpoints:
            try:
                table = p.load_endpoints(spec.options.endpoints)
            except ValueError as err:
                return [("endpoints", f"{err}.", "give the flat_endpoints.json of the drives' "
                         "firmware build (odrivetool keeps it; ODrive publishes one per "
                         "release), or endpoints: ''.")]
            missing = [k for k in (p.WATCHDOG_TIMEOUT, p.ENABLE_WATCHDOG) if k not in table]
            if missing:
                return [("endpoints", f"{spec.options.endpoints} has no endpoint {missing[0]}.",
                         "give the flat_endpoints.json of the drives' own firmware build.")]
        return []

    @classmethod
    def decode(cls, msg: can.Message, spec: DriveSpec) -> Signals:
        """CAN Simple frames of `spec.options.firmware`, scaled with `spec.gear`."""
        node, cmd = p.split_id(msg.arbitration_id)
        data = bytes(msg.data)
        if msg.is_remote_frame:
            return [(node, f"request_0x{cmd:02x}", 1.0)]
        if cmd == p.SET_INPUT_TORQUE:
            return [(node, "torque_command", p.decode_torque(data, spec.gear))]
        if cmd == p.GET_ENCODER_ESTIMATES:
            angle, speed = p.decode_encoder(data, spec.gear)
            return [(node, "angle", angle), (node, "speed", speed)]
        if cmd == p.HEARTBEAT:
            beat = p.decode_heartbeat(data, spec.options.firmware)
            return [(node, "axis_error", beat.axis_error), (node, "axis_state", beat.axis_state)]
        if cmd == p.SET_AXIS_STATE:
            return [(node, "requested_state", int.from_bytes(data[:4], "little"))]
        if cmd == p.SET_LIMITS:
            speed, current = p.decode_limits(data, spec.gear)
            return [(node, "speed_limit", speed), (node, "current_limit", current)]
        if cmd in (p.RX_SDO, p.TX_SDO) and p.has_sdo(spec.options.firmware):
            opcode, endpoint, raw = p.decode_sdo(data)
            what = "sdo_answer" if cmd == p.TX_SDO else ("sdo_write" if opcode else "sdo_read")
            return [(node, f"{what}_{endpoint}", int.from_bytes(raw, "little"))]
        names = {p.ESTOP: "estop", p.CLEAR_ERRORS: "clear_errors",
                 p.SET_CONTROLLER_MODE: "controller_mode"}
        return [(node, names[cmd], 1.0)] if cmd in names else []

    @classmethod
    def emulate(cls, spec: DriveSpec, options: dict[str, Any]) -> tuple[Emulator, DriveSpec]:
        """Emulated ODrives; the host reaches them with the emulator's endpoint table unless
        `spec.options.endpoints` names one."""
        from twmr.hw.emulator import OdriveEmulator

        endpoints = spec.options.endpoints or str(p.emulated_endpoints())
        return OdriveEmulator(spec.nodes, options, spec.options.firmware, spec.gear,
                              encoder_period=spec.options.encoder_period,
                              torque_constant=spec.options.torque_constant,
                              watchdog_timeout=spec.options.saved_watchdog,
                              endpoints=endpoints), \
            replace(spec, options=replace(spec.options, endpoints=endpoints))

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
        elif cmd == p.TX_SDO and p.has_sdo(self.firmware):
            _, endpoint, raw = p.decode_sdo(bytes(msg.data))
            with self._sdo_seen:
                self._sdo[(node, endpoint)] = raw
                self._sdo_seen.notify_all()
        elif cmd == p.HEARTBEAT:
            beat = p.decode_heartbeat(msg.data, self.firmware)
            with self.lock:
                self.beats[node], self.states[node] = now, beat
            if self.running and (beat.axis_error or beat.axis_state != p.AXIS_CLOSED_LOOP):
                self._latch(Fault(node, f"axis error "
                                  f"{p.axis_error_text(beat.axis_error, self.firmware)}, state "
                                  f"{beat.axis_state} (heartbeat)",
                                  p.axis_error_fix(beat.axis_error, self.firmware)))

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
                self.fault_at = time.perf_counter()

    # -- life cycle ------------------------------------------------------------------------------
    def _set_watchdogs(self, timeout: float) -> None:
        """Each axis's own watchdog set through RxSdo and read back through TxSdo (0.6.x);
        `self.watchdog` says per node whether it holds, and why not."""
        spec = self.spec
        if not p.has_sdo(self.firmware):
            self.watchdog = {n: (False, f"firmware {self.firmware} has no RxSdo/TxSdo: enable "
                                 "the axis watchdog with odrivetool (docs/bench.md)")
                             for n in self.nodes}
            return
        if spec.options.drive_watchdog <= 0:
            self.watchdog = {n: (False, "not set by the host (drive_watchdog: 0)")
                             for n in self.nodes}
            return
        if not spec.options.endpoints:
            self.watchdog = {n: (False, "endpoint ids unknown: give endpoints: (the "
                                 "flat_endpoints.json of the firmware build)")
                             for n in self.nodes}
            return
        table = p.load_endpoints(spec.options.endpoints)
        wanted = {p.WATCHDOG_TIMEOUT: spec.options.drive_watchdog, p.ENABLE_WATCHDOG: True}
        for n in self.nodes:
            for name, value in wanted.items():
                endpoint, kind = table[name]
                self._send(*p.encode_sdo(n, p.SDO_WRITE, endpoint, kind, value))
            for name in wanted:
                self._send(*p.encode_sdo(n, p.SDO_READ, table[name][0], table[name][1]))
        deadline = time.monotonic() + timeout
        keys = {(n, table[name][0]) for n in self.nodes for name in wanted}
        with self._sdo_seen:
            while not keys <= self._sdo.keys() and time.monotonic() < deadline:
                self._sdo_seen.wait(deadline - time.monotonic())
            got = dict(self._sdo)
        for n in self.nodes:
            back = {name: got.get((n, table[name][0])) for name in wanted}
            if any(raw is None for raw in back.values()):
                self.watchdog[n] = (False, f"no TxSdo answer within {timeout:g} s: the drive "
                                    "does not confirm its watchdog")
                continue
            seen = {name: p.sdo_value(raw, table[name][1]) for name, raw in back.items()
                    if raw is not None}
            expect = p.wire_value(table[p.WATCHDOG_TIMEOUT][1], spec.options.drive_watchdog)
            if seen[p.ENABLE_WATCHDOG] and seen[p.WATCHDOG_TIMEOUT] == expect:
                self.watchdog[n] = (True, f"axis watchdog {spec.options.drive_watchdog:g} s, "
                                    "set and read back")
            else:
                self.watchdog[n] = (False, f"read back enable_watchdog="
                                    f"{bool(seen[p.ENABLE_WATCHDOG])}, watchdog_timeout="
                                    f"{seen[p.WATCHDOG_TIMEOUT]:g} s: not what was written")

    def start(self, timeout: float) -> None:
        """The axis watchdogs (where the firmware allows), then every axis to closed-loop torque
        control; `LinkError` when one is not there in time."""
        self._set_watchdogs(min(timeout, 0.5))
        wheel_speed_limit = self.spec.options.speed_limit
        current_limit = self.spec.torque_limit / (self.gear * self.spec.options.torque_constant)
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
        with self.lock:
            beat, state = self.beats[late], self.states[late]
        if not beat:
            raise LinkError(Fault(late, f"no heartbeat arrived within {timeout:g} s on "
                                  f"{describe(self.options)}: nothing answers as this node",
                                  "check that the drive (or twmr emulate-drive) is powered and "
                                  "on this bus, with this node id, interface, channel and "
                                  "bitrate; python-can's virtual bus reaches no other process "
                                  "(use udp_multicast or socketcan there)"))
        what = (f"its last heartbeat reports axis state {state.axis_state}, axis error "
                f"{p.axis_error_text(state.axis_error, self.firmware)}"
                if state.axis_state != p.AXIS_CLOSED_LOOP else
                "it reports closed loop but sent no encoder estimates")
        fix = p.axis_error_fix(state.axis_error, self.firmware) if state.axis_error else \
            "check power, node ids and the firmware version (firmware:)"
        raise LinkError(Fault(late, f"not in closed loop after {timeout:g} s ({what})", fix))

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

    def protection(self) -> dict[int, tuple[bool, str]]:
        return dict(self.watchdog)

    def disable(self, emergency: bool = False, confirm: float = STOP_CONFIRM_S) -> list[int]:
        """Zero torque, then IDLE (or Estop when `emergency`) to every axis; errors ignored.
        Frames still waiting to be sent (a backlog behind a flood) are discarded first, where
        the interface can: the stop goes out next. Sent again every `STOP_RESEND_S` to each axis
        whose heartbeat has not yet reported IDLE since, for up to `confirm` [s] (a frame lost
        on the way, e.g. on a UDP bus, leaves no drive running); the nodes that did not
        confirm."""
        self.running = False
        discard_unsent(self.bus)
        t0 = time.monotonic()
        deadline = t0 + confirm
        left = list(self.nodes)
        while True:
            for n in left:
                for ident, data in (p.encode_torque(n, 0.0, self.gear),
                                    p.encode_estop(n) if emergency else
                                    p.encode_axis_state(n, p.AXIS_IDLE)):
                    with contextlib.suppress(LinkError):
                        self._send(ident, data)
            resend = min(deadline, time.monotonic() + STOP_RESEND_S)
            while left and time.monotonic() < resend:
                time.sleep(0.005)
                with self.lock:
                    left = [n for n in left if not (self.beats[n] > t0 and
                                                    self.states[n].axis_state == p.AXIS_IDLE)]
            if not left or time.monotonic() >= deadline:
                return left

    def close(self) -> None:
        """Stop the bus thread and shut the bus down."""
        self.notifier.stop()
        self.bus.shutdown()
