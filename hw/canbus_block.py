"""`CanBus` (kind `can_bus`): one CAN bus of a scenario, simulated in time, that CAN participants
join: `can_drive` blocks with `bus: <this block>` (their host side and their emulated drives), a
python-can bus outside (`interface`/`channel` or `can_config`: real adapters, other processes),
and later FMI-LS-BUS terminals (`twmr.hw.canbus.Participant`).

What the bus does to frames is `twmr.hw.cansim`'s: arbitration by identifier, transmission time
from `bitrate` (CAN FD with `fd: true` and `data_bitrate`), stuff bits `exact` or `worst`,
delivery and confirmation at the end of EOF, ACK errors when no one else is there, refusal of
frames that cannot exist on the bus. In a run with hardware the bus runs on the wall clock; the
log's times are run times (the block's first step is its time 0 on the bus). Every event is
streamed to `<name>_frames.arrows` (Arrow IPC stream; `twmr.hw.canbus.read_log`). Outputs: frames
carried so far, bus errors so far, the bus load over the last step.
"""
from __future__ import annotations

import math
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

from twmr.core import BOOLEAN, STRING, Component, HardwareError, Output, Parameter
from twmr.hw.bus import bus_options, describe, interface_problem
from twmr.hw.canbus import INTERFACE, BusRunner, FrameLog, Gateway, runner
from twmr.hw.cansim import STUFFING, CanBusModel


def channel_of(run_id: int, name: str) -> str:
    """The `twmr` python-can channel of bus block `name` in the run `run_id`."""
    return f"{name}@{run_id:x}"


def candidates(own: str, ref: str) -> list[str]:
    """Where `bus: ref` of component `own` may point: a sibling in its own subsystem first
    ('robot.motor' -> 'robot.can0'), then outward to the top ('can0')."""
    parts = own.split(".")[:-1]
    return [".".join([*parts[:i], ref]) for i in range(len(parts), -1, -1)]


def bus_problem(own: str, ref: str, peers: Mapping[str, Component]) -> str:
    """'' when `bus: ref` of `own` names a can_bus block among `peers`, else what is wrong."""
    from twmr.registry import suggest

    for name in candidates(own, ref):
        if name in peers:
            if isinstance(peers[name], CanBus):
                return ""
            kind = getattr(peers[name], "kind", type(peers[name]).__name__)
            return (f"bus '{ref}' is component '{name}' of kind '{kind}', not a can_bus: a CAN "
                    f"participant joins a bus block, not another component's port")
    buses = sorted(n for n, c in peers.items() if isinstance(c, CanBus))
    return (f"bus '{ref}' is no component of this scenario{suggest(ref, buses)} "
            f"(can_bus blocks: {', '.join(buses) or 'none'})")


