"""`CanBus` (kind `can_bus`): one CAN bus of a scenario, simulated in time, that CAN participants
join: `can_drive` blocks with `bus: <this block>` (their host side and their emulated drives), a
python-can bus outside (`interface`/`channel` or `can_config`: real adapters, other processes),
and FMI-LS-BUS CAN terminals of FMUs, wired by terminal name (`ecu.CanChannel -> bus.ecu` opens
terminal `ecu` on the block: inputs `ecu.Rx_Data`/`ecu.Rx_Clock` from the FMU's Tx members,
outputs `ecu.Tx_Data`/`ecu.Tx_Clock` to its Rx members; `twmr.hw.lsbus_node`).

What the bus does to frames is `twmr.hw.cansim`'s: arbitration by identifier, transmission time
from `bitrate` (CAN FD with `fd: true` and `data_bitrate`), stuff bits `exact` or `worst`,
delivery and confirmation at the end of EOF, ACK errors when no one else is there, refusal of
frames that cannot exist on the bus. With a drive or a python-can bus outside, or in a paced
run, the bus runs on the wall clock (`twmr.hw.canbus.BusRunner`); the log's times are run times
(the block's first step is its time 0 on the bus). With LS-BUS terminals only it runs in run
time inside the block's steps (`twmr.hw.steppedbus`): not paced, the same events every run, its
state saved and restored for `algorithm: adaptive`, its next event its `next_event`. A frame an
FMU sent at a tick goes on the bus at the tick's time; what the bus tells an FMU reaches it at
the communication point that ends the step holding the event (the end of EOF). Every event is
streamed to `<name>_frames.arrows` (Arrow IPC stream; `twmr.hw.canbus.read_log`). Outputs:
frames carried so far, bus errors so far, the bus load over the last step.
"""
from __future__ import annotations

import logging
import math
import time
from collections import Counter, deque
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from twmr.core import (
    BOOLEAN,
    STRING,
    Component,
    ComponentError,
    HardwareError,
    Input,
    Output,
    Parameter,
)
from twmr.core.port import BINARY, CLOCK
from twmr.core.run import RunContext
from twmr.fmi.lsbus import operations as ops
from twmr.fmi.lsbus.terminals import is_bus_simulation, max_sizes
from twmr.fmi.lsbus.ticks import tick_parts
from twmr.hw.bus import INTERFACE, bus_options, describe, interface_problem
from twmr.hw.canbus import BusCore, BusRunner, FrameLog, Gateway, runner
from twmr.hw.cansim import FAULTS, STUFFING, CanBusModel, FrameFault
from twmr.hw.lsbus_node import LsBusNode, frame_of
from twmr.hw.steppedbus import SteppedBus

log = logging.getLogger(__name__)

#: the share of the steps over `flood_time` with a bus error from which it is an error storm
BAD_SHARE = 0.8


def frame_fault(bus: CanBus) -> FrameFault | str | None:
    """The fault bus block `bus`'s `fault*` parameters give (None: none), or what is wrong
    with its `fault_ids`."""
    text = str(bus.fault_ids).strip()
    if not text:
        return None
    ids: set[int] = set()
    if text.lower() != "all":
        for part in text.replace(";", ",").split(","):
            try:
                ident = int(part.strip(), 0)
            except ValueError:
                return f"fault_ids '{text}': '{part.strip()}' is no CAN identifier"
            if not 0 <= ident < 1 << 29:
                return f"fault_ids '{text}': {ident:#x} is outside 0 .. 0x1FFFFFFF"
            ids.add(ident)
    senders = frozenset(n.strip() for n in str(bus.fault_node).split(",") if n.strip())
    return FrameFault(frozenset(ids), float(bus.fault_start), float(bus.fault_stop),
                      float(bus.fault_probability), int(bus.fault_seed), int(bus.fault_count),
                      str(bus.fault), float(bus.fault_delay), int(bus.fault_bit), senders)


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


def joins(own: str, ref: str, peers: Mapping[str, Component]) -> str:
    """The component `bus: ref` of `own` names among `peers` ('' when none)."""
    return next((name for name in candidates(own, ref) if name in peers), "")


