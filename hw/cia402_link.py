"""Host side of CiA 402 drives through the `canopen` package (the `cia402` protocol): one network,
one RemoteNode per axis with the object dictionary of its EDS/DCF (used unchanged).

Configuration (SDO, pre-operational): modes of operation 0x6060 = 10 (cyclic synchronous torque),
motor rated torque 0x6076 read back, max torque 0x6072 written from the torque limit when the
dictionary has it, RPDO1 = controlword 0x6040 + target torque 0x6071 (applied at once),
TPDO1 = statusword 0x6041 + velocity actual 0x606C and TPDO2 = position actual 0x6064 (both on
every SYNC), with the predefined connection set's COB-IDs (0x200/0x180/0x280 + node); then NMT
start and the power state machine to OPERATION ENABLED. Each period: RPDO1 per axis, then one
SYNC; the TPDOs that answer it give the round trip. Heartbeats are consumed, EMCY frames and error
frames latch a fault, and so does a drive leaving OPERATION ENABLED.
"""
from __future__ import annotations

import contextlib
import functools
import logging
import math
import struct
import threading
import time
from collections.abc import Sequence
from dataclasses import replace
from importlib import resources
from pathlib import Path
from typing import Any, ClassVar

import can
import canopen

from twmr.hw import c_nodes
from twmr.hw import cia402 as c
from twmr.hw.bus import FrameLog, describe, discard_unsent, frame_text, strict_canopen
from twmr.hw.cia402 import State
from twmr.hw.link import STOP_CONFIRM_S, STOP_RESEND_S, DriveSpec, Emulator, Link, Signals
from twmr.hw.safety import Fault, LinkError

log = logging.getLogger("twmr.hw")
_KEYS = {c.STATUSWORD: "status", c.VELOCITY_ACTUAL: "rpm", c.POSITION_ACTUAL: "inc"}
SHIPPED_EDS = "maxon_epos4_module_50-5.eds"


def eds_path(spec: DriveSpec) -> str:
    """The drives' EDS/DCF: `spec.options.eds`, or the shipped maxon EPOS4 EDS."""
    return spec.options.eds or str(resources.files("twmr.hw") / "data" / SHIPPED_EDS)


