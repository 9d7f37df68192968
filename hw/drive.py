"""`CanMotorDrive` (kind `can_drive`): two wheel motors on CAN drives with the ports of the
simulated motor driver, so a scenario swaps one for the other by its `kind:` alone.

Protocols: any `Link` registered under `twmr.can_protocols` (`protocol:`), shipped: ODrive CAN
Simple (`odrive`) and CiA 402 over CANopen (`cia402`); the block knows them only through that
interface. The bus is python-can's (`interface`, `channel`, `bitrate`, or a python-can config file
`can_config`), or a `can_bus` block of the scenario that the drives join (`bus:`,
`twmr.hw.canbus_block`).

Each step: `evaluate(t)` limits the torque command to `torque_limit` and sends it at once (the
torque output depends directly on the command, as for the simulated driver, and is what the drives
receive after the wire's quantisation); `do_step(t, h)` waits up to `reply_timeout` for the
feedback that answers this period (polled ODrive estimates, CiA 402 TPDOs after the SYNC) and
publishes the latest wheel speed and angle. Safety (`safety`): a latched fault (axis error, EMCY,
error frame, bus-off), feedback older than `watchdog_periods` steps or a heartbeat older than
`heartbeat_timeout` sends zero torque and disables the drives at once, and stops the run with a
`HardwareError` naming the block and the node. `terminate()` — after a normal end, an error or
Ctrl-C — sends zero torque and disables every drive. Every frame is logged (python-can BLF/ASC)
beside the results unless `log_file: ""`. `report()` says which drives stop by themselves when the
host falls silent (ODrive 0.6.x: the axis watchdog the host set and read back; CiA 402: the
heartbeat consumer) and which do not. Hardware cannot be rolled back: `get_state`/`set_state`
refuse.
"""
from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import can
import numpy as np

from twmr.core import (
    BOOLEAN,
    STRING,
    Component,
    CosimError,
    HardwareError,
    Input,
    Output,
    Parameter,
)
from twmr.core.run import RunContext
from twmr.hw.bus import BusMember, FrameLog, bus_options, interface_problem, member_problems
from twmr.hw.link import (
    DriveSpec,
    Link,
    option_files,
    option_parameters,
    protocol,
    protocols,
)
from twmr.hw.safety import Fault, LinkError, clamp, stale

log = logging.getLogger("twmr.hw")


