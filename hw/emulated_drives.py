"""`EmulatedDrives` (kind `emulated_drives`): two emulated CAN drives on a `can_bus` block of the
scenario, without a host side — for a host elsewhere on that bus, such as the controller
exported as an FMI-LS-BUS CAN node (`twmr export asmc --fmi 3 --can odrive`, docs/export.md).

The drives are the protocol's own emulator (`Link.emulate`: ODrive CAN Simple, CiA 402), joined
to the bus block as `can_drive` joins its emulated drives; their parameters are the `can_drive`
block's. Each step the plant's wheel speeds are the axes' load speeds (`wheel_speed`) and
`torque` is what the axes apply at the end of the step (after the drives' own limits; zero out
of closed loop / OPERATION ENABLED). The drives guard themselves as real ones set up for a bench:
an emulated ODrive arms its axis watchdog (`watchdog`), an emulated CiA 402 drive faults when
SYNC stops. They terminate after the bus (`terminate_stage`), so they hear the host's last
frames. The emulators run on the wall clock: a scenario with this block runs paced, and cannot
be rolled back.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, ClassVar

import can

from twmr.core import STRING, Component, HardwareError, Input, Output, Parameter
from twmr.core.run import RunContext
from twmr.hw.drive import CanMotorDrive, drive_spec, other_protocols_option, with_options
from twmr.hw.link import DriveSpec, Emulator, option_parameters, protocol, protocols


def _drive(name: str) -> Any:
    return replace(getattr(CanMotorDrive, name))


class EmulatedDrives(Component):
    """Two emulated CAN drives (no host) on a can_bus block: load speeds in, applied torque out."""

    kind = "emulated_drives"
    needs_realtime: ClassVar[bool] = True
    base_dir: Path  # the scenario's folder (file options resolve against it)
    terminate_stage = 2  # after the bus has carried its host's last frames
    can_get_and_set_state = False  # the emulators run on the wall clock
    construction_parameters = ("protocol",)

    protocol = _drive("protocol")
    bus = Parameter("", type=STRING, description="the can_bus block of the scenario the drives "
                    "join")
    node_ids = _drive("node_ids")
    gear = _drive("gear")
    watchdog = Parameter(0.1, unit="s", min=0.0, description="ODrive: the axis watchdog each "
                         "drive arms itself, as saved with odrivetool: no torque command for "
                         "this long -> IDLE (0: off). CiA 402: the drives watch SYNC (0.25 s)")

    wheel_speed = Input(size=2, unit="rad/s", description="load speed of each axis (the plant's)")
    torque = Output(size=2, unit="N.m", description="wheel torque the axes apply")

    def __init__(self, name: str = "", **parameters: Any):
        """The protocol's own options are parameters of this instance (the saved watchdog is
        `watchdog`)."""
        super().__init__(name)
        with_options(self, parameters, taken=frozenset({"saved_watchdog"}))

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> EmulatedDrives:
        """The protocol's file options (`eds`) resolve against the scenario's folder."""
        drives = cls(name, **construction)
        drives.base_dir = base_dir
        return drives

    def unknown_parameter(self, name: str) -> tuple[str, str] | None:
        return other_protocols_option(self, name)

    @classmethod
    def added_parameters(cls) -> dict[str, dict[str, Any]]:
        """Each registered protocol's own options."""
        return {f"protocol: {n}": option_parameters(protocol(n).Options) for n in protocols()}

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        """A registered protocol, its own parameters and node ids; a `bus:`."""
        known = protocols()
        if self.protocol not in known:
            return [("protocol", f"protocol '{self.protocol}' is unknown.",
                     f"use one of: {', '.join(known)}.")]
        link = protocol(self.protocol)
        problems = link.check(self._spec())
        what = link.node_problem(tuple(int(n) for n in self.node_ids))
        if what:
            problems.append(("node_ids", what + ".", "give the two ids the host addresses."))
        if not self.bus:
            problems.append(("bus", "emulated drives need a can_bus block to join.",
                             "name one: bus: can0."))
        return problems

    def check_peers(self, peers: Any) -> list[tuple[str, str, str]]:
        from twmr.hw.canbus_block import bus_problem

        what = bus_problem(self.name, self.bus, peers) if self.bus else ""
        return [("bus", what + ".", "name a component of kind can_bus.")] if what else []

    def _spec(self) -> DriveSpec:
        return drive_spec(self, nodes=tuple(int(n) for n in self.node_ids),
                          saved_watchdog=float(self.watchdog))

    def prepare(self, run: RunContext) -> None:
        self._run = run

    def setup(self, start: float, stop: float | None) -> None:
        from twmr.hw.canbus_block import drive_options

        super().setup(start, stop)
        self.emulator: Emulator | None = None
        self._nodes = tuple(int(n) for n in self.node_ids)
        try:
            options = drive_options(self.name, self.bus, getattr(self, "_run", None), self.name)
            self.emulator = protocol(self.protocol).emulate(self._spec(), options)[0]
        except (OSError, ValueError, ImportError, can.CanError) as err:
            raise HardwareError(self.name, start, f"cannot start the emulated drives on bus "
                                f"'{self.bus}' ({err}). Fix: name a can_bus block of this "
                                f"scenario in bus:.") from err

    def _publish(self) -> None:
        assert self.emulator is not None
        applied = self.emulator.applied()
        self.torque = tuple(applied[n] for n in self._nodes)

    def initialize(self) -> None:
        self._publish()

    def do_step(self, t: float, h: float) -> None:
        assert self.emulator is not None
        self.emulator.set_load_speeds(dict(zip(self._nodes, self.wheel_speed, strict=True)))
        self._publish()

    def terminate(self) -> None:
        emulator, self.emulator = getattr(self, "emulator", None), None
        if emulator is not None:
            emulator.close()
