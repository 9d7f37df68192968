"""`CanMotorDrive`: two wheel motors on CAN drives — ODrive (CAN Simple) or CiA 402 (CANopen,
through `canopen`, see `cia402_link`) — with the motor driver's ports.

Ports are those of `motor_driver` (torque command in; applied torque, measured speed and angle
out) plus the load `wheel_speed` input, which is forwarded to an in-process emulator when
`emulate` is true (no hardware) and is otherwise only a plausibility reference.

Start-up: the DBC of the firmware line is checked against the frame layouts (cantools); each axis
gets Clear_Errors, Set_Controller_Mode(torque, passthrough) and Set_Axis_State(CLOSED_LOOP), and
must report CLOSED_LOOP in its heartbeat within `start_timeout`. Each step sends Set_Input_Torque
(limited to `torque_limit`) for both axes as soon as the command is known (`evaluate`, so the
torque output depends directly on the command, as for the simulated driver) and publishes the
latest Get_Encoder_Estimates. Safety:
no encoder frame for `feedback_timeout`, a heartbeat with an error or out of closed loop, or a
bus error stops the run with a `HardwareError` naming the drive; `terminate()` — also after any
error or Ctrl-C — sends zero torque and IDLE to every axis. Every frame sent and received is logged
to `log_file` (python-can ASC or BLF by suffix) when one is given.
"""
from __future__ import annotations

import threading
import time
from typing import Any

import can
import canopen

from twmr.core import BOOLEAN, STRING, Component, HardwareError, Input, Output, Parameter
from twmr.hw import protocol as p