class CanMotorDrive(Component, BusMember):
    """Two drive axes on a CAN bus (ODrive CAN Simple or CiA 402), as the `motor_driver` block."""

    kind = "can_drive"
    needs_realtime: ClassVar[bool] = True
    can_get_and_set_state = False  # hardware cannot be rolled back
    base_dir: Path  # the scenario's folder (file options resolve against it)
    construction_parameters = ("protocol", "can_config")

    protocol = Parameter("odrive", type=STRING, description="a registered CAN protocol "
                         "(twmr.can_protocols): odrive | cia402")
    node_ids = Parameter((0, 1), size=2, type="Integer", description="right, left node id")
    gear = Parameter(1.0, min=1e-9, description="motor turns per wheel turn")
    torque_limit = Parameter(50.0, unit="N.m", min=0.0, description="|wheel torque| limit, "
                             "host and drive")
    max_current = Parameter(0.0, unit="A", min=0.0, description="the drive's rated maximum "
                            "motor current (0: not stated; required with emulate: false)")
    watchdog_periods = Parameter(10, type="Integer", min=1, description="host watchdog: steps "
                                 "without fresh feedback before the drives are disabled")
    heartbeat_timeout = Parameter(0.5, unit="s", min=0.0, description="heartbeat loss")
    reply_timeout = Parameter(1e-3, unit="s", min=0.0, description="wait for a period's feedback")
    start_timeout = Parameter(1.0, unit="s", min=0.0)
    emulate = Parameter(True, type=BOOLEAN, description="run emulated drives in this process")
    log_file = Parameter("auto", type=STRING, description="frame log (.blf | .asc) in the "
                         "results folder; 'auto' = "
                         "<results>/<name>_frames.blf, '' = none")
    on_pause = Parameter("hold", type=STRING, description="while the run is paused: hold "
                         "(zero torque every step period, the drives' watchdogs fed) | trip "
                         "(nothing sent: the drives' own watchdogs trip, and the host stops "
                         "the run on it)")

    torque_command = Input(size=2, unit="N.m", description="(tau_R, tau_L) requested")
    wheel_speed = Input(size=2, unit="rad/s", description="load speed (fed to the emulator)")
    torque = Output(size=2, unit="N.m", depends_on=("torque_command",),
                    description="torque the drives receive (limited, quantised)")
    measured_speed = Output(size=2, unit="rad/s", description="encoder speed (latest frame)")
    angle = Output(size=2, unit="rad", description="encoder angle (latest frame)")

    def __init__(self, name: str = "", **parameters: Any):
        """The protocol's own options (`Link.Options`) are parameters of this instance."""
        super().__init__(name)
        with_options(self, parameters)

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> CanMotorDrive:
        """A relative `can_config` path, and the protocol's file options (`eds`, `endpoints`),
        resolve against the scenario's folder."""
        config = construction.pop("can_config", "")
        if config and not Path(str(config)).is_absolute():
            config = str(base_dir / config)
        drive = cls(name, can_config=config, **construction)
        drive.base_dir = base_dir
        return drive

    def unknown_parameter(self, name: str) -> tuple[str, str] | None:
        return other_protocols_option(self, name)

    @classmethod
    def added_parameters(cls) -> dict[str, dict[str, Any]]:
        """Each registered protocol's own options."""
        return {f"protocol: {n}": option_parameters(protocol(n).Options) for n in protocols()}

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        """The drives' problems (`drive_problems`), the log file; with real drives (emulate:
        false) explicit torque and speed limits within the drive's rating (max_current x
        torque_constant x gear, where the protocol knows its torque constant)."""
        problems = self.drive_problems()
        if problems and problems[0][0] == "protocol":
            return problems
        if self.on_pause not in ("hold", "trip"):
            problems.append(("on_pause", f"on_pause '{self.on_pause}' is unknown.",
                             "give hold (zero torque, watchdogs fed) or trip (the drives' "
                             "watchdogs trip)."))
        log = Path(self.log_file)
        if self.log_file not in ("auto", "") and (log.is_absolute() or ".." in log.parts or
                                                  log.suffix.lower() not in (".blf", ".asc")):
            problems.append(("log_file", f"log_file '{self.log_file}' must be a .blf or .asc "
                             f"file name inside the results folder.",
                             "give a plain name such as motor.blf (it is written beside the "
                             "results), 'auto' or ''."))
        problems += self._bus_problems(given)
        if not self.emulate:
            missing = [k for k in ("torque_limit", "speed_limit", "max_current")
                       if k in self.variables and k not in given]
            if missing:
                problems.append((missing[0], f"with real drives (emulate: false) "
                                 f"{', '.join(missing)} must be given explicitly.",
                                 "state the drive's rated current (max_current [A]) and the "
                                 "limits the bench may use (torque_limit [N.m], speed_limit "
                                 "[rad/s]) for these motors."))
            elif self.max_current > 0 and "torque_constant" in self.variables:
                rating = self.max_current * self.get("torque_constant") * self.gear
                if self.torque_limit > rating:
                    problems.append(("torque_limit", f"torque_limit {self.torque_limit:g} N.m "
                                     f"is above the drive's rating max_current x "
                                     f"torque_constant x gear = {rating:g} N.m.",
                                     f"give at most {rating:g} N.m."))
        return problems

    def _bus_problems(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        """`bus:` with its own python-can options, our bus blocks' interface named directly,
        and a `virtual` bus for drives in another process (python-can's virtual bus exists
        inside one process only)."""
        problems = member_problems(self, given)
        if problems or self.bus:
            return problems
        if not self.emulate and not self.can_config and self.interface == "virtual":
            return [("interface", "interface 'virtual' with emulate: false: python-can's "
                     "virtual bus exists inside one process only, so no drive in another "
                     "process (twmr emulate-drive, a bench PC) can hear it.",
                     "use a bus that crosses processes: interface: udp_multicast with "
                     "channel: 239.74.163.2 on loopback (and twmr emulate-drive --interface "
                     "udp_multicast --channel 239.74.163.2), or socketcan with a vcan or real "
                     "adapter; or emulate: true.")]
        return []

    def check_peers(self, peers: Mapping[str, Component]) -> list[tuple[str, str, str]]:
        """`bus:` names a can_bus block of the scenario."""
        if not self.bus:
            return []
        from twmr.hw.canbus_block import bus_problem

        what = bus_problem(self.name, self.bus, peers)
        return [("bus", what + ".", "name a component of kind can_bus (bus: can0), or leave "
                 "bus: out to use interface/channel.")] if what else []

    def drive_problems(self) -> list[tuple[str, str, str]]:
        """The protocol (registered), its own parameters (`Link.check`), the node ids and the
        python-can interface: what no run can start without."""
        from twmr.registry import suggest

        known = protocols()
        if self.protocol not in known:
            return [("protocol", f"protocol '{self.protocol}' is unknown"
                     f"{suggest(self.protocol, known)}.", f"use one of: {', '.join(known)} "
                     f"(CAN protocols registered under twmr.can_protocols).")]
        link = protocol(self.protocol)
        problems = link.check(self.spec())
        what = link.node_problem(tuple(int(n) for n in self.node_ids))
        if what:
            problems.append(("node_ids", what + ".", "give two different ids the drives are "
                             f"configured with ({link.node_range.start}.."
                             f"{link.node_range.stop - 1} for {self.protocol})."))
        if not (self.can_config or self.bus):
            wrong = interface_problem(self.interface)
            if wrong:
                problems.append(("interface", wrong + ".", "give a python-can interface name "
                                 "(or can_config: a python-can config file)."))
        return problems

    # -- life cycle ------------------------------------------------------------------------------
    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self._t = start
        self.link: Link | None = None
        self.emulators: list[Any] = []
        self.log: FrameLog | None = None
        self._tripped = False
        self._rtt_ns: list[int] = []
        self._log_error = ""
        self._late_replies = 0
        self._age_max = 0.0
        self._protection: dict[int, tuple[bool, str]] = {}
        self._nodes = tuple(int(n) for n in self.node_ids)
        problems = self.drive_problems()
        if problems:
            key, what, fix = problems[0]
            raise HardwareError(self.name, start, f"parameter '{key}': {what} Fix: {fix}")
        link = protocol(self.protocol)
        try:
            options = self._options(self.name)
            emulated = self._options(f"{self.name} (emulated)")
        except (OSError, ValueError) as err:
            fix = "name a can_bus block of this scenario in bus:" if self.bus else \
                "give an existing python-can config file or interface and channel"
            raise HardwareError(self.name, start, f"bus configuration: {err}. Fix: {fix}."
                                ) from err
        path = self._log_path()
        self.log = FrameLog(path) if path else None
        spec = self.spec()
        if self.emulate:
            try:
                emulator, spec = link.emulate(spec, emulated)
            except (OSError, ValueError, ImportError, can.CanError) as err:
                raise HardwareError(self.name, start, f"cannot start the emulated drives "
                                    f"({err}). Fix: check interface, channel and can_config."
                                    ) from err
            self.emulators = [emulator]
        try:
            self.link = link(spec, options, self.log)
        except LinkError as err:
            raise HardwareError(self.name, start, err.fault.text()) from err

    def _options(self, participant: str) -> dict[str, Any]:
        """python-can options of the host side (or, `participant` named so, of the emulated
        drives): the bus block's (`bus:`), else interface/channel/bitrate or can_config."""
        if self.bus:
            from twmr.hw.canbus_block import drive_options

            return drive_options(self.name, self.bus, getattr(self, "_run", None), participant)
        return bus_options(self.interface, self.channel, int(self.bitrate), self.can_config,
                           self.can_context)

    def spec(self) -> DriveSpec:
        """The drives as their protocol sees them, its file options against the scenario's
        folder."""
        return drive_spec(self, nodes=self.node_ids)

    def prepare(self, run: RunContext) -> None:
        self._run_folder = run.folder
        self._run = run

    def _log_path(self) -> Path | None:
        """The frame log inside the run's folder ('auto': <name>_frames.blf), or None."""
        out = getattr(self, "_run_folder", None)
        if not self.log_file or out is None:
            return None
        return Path(out) / (f"{self.name}_frames.blf" if self.log_file == "auto"
                            else self.log_file)

    def get_state(self) -> Any:
        raise CosimError(f"component '{self.name}' (can_drive): the state of real drives cannot "
                         f"be saved or rolled back. Fix: use an algorithm that does not roll "
                         f"back, or the simulated motor (kind: motor_driver) for this run.")

    def set_state(self, state: Any) -> None:
        self.get_state()

    def initialize(self) -> None:
        """Start the drives, then hold them at zero torque every step period until the first
        step (what the run does in between, such as loading compiled kernels, must not leave
        the drives' watchdog without commands)."""
        try:
            self._live().start(self.start_timeout)
        except LinkError as err:
            self._trip(err.fault)
        finally:
            if self.link is not None:
                self._protection = self.link.protection()
        self._publish(time.monotonic())
        self._age_max = 0.0  # measured over the steps
        run = getattr(self, "_run", None)
        self._period = getattr(run, "step", 0.0) or 0.01
        self._holding: ZeroTorque | None = ZeroTorque(self._live(), len(self._nodes),
                                                      self._period)

    def hold(self, t: float) -> None:
        """While the run is paused: a fault the drives report stops the run (zero torque and
        disabled); `on_pause: hold` sends zero torque every step period from a thread of its
        own until the next step, `trip` sends nothing."""
        self._t = t
        if self.link is None:
            return
        fault = self.link.fault
        if fault is not None:
            if self.on_pause == "trip":
                fault = dataclasses.replace(fault, what=f"{fault.what}, while the run was "
                                            f"paused with on_pause: trip (nothing sent, as "
                                            f"asked)", fix="on_pause: hold keeps the drives' "
                                            "watchdogs fed with zero torque while paused")
            self._trip(fault)
        if self.on_pause == "hold" and getattr(self, "_holding", None) is None:
            self._holding = ZeroTorque(self.link, len(self._nodes), self._period)

    def _release(self) -> None:
        """Stop holding the drives at zero torque (the run's own commands follow)."""
        holding, self._holding = getattr(self, "_holding", None), None
        if holding is not None:
            holding.stop()

    def evaluate(self, t: float) -> None:
        """Send the (limited) torque command now: the drives apply it over [t, t + h)."""
        self._t = t
        self._release()
        try:
            self.torque = self._live().command(clamp(self.torque_command, self.torque_limit))
        except LinkError as err:
            self._trip(err.fault)

    def do_step(self, t: float, h: float) -> None:
        self._t = t
        for emu in self.emulators:
            emu.set_load_speeds(dict(zip(self._nodes, self.wheel_speed, strict=False)))
        if not self._live().wait_feedback(self.reply_timeout):
            self._late_replies += 1
        now = time.monotonic()
        fault = self._live().fault or stale(
            now, {n: fb[2] for n, fb in zip(self._nodes, self._live().feedback(), strict=False)},
            self._live().heartbeats(), self.watchdog_periods * h, self.heartbeat_timeout)
        if fault is not None:
            self._trip(fault)
        self._publish(now)

    def _live(self) -> Link:
        """The started link (setup() succeeded)."""
        if self.link is None:
            raise HardwareError(self.name, self._t, "the drives are not started (setup() did not "
                                "succeed). Fix: see the first error of this run.")
        return self.link

    def _publish(self, now: float) -> None:
        fb = self._live().feedback()
        self._age_max = max(self._age_max, max(now - f[2] for f in fb))
        self.angle = (fb[0][0], fb[1][0])
        self.measured_speed = (fb[0][1], fb[1][1])

    def _trip(self, fault: Fault) -> None:
        """Zero torque and drives disabled now, then the run stops."""
        self._tripped = True
        if self.link is not None:
            self._unconfirmed(self.link.disable(emergency=True))
        raise HardwareError(self.name, self._t, fault.text())

    def _unconfirmed(self, nodes: list[int]) -> None:
        """Say which drives did not confirm the stop (their heartbeat still not IDLE)."""
        if nodes:
            log.error("%s: drive node(s) %s did not confirm the stop (sent again meanwhile): "
                      "they may still be enabled. Fix: check them now (power, bus); a drive "
                      "whose heartbeat period is long confirms late", self.name,
                      ", ".join(map(str, nodes)))

    def report(self) -> dict[str, Any]:
        """CAN round trip p50/p99/max [us] (request -> answer), late answers, oldest feedback;
        by node, the drives that stop by themselves when the host falls silent (and how) and
        those that do not (and why)."""
        out: dict[str, Any] = {"late_replies": self._late_replies,
                               "feedback_age_max_ms": round(1e3 * self._age_max, 3)}
        if self._log_error:
            out["frame_log_error"] = self._log_error
        protection: dict[int, tuple[bool, str]] = getattr(self, "_protection", {})
        out["protected_by_drive"] = {str(n): how for n, (ok, how) in protection.items() if ok}
        out["not_protected_by_drive"] = {str(n): why for n, (ok, why) in protection.items()
                                         if not ok}
        rtt = np.asarray(getattr(self.link, "rtt_ns", self._rtt_ns), dtype=float) / 1e3
        if rtt.size:
            out.update(can_rtt_p50_us=float(np.percentile(rtt, 50)),
                       can_rtt_p99_us=float(np.percentile(rtt, 99)),
                       can_rtt_max_us=float(rtt.max()), can_rtt_samples=int(rtt.size))
        return {k: (round(v, 2) if isinstance(v, float) and math.isfinite(v) else v)
                for k, v in out.items()}

    def terminate(self) -> None:
        """Zero torque and disable every drive (IDLE / SHUTDOWN, or Estop / DISABLE VOLTAGE after
        a fault), then close the bus, the log and the emulators."""
        self._release()
        link, self.link = getattr(self, "link", None), None
        try:
            if link is not None:
                self._rtt_ns = link.rtt_ns  # for report(), which comes after the stop
                self._unconfirmed(link.disable(emergency=self._tripped))
                link.close()
        finally:
            frames, self.log = getattr(self, "log", None), None
            if frames is not None:
                frames.close()
                self._log_error = frames.error
                if frames.error:
                    log.warning("%s: the frame log %s ended early (%s); the frames after that "
                                "are not in it", self.name, frames.path, frames.error)
            for emu in getattr(self, "emulators", ()):
                emu.close()
            self.emulators = []


class ZeroTorque:
    """Zero torque to the `n` drives of `link` every `period` [s] from a thread of its own, until
    `stop()`; a failed send ends it (the run's first step then finds the link's fault)."""

    def __init__(self, link: Link, n: int, period: float):
        self.link, self.n, self.period = link, n, period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="can-drive zero torque",
                                        daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self.link.command((0.0,) * self.n)
            except LinkError:
                return

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5.0)