class CanBus(Component):
    """A CAN bus in time (classic or FD) that drives and python-can buses join."""

    kind = "can_bus"
    needs_realtime: ClassVar[bool] = True
    can_get_and_set_state = False  # frames on a wire cannot be rolled back
    construction_parameters = ("can_config",)

    bitrate = Parameter(1_000_000, type="Integer", min=1, description="nominal bit rate [bit/s]")
    fd = Parameter(False, type=BOOLEAN, description="CAN FD frames allowed")
    data_bitrate = Parameter(0, type="Integer", min=0, description="CAN FD data-phase bit rate "
                             "[bit/s] of frames with BRS (0: the nominal rate)")
    stuffing = Parameter("exact", type=STRING, description="stuff bits: exact (from the "
                         "frame's bits) | worst (floor((n-1)/4))")
    interface = Parameter("", type=STRING, description="python-can interface of a bus outside "
                          "to bridge ('' = none)")
    channel = Parameter("", type=STRING, description="python-can channel of that bus")
    can_config = Parameter("", type=STRING, description="python-can config file (INI) of that "
                           "bus; replaces interface/channel")
    can_context = Parameter("default", type=STRING, description="section of can_config")
    log_file = Parameter("auto", type=STRING, description="frame log (.arrows) in the results "
                         "folder; 'auto' = <name>_frames.arrows, '' = none")

    frames = Output(description="frames carried since the start")
    errors = Output(description="bus errors since the start (ACK errors, refused frames)")
    load = Output(unit="1", description="fraction of the last step the bus was busy")

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> CanBus:
        """A relative `can_config` resolves against the scenario's folder."""
        files = {k: str(base_dir / v) if v and not Path(str(v)).is_absolute() else v
                 for k, v in construction.items()}
        return cls(name, **files)

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        problems: list[tuple[str, str, str]] = []
        if self.stuffing not in STUFFING:
            problems.append(("stuffing", f"stuffing '{self.stuffing}' is unknown.",
                             f"use one of: {', '.join(STUFFING)}."))
        if self.data_bitrate and not self.fd:
            problems.append(("data_bitrate", "data_bitrate is a CAN FD rate and fd is false.",
                             "set fd: true, or leave data_bitrate out."))
        elif self.fd and 0 < self.data_bitrate < self.bitrate:
            problems.append(("data_bitrate", f"data_bitrate {self.data_bitrate} is below the "
                             f"nominal bitrate {self.bitrate}.", "give a data phase rate at "
                             "least the nominal one (e.g. 2000000 or 5000000)."))
        if self.interface == INTERFACE:
            problems.append(("interface", f"interface '{INTERFACE}' is the bus blocks' own: two "
                             f"buses joined into one.", "put every participant on one can_bus "
                             "block (bus: <name> on each), or bridge a python-can bus outside "
                             "(udp_multicast, socketcan, ...)."))
        elif self.interface and not self.can_config:
            wrong = interface_problem(self.interface)
            if wrong:
                problems.append(("interface", wrong + ".", "give a python-can interface name, "
                                 "or '' for a bus with no link outside."))
        log = Path(self.log_file)
        if self.log_file not in ("auto", "") and (log.is_absolute() or ".." in log.parts or
                                                  log.suffix.lower() != ".arrows"):
            problems.append(("log_file", f"log_file '{self.log_file}' must be an .arrows file "
                             f"name inside the results folder.", "give a plain name such as "
                             "bus.arrows, 'auto' or ''."))
        return problems

    def check_peers(self, peers: Mapping[str, Component]) -> list[tuple[str, str, str]]:
        """Two bus blocks bridged to the same python-can bus are one bus joined twice."""
        if not self.interface or self.can_config:
            return []
        for name, other in peers.items():
            if other is not self and isinstance(other, CanBus) and \
                    (other.interface, other.channel) == (self.interface, self.channel):
                return [("channel", f"bridges {self.interface}:{self.channel}, as can_bus "
                         f"'{name}' does: two buses joined into one.", "give each bus block "
                         "its own python-can channel, or put the participants of both on "
                         "one can_bus block.")]
        return []

    # -- life cycle ------------------------------------------------------------------------------
    def prepare(self, run: Any) -> None:
        self._run_folder = getattr(run, "folder", None)
        self._start = 0.0
        self._busy = 0.0
        self.gateway: Gateway | None = None
        model = CanBusModel(float(self.bitrate), float(self.data_bitrate), bool(self.fd),
                            str(self.stuffing))
        self.bus: BusRunner | None = BusRunner(self.name, channel_of(id(run), self.name),
                                               model, self._closed)
        out = self._run_folder
        name = f"{self.name}_frames.arrows" if self.log_file == "auto" else self.log_file
        self.log: FrameLog | None = FrameLog(self.bus, Path(out) / name) \
            if self.log_file and out is not None else None

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self._start = start
        self.frames = self.errors = self.load = 0.0
        if getattr(self, "bus", None) is None:
            raise HardwareError(self.name, start, "the bus was not prepared by a run. Fix: run "
                                "it in a scenario (twmr run, twmr.simulate).")
        if not (self.interface or self.can_config):
            return
        try:
            options = bus_options(self.interface, self.channel, int(self.bitrate),
                                  self.can_config, self.can_context)
            if options.get("interface") == INTERFACE:
                raise ValueError(f"interface '{INTERFACE}' joins two bus blocks")
            assert self.bus is not None
            self.gateway = Gateway(self.bus, options, describe(options))
        except Exception as err:  # noqa: BLE001 - python-can backends raise many kinds
            raise HardwareError(self.name, start, f"cannot open the python-can bus to bridge "
                                f"({type(err).__name__}: {err}). Fix: check interface, "
                                f"channel and can_config.") from err

    def do_step(self, t: float, h: float) -> None:
        bus = self.bus
        assert bus is not None
        if math.isnan(bus.offset):
            bus.begin(t)
        self.frames = float(bus.counts["transmit"])
        self.errors = float(bus.counts["bus_error"])
        busy = bus.model.busy_time
        self.load = min(1.0, (busy - self._busy) / h)
        self._busy = busy

    def report(self) -> dict[str, Any]:
        """Frames, bus errors, arbitrations lost, the first problems (each naming the
        participant, the frame and the time) and the bus load over the run."""
        bus = getattr(self, "bus_done", None) or getattr(self, "bus", None)
        if bus is None:
            return {}
        out: dict[str, Any] = {"frames": bus.counts["transmit"],
                               "bus_errors": bus.counts["bus_error"],
                               "arbitration_lost": bus.counts["arbitration_lost"]}
        problems = bus.problems()
        if problems:
            out["problems"] = problems[:5]
        return out

    def terminate(self) -> None:
        """The bus stops when its last participant has left (a drive's zero torque and disable
        still pass, and go out through the link outside), then closes that link and writes its
        log."""
        bus, self.bus = getattr(self, "bus", None), None
        if bus is not None:
            self.bus_done = bus
            if math.isnan(bus.offset):
                bus.offset = self._start - time.monotonic()
            bus.close()

    def _closed(self, bus: BusRunner) -> None:
        """The bus has stopped: close the link outside, write the log."""
        gateway, self.gateway = getattr(self, "gateway", None), None
        if gateway is not None:
            gateway.close()
        log, self.log = getattr(self, "log", None), None
        if log is not None:
            log.close()
            if log.error:
                bus.failures.append(f"bus '{self.name}': frame log {log.path.name}: {log.error}")


def drive_options(own: str, ref: str, run: Any, participant: str) -> dict[str, Any]:
    """python-can options that join participant `participant` of component `own` to the bus
    block `ref` of the run `run`; ValueError when there is none."""
    for name in candidates(own, ref):
        channel = channel_of(id(run), name)
        if runner(channel) is not None:
            return {"interface": INTERFACE, "channel": channel, "participant": participant}
    raise ValueError(f"no can_bus '{ref}' is running in this run")