class CanMotorDrive(Component):
    """Two drive axes on a CAN bus (ODrive CAN Simple or CiA 402), as the `motor_driver` block."""

    kind = "can_motor_drive"
    interface = Parameter("virtual", type=STRING, description="python-can interface")
    channel = Parameter("twmr", type=STRING, description="python-can channel")
    bitrate = Parameter(1_000_000, type="Integer", description="bit/s")
    protocol = Parameter("odrive", type=STRING, description="odrive | cia402")
    firmware = Parameter("0.6.10", type=STRING, description="ODrive firmware (0.5.x | 0.6.x)")
    node_ids = Parameter((0, 1), size=2, type="Integer", description="right, left axis node id")
    gear = Parameter(1.0, min=1e-9, description="motor turns per wheel turn")
    torque_limit = Parameter(50.0, unit="N.m", min=0.0, description="|wheel torque| limit")
    feedback_timeout = Parameter(0.05, unit="s", min=0.0, description="encoder watchdog")
    start_timeout = Parameter(1.0, unit="s", min=0.0)
    emulate = Parameter(True, type=BOOLEAN, description="run emulated drives in this process")
    eds = Parameter("", type=STRING, description="CiA 402: EDS/DCF of the drives ('' = the "
                    "shipped maxon EPOS4 EDS)")
    rated_torque = Parameter(100_000, type="Integer", description="CiA 402: rated torque "
                             "[mN.m] used when the drive reports 0 in 0x6076")
    increments_per_rev = Parameter(4096, type="Integer", description="CiA 402: encoder "
                                   "increments per motor revolution")
    log_file = Parameter("", type=STRING, description="frame log (.asc or .blf); '' = none")

    torque_command = Input(size=2, unit="N.m", description="(tau_R, tau_L) requested")
    wheel_speed = Input(size=2, unit="rad/s", description="load speed (fed to the emulator)")
    torque = Output(size=2, unit="N.m", depends_on=("torque_command",),
                    description="torque sent (after the limit)")
    measured_speed = Output(size=2, unit="rad/s", description="encoder speed (latest frame)")
    angle = Output(size=2, unit="rad", description="encoder angle (latest frame)")

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        if self.protocol not in ("odrive", "cia402"):
            raise HardwareError(self.name, start, f"protocol '{self.protocol}' is unknown. "
                                f"Fix: use protocol: odrive or cia402.")
        self._nodes = tuple(int(n) for n in self.node_ids)
        self._t = start
        self.emulator = None
        self.logger = None
        if self.protocol == "cia402":
            self._setup_cia402()
            return
        self._line = p.firmware_line(self.firmware)
        p.check_layout(self.firmware)
        self._lock = threading.Lock()
        self._feedback = {n: (0.0, 0.0, 0.0) for n in self._nodes}  # angle, speed, time
        self._heartbeat = {n: p.Heartbeat(0, 0) for n in self._nodes}
        self._bus_error = ""
        if self.emulate:
            from twmr.hw.emulator import OdriveEmulator

            self.emulator = OdriveEmulator(self._nodes, self.interface, self.channel,
                                           self.firmware, self.gear, bitrate=self.bitrate)
        try:
            self.bus = can.Bus(interface=self.interface, channel=self.channel,
                               bitrate=self.bitrate)
        except (can.CanError, OSError, ValueError) as err:
            raise HardwareError(self.name, start, f"cannot open CAN bus {self.interface}:"
                                f"{self.channel} ({err}). Fix: check the adapter and the "
                                f"interface/channel parameters.") from err
        self.logger = can.Logger(self.log_file) if self.log_file else None
        listeners: list[Any] = [self._on_frame] + ([self.logger] if self.logger else [])
        self.notifier = can.Notifier(self.bus, listeners, timeout=0.01)

    def _setup_cia402(self) -> None:
        from importlib import resources

        from twmr.hw.cia402_emulator import Cia402Emulator
        from twmr.hw.cia402_link import Cia402Link

        eds = self.eds or str(resources.files("twmr.hw").joinpath(
            "data", "maxon_epos4_module_50-5.eds"))
        if self.emulate:
            self.emulator = [Cia402Emulator(n, eds, self.interface, self.channel, self.gear,
                                            int(self.rated_torque), int(self.increments_per_rev))
                             for n in self._nodes]
        try:
            self.link = Cia402Link(self._nodes, eds, self.interface, self.channel,
                                   int(self.bitrate), self.gear, int(self.increments_per_rev),
                                   int(self.rated_torque))
            self.link.configure()
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError, OSError) as err:
            raise HardwareError(self.name, self._t, f"CiA 402 drives {self._nodes} could not "
                                f"be configured ({err}). Fix: check node ids, power, the "
                                f"EDS and the bus.") from err
        if self.log_file:
            self.logger = can.Logger(self.log_file)
            self.link.network.notifier.add_listener(self.logger)

    def _on_frame(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            self._bus_error = f"error frame {msg}"
            return
        node, cmd = p.split_id(msg.arbitration_id)
        if node not in self._feedback or msg.is_remote_frame:
            return
        if cmd == p.GET_ENCODER_ESTIMATES:
            angle, speed = p.decode_encoder(msg.data, self.gear)
            with self._lock:
                self._feedback[node] = (angle, speed, time.monotonic())
        elif cmd == p.HEARTBEAT:
            with self._lock:
                self._heartbeat[node] = p.decode_heartbeat(msg.data, self.firmware)

    def _send(self, ident: tuple[int, bytes]) -> None:
        msg = can.Message(arbitration_id=ident[0], data=ident[1], is_extended_id=False)
        try:
            self.bus.send(msg)
        except can.CanError as err:
            raise HardwareError(self.name, self._t, f"CAN send failed ({err}); bus-off or "
                                f"adapter lost. Fix: check wiring, termination, bitrate.") from err
        if self.logger is not None:
            self.logger.on_message_received(msg)

    def initialize(self) -> None:
        if self.protocol == "cia402":
            if not self.link.enable(self.start_timeout):
                raise HardwareError(self.name, self.start_time, f"drives {self._nodes} did not "
                                    f"reach OPERATION ENABLED within {self.start_timeout} s "
                                    f"(states {self.link.states()}, EMCY {self.link.emcy}). "
                                    f"Fix: check the drives' faults and power.")
            self._read_cia402()
            return
        for node in self._nodes:
            self._send((p.can_id(node, p.CLEAR_ERRORS), b""))
            self._send(p.encode_controller_mode(node))
            self._send(p.encode_axis_state(node, p.AXIS_CLOSED_LOOP))
        deadline = time.monotonic() + self.start_timeout
        while time.monotonic() < deadline:
            for node in self._nodes:  # zero torque keeps the drives' command watchdogs fed
                self._send(p.encode_torque(node, 0.0, self.gear))
            with self._lock:
                ready = all(self._heartbeat[n].axis_state == p.AXIS_CLOSED_LOOP and
                            self._feedback[n][2] > 0 for n in self._nodes)
            if ready:
                break
            time.sleep(0.002)
        else:
            raise HardwareError(self.name, self.start_time, f"drives {self._nodes} did not "
                                f"reach closed loop within {self.start_timeout} s (heartbeats: "
                                f"{self._heartbeat}). Fix: check power, node ids and errors.")
        self._read()

    def _read(self) -> None:
        now = time.monotonic()
        with self._lock:
            fb = [self._feedback[n] for n in self._nodes]
            hb = [self._heartbeat[n] for n in self._nodes]
        for node, (_, _, stamp), beat in zip(self._nodes, fb, hb):
            if now - stamp > self.feedback_timeout:
                raise HardwareError(self.name, self._t, f"drive node {node}: no encoder frame "
                                    f"for {now - stamp:.3f} s (watchdog {self.feedback_timeout} "
                                    f"s). Torque set to zero. Fix: check the drive and the bus.")
            if beat.axis_error or beat.axis_state != p.AXIS_CLOSED_LOOP:
                raise HardwareError(self.name, self._t, f"drive node {node}: axis error "
                                    f"0x{beat.axis_error:x}, state {beat.axis_state}. Torque set "
                                    f"to zero. Fix: read the drive's errors, then Clear_Errors.")
        if self._bus_error:
            raise HardwareError(self.name, self._t, f"CAN {self._bus_error}. Fix: check the bus.")
        self.angle = (fb[0][0], fb[1][0])
        self.measured_speed = (fb[0][1], fb[1][1])

    def evaluate(self, t: float) -> None:
        """Send the (limited) torque command now: the drive applies it over [t, t + h)."""
        self._t = t
        lim = self.torque_limit
        tau = tuple(min(lim, max(-lim, v)) for v in self.torque_command)
        if self.protocol == "cia402":
            from twmr.hw import cia402

            self.link.send({n: cia402.ENABLE_OPERATION for n in self._nodes},
                           dict(zip(self._nodes, tau)))
            self.torque = tuple(cia402.permille_to_torque(cia402.torque_to_permille(
                v, self.gear, self.link.rated[n]), self.gear, self.link.rated[n])
                for n, v in zip(self._nodes, tau))  # what the drive receives (per mille)
            return
        for node, v in zip(self._nodes, tau):
            self._send(p.encode_torque(node, v, self.gear))
        self.torque = tau

    def do_step(self, t: float, h: float) -> None:
        self._t = t
        if self.protocol == "cia402":
            for emu, w in zip(self.emulator or (), self.wheel_speed):
                emu.set_load_speed(w)
            self._read_cia402()
            return
        if self.emulator is not None:
            for node, w in zip(self._nodes, self.wheel_speed):
                self.emulator.set_load_speed(node, w)
        self._read()

    def _read_cia402(self) -> None:
        from twmr.hw.cia402 import State

        now = time.monotonic()
        if self.link.emcy:
            node, code = self.link.emcy[0]
            raise HardwareError(self.name, self._t, f"drive node {node} sent EMCY 0x{code:04x}. "
                                f"Drives disabled. Fix: read the drive's error history, then "
                                f"fault-reset.")
        values = []
        for node in self._nodes:
            angle, speed, stamp, state = self.link.read(node)
            if now - stamp > self.feedback_timeout:
                raise HardwareError(self.name, self._t, f"drive node {node}: no TPDO for "
                                    f"{now - stamp:.3f} s (watchdog {self.feedback_timeout} s). "
                                    f"Drives disabled. Fix: check the drive and the bus.")
            if now - self.link.beats[node] > max(0.2, 4 * self.feedback_timeout):
                raise HardwareError(self.name, self._t, f"drive node {node}: heartbeat lost. "
                                    f"Drives disabled. Fix: check power and wiring.")
            if state != State.OPERATION_ENABLED:
                raise HardwareError(self.name, self._t, f"drive node {node} left OPERATION "
                                    f"ENABLED ({state.value}). Drives disabled.")
            values.append((angle, speed))
        self.angle = (values[0][0], values[1][0])
        self.measured_speed = (values[0][1], values[1][1])

    def terminate(self) -> None:
        """Zero torque and IDLE (ODrive) / SHUTDOWN (CiA 402) to every axis, then close
        everything (also after errors)."""
        link = getattr(self, "link", None)
        if link is not None:
            try:
                link.stop()
            finally:
                if self.logger is not None:
                    self.logger.stop()
                link.close()
                self.link = None
                for emu in self.emulator or ():
                    emu.close()
                self.emulator = None
            return
        bus = getattr(self, "bus", None)
        if bus is not None:
            for node in getattr(self, "_nodes", ()):
                try:
                    self._send(p.encode_torque(node, 0.0, self.gear))
                    self._send(p.encode_axis_state(node, p.AXIS_IDLE))
                except HardwareError:
                    pass
            self.notifier.stop()
            if self.logger is not None:
                self.logger.stop()
            bus.shutdown()
            self.bus = None
        if getattr(self, "emulator", None) is not None:
            self.emulator.close()
            self.emulator = None