def with_options(block: Component, parameters: dict[str, Any],
                 taken: frozenset[str] = frozenset()) -> None:
    """Set a drive block's `protocol` (from `parameters`, else its default), add its protocol's
    own options (`Link.Options`, but those in `taken`, which the block sets itself) as
    parameters of this instance, then set `parameters`. `block.base_dir`, the scenario's
    folder, is the working directory until `create` says otherwise."""
    block.set_parameter("protocol", parameters.pop("protocol", block.get("protocol")))
    block.base_dir = Path.cwd()  # type: ignore[attr-defined]
    if block.get("protocol") in protocols():  # an unknown one is reported by `check`
        for key, var in option_parameters(protocol(block.get("protocol")).Options).items():
            if key not in taken:
                block.variables[key] = var
                block.__dict__[key] = var.start
    for key, value in parameters.items():
        block.set_parameter(key, value)


def other_protocols_option(block: Component, name: str) -> tuple[str, str] | None:
    """`name` as an option of registered protocols other than the block's: what it is and the
    fix; None when no protocol has it."""
    mine = block.get("protocol")
    owners = [n for n in protocols()
              if n != mine and name in option_parameters(protocol(n).Options)]
    if not owners:
        return None
    return (f"'{name}' is an option of protocol {' and '.join(owners)}, not of {mine} (the "
            f"protocol: of this block).", f"remove {name}:, or set protocol: {owners[0]}.")


def drive_spec(block: Any, **given: Any) -> DriveSpec:
    """The `DriveSpec` of a drive block (`protocol` and its parameters), the protocol's file
    options resolved against the block's scenario folder."""
    link = protocol(block.protocol)
    base = block.base_dir
    for name in option_files(link.Options):
        value = str(given.get(name, getattr(block, name, "")))
        if value and not Path(value).is_absolute():
            given[name] = str(base / value)
    return DriveSpec.of(link, block, **given)