class Cia402Link(Link):
    """CiA 402 axes `spec.nodes` (wheel order) on one CANopen network over python-can
    `options`."""

    #: CANopen nodes are 1..127 (0 is the NMT broadcast); the host's heartbeat takes 127
    node_range: ClassVar[range] = range(1, 127)
    default_nodes: ClassVar[tuple[int, int]] = (1, 2)
    Options: ClassVar[type] = c.Cia402Options
    c_node: ClassVar[Any] = c_nodes.CIA402
    signal_units: ClassVar[dict[str, str]] = {
        "torque_command": "N.m", "angle": "rad", "speed": "rad/s", "statusword": "",
        "controlword": ""}

    def __init__(self, spec: DriveSpec, options: dict[str, Any], log: FrameLog | None = None):
        problems = self.check(spec)
        if problems:
            raise LinkError(Fault(None, problems[0][1].rstrip("."), problems[0][2]))
        self.spec = spec
        self.nodes, self.gear = tuple(spec.nodes), spec.gear
        self.increments_per_rev = spec.options.increments_per_rev
        self.default_rated = spec.options.rated_torque
        eds = eds_path(spec)
        self.log = log
        self.lock = threading.Lock()
        self.values = {n: {"status": 0, "rpm": 0, "inc": 0, "stamp": 0.0} for n in self.nodes}
        self.beats = {n: time.monotonic() for n in self.nodes}  # grace until the first one
        self.fault: Fault | None = None
        self.fault_at = math.nan  # perf_counter() when the fault was latched
        self.running = False
        self.rtt_ns: list[int] = []
        self._pending: set[tuple[int, int]] = set()
        self._sync_ns = 0
        self._replied = threading.Event()
        self.rx: dict[int, tuple[Any, Any, Any]] = {}  # RPDO1, controlword, target torque
        self.rated: dict[int, int] = {}  # 0x6076 [mN.m]
        self.foreign_malformed = 0  # undecodable frames that no drive of ours sent
        self.protected: dict[int, bool] = {}  # heartbeat consumer and abort option written
        self.host_beat: Any = None  # the host's heartbeat producer (a periodic frame)
        self.network = canopen.Network()
        try:
            self.network.connect(**options)
        except (can.CanError, OSError, ValueError, ImportError) as err:
            raise LinkError(Fault(None, f"cannot open {describe(options)} ({err})",
                                  "check the adapter and the interface/channel/bitrate or "
                                  "can_config parameters")) from err
        notifier, bus = self.network.notifier, self.network.bus
        assert notifier is not None and bus is not None  # connect() made them
        if log is not None:
            notifier.add_listener(log.received)
            raw_send = bus.send

            def logged_send(msg: can.Message, timeout: float | None = None) -> None:
                raw_send(msg, timeout)
                log.sent(msg)

            bus.send = logged_send  # type: ignore[method-assign]
        notifier.add_listener(self._on_frame)
        self.guard = strict_canopen(self.network, self._malformed)
        self.nodes_od: dict[int, Any] = {}
        for n in self.nodes:
            node = canopen.RemoteNode(n, canopen.import_od(str(eds), n))
            self.network.add_node(node)
            node.emcy.add_callback(functools.partial(self._on_emcy, n))
            node.nmt.add_heartbeat_callback(functools.partial(self._on_beat, n))
            self.nodes_od[n] = node

    @classmethod
    def check(cls, spec: DriveSpec) -> list[tuple[str, str, str]]:
        """The EDS/DCF exists; rated torque and encoder resolution are positive."""
        if spec.options.eds and not Path(spec.options.eds).is_file():
            return [("eds", f"the EDS/DCF {spec.options.eds} does not exist.",
                     "give the drive's description file (relative paths are against the "
                     "scenario's folder), or leave eds: out for the shipped maxon EPOS4 EDS.")]
        for key in ("rated_torque", "increments_per_rev"):
            if getattr(spec.options, key) <= 0:
                return [(key, f"{key} is {getattr(spec.options, key)}; it scales every torque or "
                         f"position frame and must be positive.",
                         "give the motor's rated torque in mN.m (0x6076) and the encoder's "
                         "increments per motor turn.")]
        return []

    @classmethod
    def decode(cls, msg: can.Message, spec: DriveSpec) -> Signals:
        """The PDOs this link maps (RPDO1 0x200+n: controlword, target torque; TPDO1 0x180+n:
        statusword, velocity; TPDO2 0x280+n: position), SYNC, EMCY and heartbeats."""
        ident, data = msg.arbitration_id, bytes(msg.data)
        base, node = ident & 0x780, ident & 0x7F
        if ident == 0x080:
            return [(None, "sync", 1.0)]
        if base == c.RPDO1:
            word, permille = c.decode_rpdo1(data)
            return [(node, "controlword", word), (node, "torque_command",
                    c.permille_to_torque(permille, spec.gear, spec.options.rated_torque))]
        if base == c.TPDO1:
            word, rpm = c.decode_tpdo1(data)
            return [(node, "statusword", word), (node, "speed", c.velocity_to_si(rpm, spec.gear))]
        if base == 0x280:
            (inc,) = struct.unpack_from("<i", data)
            return [(node, "angle",
                     c.position_to_si(inc, spec.gear, spec.options.increments_per_rev))]
        if base == 0x080 and node:
            return [(node, "emcy", struct.unpack_from("<H", data)[0])]
        if base == 0x700:
            return [(node, "heartbeat", struct.unpack_from("<B", data)[0])]
        return []

    @classmethod
    def emulate(cls, spec: DriveSpec, options: dict[str, Any]) -> tuple[Emulator, DriveSpec]:
        from twmr.hw.cia402_emulator import Cia402Emulator

        eds = eds_path(spec)
        emulator = Cia402Emulator(spec.nodes, eds, options, spec.gear, spec.options.rated_torque,
                                  spec.options.increments_per_rev)
        return emulator, replace(spec, options=replace(spec.options, eds=eds))

    # -- bus ------------------------------------------------------------------------------------
    def _on_frame(self, msg: can.Message) -> None:
        if msg.is_error_frame:
            self._latch(Fault(None, f"error frame received ({msg.data.hex() or 'no data'})",
                              "check termination, bitrate and wiring"))

    def _malformed(self, msg: can.Message | None, exc: Exception) -> None:
        """A frame canopen or we cannot decode: a fault of the drive when one of ours sent it
        (EMCY, TPDO, SDO answer, heartbeat), else counted and logged."""
        node = msg.arbitration_id & 0x7F if msg is not None else None
        function = msg.arbitration_id & 0x780 if msg is not None else None
        if node not in self.values or function not in (0x080, 0x180, 0x280, 0x380, 0x480,
                                                       0x580, 0x700):
            self.foreign_malformed += 1
            log.warning("ignored a malformed frame %s not sent by a drive (%s)",
                        frame_text(msg), exc)
            return
        self._latch(Fault(node,
                          f"malformed frame {frame_text(msg)} ({type(exc).__name__}: {exc})",
                          "check the drive's PDO mapping against its EDS/DCF and that no other "
                          "device uses this node id"))

    def _on_emcy(self, n: int, e: Any) -> None:
        self._latch(Fault(n, f"EMCY 0x{e.code:04x} ({e.get_desc() or 'no description'}), error "
                          f"register 0x{e.register:02x}",
                          "read the drive's error history 0x1003, then fault-reset"))

    def _on_beat(self, n: int, state: int) -> None:
        with self.lock:
            self.beats[n] = time.monotonic()
        if self.running and state != 0x05:  # 5: OPERATIONAL
            names = {0x04: "STOPPED", 0x7F: "PRE-OPERATIONAL", 0x00: "INITIALISING"}
            self._latch(Fault(n, f"NMT state {names.get(state, hex(state))} in its heartbeat "
                              f"(PDOs stopped)", "check who sent an NMT command on the bus"))

    def _latch(self, fault: Fault) -> None:
        with self.lock:
            if self.fault is None:
                self.fault = fault
                self.fault_at = time.perf_counter()

    def _on_tpdo(self, n: int, number: int, pdo: Any) -> None:
        now_ns = time.perf_counter_ns()
        with self.lock:
            fb = self.values[n]
            for var in pdo.map:
                key = _KEYS.get(var.index)
                if key:
                    fb[key] = int(var.raw)
            fb["stamp"] = time.monotonic()
            if (n, number) in self._pending:
                self._pending.discard((n, number))
                if not any(m == n for m, _ in self._pending):
                    self.rtt_ns.append(now_ns - self._sync_ns)
                if not self._pending:
                    self._replied.set()
            state = c.decode_statusword(fb["status"])
        if self.running and state != State.OPERATION_ENABLED:
            self._latch(Fault(n, f"left OPERATION ENABLED ({state.value})",
                              "read the drive's error history 0x1003, then fault-reset"))

    # -- life cycle ------------------------------------------------------------------------------
    def configure(self, torque_limit: float, host_timeout: float) -> None:
        """SDO configuration and PDO mapping of every axis, then NMT start. Drive-side
        protection where the dictionary has it: each drive consumes the host's heartbeat
        (0x1016, timeout `host_timeout` [s]) and faults when it is lost (0x6007 = 1), so a host
        that dies or loses the bus stops the drives without a word from it."""
        ms = max(1, min(0xFFFF, round(host_timeout * 1e3)))
        for n, node in self.nodes_od.items():
            node.nmt.state = "PRE-OPERATIONAL"
            od = node.object_dictionary
            if c.HEARTBEAT_CONSUMER in od:
                node.sdo[c.HEARTBEAT_CONSUMER][1].raw = (c.HOST_NODE << 16) | ms
            if c.ABORT_CONNECTION in od:
                node.sdo[c.ABORT_CONNECTION].raw = c.ABORT_FAULT
            self.protected[n] = c.HEARTBEAT_CONSUMER in od and c.ABORT_CONNECTION in od
            node.sdo[c.MODES_OF_OPERATION].raw = c.CYCLIC_SYNC_TORQUE
            self.rated[n] = int(node.sdo[c.MOTOR_RATED_TORQUE].raw) or self.default_rated
            if c.MAX_TORQUE in node.object_dictionary:
                node.sdo[c.MAX_TORQUE].raw = c.limit_to_permille(torque_limit, self.gear,
                                                                 self.rated[n])
            node.rpdo.read(from_od=True)
            node.tpdo.read(from_od=True)
            for maps in (node.rpdo, node.tpdo):
                for m in maps.map.values():
                    m.enabled = False
            r = node.rpdo[1]
            r.clear()
            cw, tt = r.add_variable(c.CONTROLWORD), r.add_variable(c.TARGET_TORQUE)
            # the predefined connection set's COB-IDs, written explicitly: a DCF made for one
            # node (node 1) carries that node's ids, which would clash on a second drive
            r.cob_id, r.trans_type, r.enabled = 0x200 + n, 255, True
            t1, t2 = node.tpdo[1], node.tpdo[2]
            t1.clear()
            t1.add_variable(c.STATUSWORD)
            t1.add_variable(c.VELOCITY_ACTUAL)
            t2.clear()
            t2.add_variable(c.POSITION_ACTUAL)
            for t, base in ((t1, 0x180), (t2, 0x280)):
                t.cob_id, t.trans_type, t.enabled = base + n, 1, True
            node.rpdo.save()
            node.tpdo.save()
            t1.add_callback(lambda m, n=n: self._on_tpdo(n, 1, m))
            t2.add_callback(lambda m, n=n: self._on_tpdo(n, 2, m))
            self.rx[n] = (r, cw, tt)
        self.host_beat = _HostHeartbeat(self, host_timeout / 4)
        for node in self.nodes_od.values():
            node.nmt.state = "OPERATIONAL"

    def start(self, timeout: float) -> None:
        """Configure, then walk every axis to OPERATION ENABLED (fault reset first if needed);
        `LinkError` when an axis does not answer or is not enabled in time."""
        try:
            self.configure(self.spec.torque_limit, self.spec.heartbeat_timeout)
        except (canopen.SdoCommunicationError, canopen.SdoAbortedError) as err:
            raise LinkError(Fault(None, f"SDO configuration of nodes {self.nodes} failed "
                                  f"({err})", "check node ids, power, the EDS and the bus")
                            ) from err
        deadline = time.monotonic() + timeout
        previous = {n: 0 for n in self.nodes}
        while time.monotonic() < deadline:
            states = self.states()
            if all(s == State.OPERATION_ENABLED for s in states.values()):
                self.running = True
                return
            words = {n: c.next_controlword(s) for n, s in states.items()}
            # fault reset acts on a rising edge: send 0 first when it was already high
            words = {n: (0 if w == c.FAULT_RESET and previous[n] == c.FAULT_RESET else w)
                     for n, w in words.items()}
            self._send(words, {})
            previous = words
            time.sleep(0.003)
        late = next(n for n, s in self.states().items() if s != State.OPERATION_ENABLED)
        raise LinkError(Fault(late, f"not OPERATION ENABLED after {timeout} s "
                              f"({self.states()[late].value}; EMCY: {self.fault})",
                              "check the drive's faults and power"))

    def states(self) -> dict[int, State]:
        with self.lock:
            return {n: c.decode_statusword(v["status"]) for n, v in self.values.items()}

    def _send(self, controls: dict[int, int], torques: dict[int, float]) -> None:
        """RPDO1 to every axis, then one SYNC."""
        try:
            for n, (pdo, cw, tt) in self.rx.items():
                cw.raw = controls[n]
                tt.raw = c.torque_to_permille(torques.get(n, 0.0), self.gear, self.rated[n])
                pdo.transmit()
            with self.lock:
                self._replied.clear()
                self._pending = {(n, k) for n in self.nodes for k in (1, 2)}
                self._sync_ns = time.perf_counter_ns()
            self.network.sync.transmit()
        except can.CanError as err:
            raise LinkError(Fault(None, f"send failed ({err}): bus-off or adapter lost",
                                  "check wiring, termination and bitrate")) from err

    def command(self, torques: Sequence[float]) -> tuple[float, ...]:
        """Target torques [N.m] with ENABLE OPERATION, then SYNC; the torques the drives receive
        (per mille of the rated torque)."""
        self._send({n: c.ENABLE_OPERATION for n in self.nodes},
                   dict(zip(self.nodes, torques, strict=False)))
        return tuple(c.permille_to_torque(c.torque_to_permille(v, self.gear, self.rated[n]),
                                          self.gear, self.rated[n])
                     for n, v in zip(self.nodes, torques, strict=False))

    def wait_feedback(self, timeout: float) -> bool:
        """Wait up to `timeout` [s] for the TPDOs answering the last SYNC."""
        return self._replied.wait(timeout)

    def feedback(self) -> list[tuple[float, float, float]]:
        """(wheel angle [rad], wheel speed [rad/s], monotonic time of the TPDO) per axis."""
        with self.lock:
            vals = [dict(self.values[n]) for n in self.nodes]
        return [(c.position_to_si(v["inc"], self.gear, self.increments_per_rev),
                 c.velocity_to_si(v["rpm"], self.gear), v["stamp"]) for v in vals]

    def heartbeats(self) -> dict[int, float]:
        with self.lock:
            return dict(self.beats)

    def protection(self) -> dict[int, tuple[bool, str]]:
        ms = round(self.spec.heartbeat_timeout * 1e3)
        return {n: (True, f"heartbeat consumer 0x1016 (host node {c.HOST_NODE}, {ms} ms) with "
                          f"0x6007 = fault") if self.protected.get(n) else
                (False, "the EDS/DCF has no heartbeat consumer 0x1016 or abort option 0x6007")
                for n in self.nodes}

    def disable(self, emergency: bool = False, confirm: float = STOP_CONFIRM_S) -> list[int]:
        """Zero torque with DISABLE VOLTAGE (emergency) or SHUTDOWN to every axis, then SYNC,
        the frames still waiting to be sent discarded first where the interface can; sent again
        (every `STOP_RESEND_S` at most) until each axis's statusword, in a TPDO since, is out of
        OPERATION ENABLED, for up to `confirm` [s]; the nodes that did not confirm."""
        self.running = False
        discard_unsent(self.network.bus)
        word = c.DISABLE_VOLTAGE if emergency else c.SHUTDOWN
        t0 = time.monotonic()
        deadline = t0 + confirm
        left = list(self.nodes)
        while True:
            with contextlib.suppress(LinkError):
                self._send({n: word for n in self.nodes}, {})
            self._replied.wait(max(0.0, min(STOP_RESEND_S, deadline - time.monotonic())))
            with self.lock:
                left = [n for n in left if not (
                    self.values[n]["stamp"] > t0 and
                    c.decode_statusword(self.values[n]["status"]) != State.OPERATION_ENABLED)]
            if not left or time.monotonic() >= deadline:
                return left

    def close(self) -> None:
        """Stop the host's heartbeat and disconnect the network."""
        if self.host_beat is not None:
            self.host_beat.stop()
        self.network.disconnect()


class _HostHeartbeat:
    """The host's heartbeat (node `HOST_NODE`, state OPERATIONAL) every `period` [s], from its
    own thread; a failed send (bus-off) latches a bus fault and ends it, never the process."""

    def __init__(self, link: Cia402Link, period: float):
        self.link, self.period = link, period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="cia402-host-heartbeat",
                                         daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            try:
                self.link.network.send_message(0x700 + c.HOST_NODE, b"\x05")
            except Exception as err:  # noqa: BLE001 - any failure is a bus fault, latched
                self.link._latch(Fault(None, f"heartbeat send failed ({err}): bus-off or "
                                       f"adapter lost", "check wiring, termination and bitrate"))
                return

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=1.0)