class CanBus(Component):
    """A CAN bus in time (classic or FD) that drives, python-can buses and LS-BUS FMUs join."""

    kind = "can_bus"
    construction_parameters = ("can_config",)
    terminate_stage = 1  # after the nodes whose last frames it carries
    #: beside the ports, what a step changes: the bus time busy so far [s], and which rates
    #: LS-BUS nodes set (((key, who and when), ...))
    state_attributes = ("_busy", "_set_by")

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
    flood_time = Parameter(0.1, unit="s", min=0.0, description="a bus on the wall clock (drives, "
                           f"hardware) stops the run when a frame waits this long for the bus (a "
                           f"flood), or {BAD_SHARE:.0%} of the steps over this long had a bus "
                           "error (an error storm); a simulated bus notes it once; 0: never")

    fault = Parameter("drop", type=STRING, description="a fault of the bus, on the frames "
                      "fault_ids names: " + "; ".join(f"{k}: {v}" for k, v in FAULTS.items()))
    fault_ids = Parameter("", type=STRING, description="the fault's frames: these identifiers "
                          "('0x00C, 0x02C', decimal or hex); 'all': every frame; '': no fault")
    fault_node = Parameter("", type=STRING, description="the participants whose frames the "
                           "fault takes (their names, by commas; a bus_off's nodes); '': "
                           "every one")
    fault_start = Parameter(0.0, unit="s", description="run time the fault begins")
    fault_stop = Parameter(math.inf, unit="s", description="run time the fault ends (it takes "
                           "frames ending on the wire before it)")
    fault_probability = Parameter(1.0, unit="1", min=0.0, max=1.0, description="each frame "
                                  "the fault may take is taken with this probability")
    fault_count = Parameter(0, type="Integer", min=0, description="at most this many frames "
                            "taken (0: no limit)")
    fault_seed = Parameter(0, type="Integer", description="seed of the fault's draws")
    fault_delay = Parameter(0.0, unit="s", min=0.0, description="delay: how much later the "
                            "receivers get a frame")
    fault_bit = Parameter(-1, type="Integer", min=-1, description="corrupt: the data bit "
                          "flipped (0: the first byte's lowest; -1 or beyond the data: drawn)")

    frames = Output(description="frames carried since the start")
    errors = Output(description="bus errors since the start (ACK errors, refused frames)")
    load = Output(unit="1", description="fraction of the last step the bus was busy")

    def __init__(self, name: str = "", **parameters: Any):
        super().__init__(name, **parameters)
        self.terminals: dict[str, dict[str, str]] = {}
        #: terminal -> (the component behind it, its bus terminal)
        self.peers: dict[str, tuple[str, str]] = {}
        self._wallclock = True  # a drive or a bus outside joins (found by check_peers)
        self.can_get_and_set_state = False
        self._given: frozenset[str] = frozenset()
        self._nodes: dict[str, LsBusNode] = {}
        self._limits: dict[str, int] = {}  # terminal -> the maxSize of its peer's Rx_Data
        self._hosts: dict[str, Component] = {}  # terminal -> the component behind it
        self._busy = 0.0
        self._set_by: tuple[tuple[str, str], ...] = ()

    @property
    def needs_realtime(self) -> bool:  # type: ignore[override]  # what joins decides
        """Hardware in the loop: a drive or a python-can bus outside joins this bus."""
        return self._wallclock

    @classmethod
    def create(cls, name: str, base_dir: Path, **construction: Any) -> CanBus:
        """A relative `can_config` resolves against the scenario's folder."""
        files = {k: str(base_dir / v) if v and not Path(str(v)).is_absolute() else v
                 for k, v in construction.items()}
        return cls(name, **files)

    def check(self, given: frozenset[str]) -> list[tuple[str, str, str]]:
        self._given = given
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
        if str(self.fault) not in FAULTS:
            problems.append(("fault", f"fault '{self.fault}' is not a fault of the bus.",
                             f"give one of {', '.join(FAULTS)}."))
        if isinstance(drop := frame_fault(self), str):
            problems.append(("fault_ids", drop, "give identifiers separated by commas (0x00C, "
                             "12, 0x18FF50E5), 'all', or '' for no fault."))
        elif drop is not None and not drop.start < drop.stop:
            problems.append(("fault_stop", f"fault_stop {drop.stop} is not after fault_start "
                             f"{drop.start}.", "give a window with fault_start < fault_stop."))
        log = Path(self.log_file)
        if self.log_file not in ("auto", "") and (log.is_absolute() or ".." in log.parts or
                                                  log.suffix.lower() != ".arrows"):
            problems.append(("log_file", f"log_file '{self.log_file}' must be an .arrows file "
                             f"name inside the results folder.", "give a plain name such as "
                             "bus.arrows, 'auto' or ''."))
        return problems

    def check_peers(self, peers: Mapping[str, Component]) -> list[tuple[str, str, str]]:
        """Two bus blocks bridged to the same python-can bus are one bus joined twice. Whether
        the bus needs the wall clock: a bus outside or a block on the wall clock (a drive, not
        a `can_io` node) joins it (`bus:` naming it)."""
        self._wallclock = bool(self.interface or self.can_config) or any(
            c.needs_realtime and isinstance(getattr(c, "bus", None), str) and
            c.bus and joins(n, c.bus, peers) == self.name  # type: ignore[attr-defined]
            for n, c in peers.items() if c is not self)
        self.can_get_and_set_state = not self._wallclock
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

    def open_terminal(self, name: str, peer: Component, terminal: str
                      ) -> Mapping[str, str] | None:
        """Terminal `name` for `peer`'s bus terminal `terminal`: inputs `name.Rx_Data` and
        `name.Rx_Clock` (what the peer sends), outputs `name.Tx_Data` and `name.Tx_Clock`
        (what the bus tells it)."""
        if name in self.variables:
            return None
        source = getattr(peer, "source_path", None) or getattr(peer, "path", None)  # an FMU's
        if isinstance(peer, CanBus) or (isinstance(source, Path) and is_bus_simulation(source)):
            what = "can_bus blocks" if isinstance(peer, CanBus) else \
                "buses (a can_bus and a bus-simulation FMU)"
            raise ValueError(f"'{peer.name}' and '{self.name}' are both {what}: two buses "
                             f"joined into one")
        if terminal not in peer.terminals:
            return None
        if name in self.peers and self.peers[name] != (peer.name, terminal):
            other, term = self.peers[name]
            raise ValueError(f"terminal '{name}' of can_bus '{self.name}' is '{other}.{term}'s "
                             f"already")
        members = {"Rx_Data": Input(type=BINARY, description=f"operations {peer.name} sends"),
                   "Rx_Clock": Input(type=CLOCK, description=f"ticks when {peer.name} sends"),
                   "Tx_Data": Output(type=BINARY, description=f"operations for {peer.name}"),
                   "Tx_Clock": Output(type=CLOCK, description=f"ticks when the bus tells "
                                      f"{peer.name} something")}
        for member, var in members.items():
            var.name = f"{name}.{member}"
            self.variables[var.name] = var
            self.__dict__[var.name] = var.start
        self.terminals[name] = {m: f"{name}.{m}" for m in members}
        self.peers[name] = (peer.name, terminal)
        self._hosts[name] = peer
        rx = peer.terminals[terminal].get("Rx_Data", "")
        if isinstance(source, Path) and rx in (sizes := max_sizes(source)):
            self._limits[name] = sizes[rx]
        return self.terminals[name]

    # -- life cycle ------------------------------------------------------------------------------
    def prepare(self, run: RunContext) -> None:
        self._run_folder = getattr(run, "folder", None)
        self._start = 0.0
        self._busy = 0.0
        self._set_by = ()
        #: the steps of the last flood_time: (t, a bus error in it, frames sent by whom so far),
        #: and the bus errors so far
        self._flood: tuple[deque[tuple[float, bool, Counter[str]]], int] = (deque(), 0)
        self._flood_told = False
        self.gateway: Gateway | None = None
        drop = frame_fault(self)
        model = CanBusModel(float(self.bitrate), float(self.data_bitrate), bool(self.fd),
                            str(self.stuffing), fault=drop if isinstance(drop, FrameFault)
                            else None)
        stepped = not (self._wallclock or getattr(run, "paced", False))
        channel = channel_of(id(run), self.name)
        self.bus: BusRunner | SteppedBus | None = SteppedBus(self.name, model, channel) \
            if stepped else BusRunner(self.name, channel, model, self._closed)
        self._nodes = {name: LsBusNode(name, peer, terminal, self._limits.get(name))
                       for name, (peer, terminal) in self.peers.items()}
        if stepped:
            self._join(self.bus)
        out = self._run_folder
        name = f"{self.name}_frames.arrows" if self.log_file == "auto" else self.log_file
        # a step taken again (adaptive) takes its events back: the log is written at the end
        period = None if stepped and run.steps_retaken else 0.5
        self.log: FrameLog | None = FrameLog(self.bus, Path(out) / name, period) \
            if self.log_file and out is not None else None

    def setup(self, start: float, stop: float | None) -> None:
        super().setup(start, stop)
        self._start = start
        self.frames = self.errors = self.load = 0.0
        if getattr(self, "bus", None) is None:
            raise HardwareError(self.name, start, "the bus was not prepared by a run. Fix: run "
                                "it in a scenario (twmr run, twmr.simulate).")
        if not (self.interface or self.can_config) or isinstance(self.bus, SteppedBus):
            return
        try:
            options = bus_options(self.interface, self.channel, int(self.bitrate),
                                  self.can_config, self.can_context)
            if options.get("interface") == INTERFACE:
                raise ValueError(f"interface '{INTERFACE}' joins two bus blocks")
            assert isinstance(self.bus, BusRunner)
            self.gateway = Gateway(self.bus, options, describe(options))
        except Exception as err:  # noqa: BLE001 - python-can backends raise many kinds
            raise HardwareError(self.name, start, f"cannot open the python-can bus to bridge "
                                f"({type(err).__name__}: {err}). Fix: check interface, "
                                f"channel and can_config.") from err

    def do_step(self, t: float, h: float) -> None:
        """The frames the terminals sent (each at its tick's time) onto the bus; in run time,
        the bus advanced to t + h; what it told each terminal's FMU since the last step onto
        that terminal's Tx members."""
        bus = self.bus
        assert bus is not None
        if isinstance(bus, BusRunner) and math.isnan(bus.offset):
            bus.begin(t)
            self._join(bus)  # the FMUs hear the bus from their time 0 on
        self._take(bus, t)
        if isinstance(bus, SteppedBus):
            bus.advance(t + h)
        self._t_end = t + h
        d = self.__dict__
        for terminal, node in self._nodes.items():
            told = node.received()
            d[f"{terminal}.Tx_Clock"] = bool(told)
            if told:
                d[f"{terminal}.Tx_Data"] = told
        self.frames = float(bus.counts["transmit"])
        self.errors = float(bus.counts["bus_error"])
        busy = bus.model.busy_time
        self.load = min(1.0, (busy - self._busy) / h)
        self._busy = busy
        self._watch_flood(bus, t, h)

    def _watch_flood(self, bus: BusRunner | SteppedBus, t: float, h: float) -> None:
        """HardwareError once a frame has waited `flood_time` for the bus (in the bus's own
        time, so a stalled process does not count: a flood, naming who sent most over the last
        `flood_time`), or `BAD_SHARE` of the steps over it had a bus error (an error storm,
        naming the last)."""
        if self.flood_time <= 0:
            return
        steps, errors_before = self._flood
        errors = bus.counts["bus_error"]
        with bus_lock(bus):
            waited, bus.model.longest_wait = bus.model.longest_wait, 0.0
        steps.append((t, errors > errors_before, Counter(bus.sent_by)))
        self._flood = (steps, errors)
        while len(steps) > 1 and steps[1][0] <= t + h - self.flood_time + 1e-9 * h:
            steps.popleft()
        span = t + h - steps[0][0]
        flooded = waited >= self.flood_time
        stormy = sum(s[1] for s in steps)
        if not flooded and (span < self.flood_time - 1e-9 * h or
                            stormy < BAD_SHARE * len(steps)):
            return
        first = steps[0]
        window = Counter(bus.sent_by)
        window.subtract(first[2])
        total = sum(window.values())
        if flooded and total:
            who, n = window.most_common(1)[0]
            what = (f"flooded: a frame waited {waited:.3g} s for the bus; over the last "
                    f"{span:.3g} s participant '{who}' sent {n} of the {total} frames")
        else:
            last = bus.last_error
            what = (f"an error storm: over {span:.3g} s from t = {first[0]:.6g} s, {stormy} of "
                    f"{len(steps)} steps had bus errors" +
                    (f", the last: {bus.describe(last)}" if last else ""))
        steps.clear()
        if isinstance(bus, SteppedBus):  # a simulated bus only: the run may study a flood
            if not self._flood_told:
                self._flood_told = True
                log.warning("bus '%s' %s (noted once; on a bus with drives the run would stop)",
                            self.name, what)
            return
        raise HardwareError(self.name, t + h, f"bus '{self.name}' {what}. The run stops, every "
                            f"drive at zero torque and disabled. Fix: find the participant that "
                            f"floods or fails; flood_time: 0 turns the watch off.")

    def _join(self, bus: BusRunner | SteppedBus) -> None:
        for node in self._nodes.values():
            bus.join(node, keeps_open=False)

    def _take(self, bus: BusRunner | SteppedBus, t: float) -> None:
        """Decode what every terminal whose Rx_Clock ticked sent, tick by tick, and act on it."""
        d = self.__dict__
        for terminal, node in self._nodes.items():
            if not d[f"{terminal}.Rx_Clock"]:
                continue
            for tick, raw in tick_parts(d[f"{terminal}.Rx_Data"], t):
                try:
                    sent = ops.decode(raw)
                except ops.BusOperationError as err:
                    raise ComponentError(self.name, tick, self._about(node, raw) +
                                         f": {err}. Fix: the component writes malformed bus "
                                         f"operations; see its log.") from None
                for op in sent:
                    if isinstance(op, (ops.CanTransmit, ops.CanFdTransmit)):
                        bus.submit(node.name, frame_of(op), at=tick)
                    elif isinstance(op, ops.CanXlTransmit):
                        raise ComponentError(self.name, tick, self._about(node, raw) +
                                             f": a CAN XL Transmit (id 0x{op.id:x}), which a "
                                             f"can_bus does not carry (classic CAN and CAN FD "
                                             f"only). Fix: send CAN or CAN FD frames.")
                    elif isinstance(op, ops.Configuration):
                        self._configure(bus, node, op, tick, raw)

    def _about(self, node: LsBusNode, raw: bytes) -> str:
        return (f"bus terminal '{node.name}' ({node.peer}.{node.terminal}.Tx_Data, "
                f"{len(raw)} bytes)")

    def _configure(self, bus: BusRunner | SteppedBus, node: LsBusNode,
                   op: ops.Configuration, t: float, raw: bytes) -> None:
        """An LS-BUS Configuration: the arbitration-lost behaviour of the node, or a bit rate,
        which sets the bus's unless the scenario gave it or another node set it first (then
        it must agree)."""
        model = bus.model
        if op.parameter == ops.CONFIG_ARBITRATION_LOST_BEHAVIOR:
            node.discard = op.value == ops.DISCARD_AND_NOTIFY
            with bus_lock(bus):
                (model.discarding.add if node.discard else model.discarding.discard)(node.name)
            return
        key = {ops.CONFIG_CAN_BAUDRATE: "bitrate",
               ops.CONFIG_CANFD_BAUDRATE: "data_bitrate"}.get(op.parameter)
        if key is None:
            return
        now = getattr(model, key)
        if op.value == now:
            return
        by = dict(self._set_by).get(key, "")
        if key in self._given or by:
            source = by or f"its parameter {key}"
            raise ComponentError(self.name, t, f"{self._about(node, raw)}: a Configuration sets "
                                 f"the {key} to {op.value} bit/s, but the bus runs at "
                                 f"{now:g} bit/s ({source}). Fix: give the can_bus the node's "
                                 f"rate ({key}: {op.value}), or configure the node to the "
                                 f"bus's: every node of a CAN bus runs at one rate.")
        with bus_lock(bus):
            setattr(model, key, float(op.value))
        self._set_by = (*self._set_by, (key, f"set by terminal '{node.name}' at t = {t:.9g} s"))

    def next_event(self, t: float) -> float | None:
        """In run time: the end of the frame on the wire, or the next arbitration."""
        bus = getattr(self, "bus", None)
        upcoming = bus.next_time() if isinstance(bus, SteppedBus) else None
        return upcoming if upcoming is not None and upcoming > t else None

    def get_state(self) -> Any:
        """In run time: the ports, the model and the records, and what waits for each
        terminal."""
        if not isinstance(getattr(self, "bus", None), SteppedBus):
            raise self.no_state("save")
        assert isinstance(self.bus, SteppedBus)
        nodes = tuple((t, tuple(n.inbox), n.discard) for t, n in self._nodes.items())
        return (super().get_state(), self.bus.snapshot(), nodes)

    def set_state(self, state: Any) -> None:
        if not isinstance(getattr(self, "bus", None), SteppedBus):
            raise self.no_state("restore")
        assert isinstance(self.bus, SteppedBus)
        ports, bus, nodes = state
        super().set_state(ports)
        self.bus.restore(bus)
        for terminal, inbox, discard in nodes:
            node = self._nodes[terminal]
            node.inbox.clear()
            node.inbox.extend(inbox)
            node.discard = discard

    def why_no_state(self) -> str:
        return ("a drive or a python-can bus outside joins it: frames on a wire on the wall "
                "clock cannot be rolled back")

    def report(self) -> dict[str, Any]:
        """Frames, bus errors, arbitrations lost, the first problems (each naming the
        participant, the frame and the time) and the bus load over the run."""
        bus = getattr(self, "bus_done", None) or getattr(self, "bus", None)
        if bus is None:
            return {}
        out: dict[str, Any] = {"frames": bus.counts["transmit"],
                               "bus_errors": bus.counts["bus_error"],
                               "arbitration_lost": bus.counts["arbitration_lost"]}
        if str(self.fault_ids).strip():
            out["dropped" if str(self.fault) == "drop" else "faulted"] = \
                bus.counts["dropped"] + bus.counts["faulted"]
        problems = bus.problems()
        if problems:
            out["problems"] = problems[:5]
        return out

    def stopping(self) -> None:
        """The injected fault ends as the run stops, before the hosts send their stop frames
        (zero torque and disable pass, even through a babbling node's flood)."""
        bus = getattr(self, "bus", None)
        if bus is not None:
            with bus_lock(bus):
                bus.model.fault = None

    def terminate(self) -> None:
        """After the components behind its terminals (`terminate_stage`): the frames each
        sent as it terminated (a CAN node FMU's zero torque and disable) go on the wire in
        place of any it had queued; the bus stops when its last participant has left (a drive's
        zero torque and disable still pass, and go out through the link outside), then closes
        that link and writes its log. A fault of the bus ends before the last frames."""
        bus = getattr(self, "bus", None)
        if bus is not None:
            with bus_lock(bus):
                bus.model.fault = None  # a fault ends with the run: the last frames pass
            self._last_frames(bus)
        bus, self.bus = getattr(self, "bus", None), None
        if isinstance(bus, SteppedBus):
            self.bus_done = bus
            bus.close()
            self._closed(bus)
        elif bus is not None:
            self.bus_done = bus
            if math.isnan(bus.offset):
                bus.offset = self._start - time.monotonic()
            bus.close()

    def _last_frames(self, bus: BusRunner | SteppedBus) -> None:
        """What each terminal's component sent as it terminated, on the wire and handed to the
        others (at most 0.5 s of waiting on the wall clock); frames it had queued dropped."""
        at = getattr(self, "_t_end", self._start)
        sent: list[str] = []
        for terminal, node in self._nodes.items():
            host = self._hosts.get(terminal)
            try:
                raw = host.last_sent(node.terminal) if host is not None else b""
            except Exception as err:  # noqa: BLE001 - the bus closes whatever a node does
                bus.failures.append(f"bus '{self.name}': terminal '{node.name}': last_sent "
                                    f"failed ({type(err).__name__}: {err})")
                raw = b""
            with bus_lock(bus):
                bus.model.drop(node.name)
            try:
                frames = [frame_of(op) for op in ops.decode(raw)
                          if isinstance(op, (ops.CanTransmit, ops.CanFdTransmit))]
            except ops.BusOperationError as err:
                bus.failures.append(f"bus '{self.name}': {self._about(node, raw)} at terminate: "
                                    f"{err}")
                continue
            for frame in frames:
                bus.submit(node.name, frame, at=at if isinstance(bus, SteppedBus) else None)
            if frames:
                sent.append(node.name)
        if isinstance(bus, SteppedBus):
            bus.advance(at + 1.0)
            return
        for name in sent:
            if not bus.handed(name, 0.5):
                bus.failures.append(f"bus '{self.name}': the last frames of terminal '{name}' "
                                    f"were not all on the wire within 0.5 s")

    def _closed(self, bus: BusCore) -> None:
        """The bus has stopped: close the link outside, write the log."""
        gateway, self.gateway = getattr(self, "gateway", None), None
        if gateway is not None:
            gateway.close()
        log, self.log = getattr(self, "log", None), None
        if log is not None:
            log.close()
            if log.error:
                bus.failures.append(f"bus '{self.name}': frame log {log.path.name}: {log.error}")


def bus_lock(bus: BusRunner | SteppedBus) -> Any:
    """The lock under which the bus's model may be changed (its thread reads it)."""
    return bus._cond  # noqa: SLF001 - the block owns its bus


def drive_options(own: str, ref: str, run: Any, participant: str) -> dict[str, Any]:
    """python-can options that join participant `participant` of component `own` to the bus
    block `ref` of the run `run`; ValueError when there is none."""
    for name in candidates(own, ref):
        channel = channel_of(id(run), name)
        if runner(channel) is not None:
            return {"interface": INTERFACE, "channel": channel, "participant": participant}
    raise ValueError(f"no can_bus '{ref}' is running in this run")
