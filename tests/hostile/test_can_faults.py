"""Hostile CAN traffic while a drive pair runs (python-can `virtual` bus, emulated drives).

Every fault case starts a `CanMotorDrive` ('motor') with its emulated drives on a fresh virtual
channel, opens an INDEPENDENT monitor (a plain python-can Bus on that channel, before the first
step and so before the fault) and a third-party bus, steps the pair at the host period H, injects
the fault, and asserts:

* the run stops with `twmr.core.HardwareError` whose message names the block ('motor'), the node
  ("drive node <n>") or "the CAN bus", and the frame or the cause;
* it stops within the case's stated number of host periods (the paced loop spends at least H of
  wall time per step; watchdog_periods N = `WATCHDOG` here, sized for a loaded machine), plus
  the periods the machine held the test's loop back meanwhile (`Paced.behind`);
* the emulated drives are left without torque (ODrive: not CLOSED_LOOP; CiA 402: not
  OPERATION ENABLED);
* after `terminate()`, the LAST commands the monitor saw for each node are a zero torque followed
  by the disable: ODrive Set_Input_Torque 0.0 then Set_Axis_State IDLE or Estop; CiA 402 an RPDO1
  carrying target torque 0 with a controlword that disables (shutdown or disable voltage);
* no thread (host or emulated drives) dies of an unhandled exception.

A bus-off makes every send of the host fail, so the drives must stop by themselves (their own
watchdogs); the bus then recovers and `terminate()` must still end in zero torque and disable.
A duplicate node (a second emulated drive with an id of the pair) must not crash the host: the run
goes on or trips with a message; an ODrive duplicate that reports IDLE must trip.

The emulator-robustness cases send malformed frames TO the emulated drives: the emulator's threads
must live on and the drive must keep answering (state kept, torque still tracked, probes answered).
"""
from __future__ import annotations

import gc
import math
import struct
import sys
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import can
import canopen
import pytest

from tests.hw_bench import WATCHDOG, H, Paced, channel, started
from twmr.core import HardwareError
from twmr.hw import cia402 as c
from twmr.hw import protocol as p
from twmr.hw.cia402 import State

N = WATCHDOG  # watchdog_periods of every case
ODRIVE_NODES, CIA_NODES = (0, 1), (1, 2)


@pytest.fixture(autouse=True)
def _fast_canopen_shutdown(monkeypatch: pytest.MonkeyPatch) -> None:
    """canopen's notifier polls the bus every second, so each `disconnect()` waits up to 1 s:
    a shorter cycle only makes the tear-down of these many drive pairs quicker."""
    monkeypatch.setattr(canopen.Network, "NOTIFIER_CYCLE", 0.05)


@pytest.fixture
def deaths(monkeypatch: pytest.MonkeyPatch) -> Any:
    """Threads that died of an unhandled exception during the case: each test asserts there are
    none, for the host's threads as for the emulated drives' (in a `twmr run` such a death is a
    traceback on stderr and a service that stopped)."""
    died: list[str] = []
    previous = threading.excepthook

    def hook(args: Any) -> None:
        name = args.thread.name if args.thread is not None else "?"
        died.append(f"{name}: {args.exc_type.__name__}: {args.exc_value}")
        previous(args)

    monkeypatch.setattr(threading, "excepthook", hook)
    yield died


def assert_no_thread_died(died: list[str]) -> None:
    assert not died, "a thread died of an unhandled exception: " + "; ".join(died)


@pytest.fixture(autouse=True)
def _paced_like_the_master() -> Any:
    """`open_bench` does what the master does before a paced run (full collection, gc.freeze,
    a 0.2 ms thread switch interval), just before the drive starts; undone here. Without it a
    full collection of the test process's heap stalls every thread for 15-30 ms now and then,
    and the host watchdog trips on a healthy drive pair."""
    switch = sys.getswitchinterval()
    yield
    gc.unfreeze()
    sys.setswitchinterval(switch)


# -- the bench ------------------------------------------------------------------------------
class Monitor:
    """Every frame on a virtual channel from its opening on (an independent python-can Bus)."""

    def __init__(self, ch: str):
        self.bus = can.Bus(interface="virtual", channel=ch)
        self.closed = False

    def frames(self) -> list[can.Message]:
        out = []
        msg = self.bus.recv(timeout=0.05)
        while msg is not None:
            out.append(msg)
            msg = self.bus.recv(timeout=0.05)
        self.close()
        return out

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            self.bus.shutdown()


@dataclass
class Bench:
    """A started drive pair ('motor') on channel `ch`, a third-party bus, extra emulators."""

    drive: Any
    ch: str
    protocol: str
    other: can.BusABC
    extra: list[Any] = field(default_factory=list)   # more emulators (duplicate nodes)
    restore: list[Callable[[], None]] = field(default_factory=list)
    closed: bool = False

    @property
    def emu(self) -> Any:
        return self.drive.emulators[0]

    @property
    def options(self) -> dict[str, Any]:
        return {"interface": "virtual", "channel": self.ch}

    def send(self, ident: int, data: bytes = b"", **kw: Any) -> None:
        self.other.send(can.Message(arbitration_id=ident, data=data, is_extended_id=False,
                                    **kw))

    def close(self) -> None:
        """Undo the injected faults (the bus recovers), terminate() the drive, close the rest."""
        if self.closed:
            return
        self.closed = True
        for fn in self.restore:
            fn()
        try:
            self.drive.terminate()
        finally:
            for emu in self.extra:
                emu.close()
            self.other.shutdown()


def open_bench(protocol: str, **params: Any) -> Bench:
    ch = channel()
    gc.collect()  # before the drive starts: its feedback is fresh at the first step
    gc.freeze()
    sys.setswitchinterval(2e-4)
    drive = started(protocol, channel=ch, **{"watchdog_periods": N, **params})
    return Bench(drive, ch, protocol, can.Bus(interface="virtual", channel=ch))


#: how long a run may go on after a fault before the test gives up on a trip [s of wall time]:
#: a loaded machine may hold the host's notifier thread back for tens of periods before it
#: reads the frame; once it is read, the next step must trip (checked by the caller)
PATIENCE = 3.0


def run_to_trip(loop: Paced, limit: int) -> tuple[int, HardwareError]:
    """Steps (the tripping one included) until the drive stops the run, and its error; at
    least `limit` host periods and `PATIENCE` s of wall time before it fails the test."""
    before = loop.steps
    loop.mark()
    t0 = time.perf_counter()
    try:
        loop.run(limit)
        while time.perf_counter() - t0 < PATIENCE:
            loop.run(10)
    except HardwareError as err:
        return loop.steps - before + 1, err
    pytest.fail(f"no HardwareError within {loop.steps - before} host periods and "
                f"{PATIENCE:g} s after the fault: the run went on", pytrace=False)


def notifier_threads(bench: Bench) -> list[threading.Thread]:
    link = bench.drive.link
    notifier = link.notifier if bench.protocol == "odrive" else link.network.notifier
    return [t for t in notifier._readers if isinstance(t, threading.Thread)]


# -- what the monitor saw -------------------------------------------------------------------
def _show(m: can.Message) -> str:
    return f"0x{m.arbitration_id:03x} [{m.dlc}] {bytes(m.data).hex(' ') or '-'}"


def odrive_commands(frames: list[can.Message], node: int) -> list[can.Message]:
    """Host commands that move an ODrive axis: Set_Input_Torque, Set_Axis_State, Estop."""
    keep = (p.SET_INPUT_TORQUE, p.SET_AXIS_STATE, p.ESTOP)
    return [m for m in frames if not (m.is_error_frame or m.is_remote_frame)
            and p.split_id(m.arbitration_id) in {(node, k) for k in keep}]


def cia_rpdo1(frames: list[can.Message], node: int) -> list[can.Message]:
    return [m for m in frames if not (m.is_error_frame or m.is_remote_frame)
            and m.arbitration_id == 0x200 + node]


def disables(word: int) -> bool:
    """A controlword that takes the drive out of OPERATION ENABLED without a quick stop:
    shutdown (xxxx x110) or disable voltage (xxxx xx0x), fault reset bit clear."""
    return not word & 0x80 and ((word & 0x07) == c.SHUTDOWN or not word & 0x02)


def assert_zero_then_disabled(frames: list[can.Message], protocol: str,
                              nodes: tuple[int, ...]) -> None:
    """Per node, the last commands the monitor saw: zero torque, then the disable."""
    for node in nodes:
        if protocol == "odrive":
            cmds = odrive_commands(frames, node)
            tail = " | ".join(_show(m) for m in cmds[-4:]) or "nothing"
            assert len(cmds) >= 2, f"node {node}: monitor saw only {tail}"
            torque, last = cmds[-2], cmds[-1]
            cmd_t, cmd_l = p.split_id(torque.arbitration_id)[1], p.split_id(last.arbitration_id)[1]
            assert cmd_t == p.SET_INPUT_TORQUE and len(torque.data) == 8 and \
                p.decode_torque(bytes(torque.data), 1.0) == 0.0, \
                f"node {node}: the last commands are not a zero torque then the disable: {tail}"
            idle = cmd_l == p.SET_AXIS_STATE and len(last.data) >= 4 and \
                int.from_bytes(bytes(last.data[:4]), "little") == p.AXIS_IDLE
            assert cmd_l == p.ESTOP or idle, \
                f"node {node}: the last command is not Set_Axis_State IDLE or Estop: {tail}"
        else:
            rpdos = cia_rpdo1(frames, node)
            tail = " | ".join(_show(m) for m in rpdos[-3:]) or "nothing"
            assert rpdos, f"node {node}: the monitor saw no RPDO1"
            last = rpdos[-1]
            assert len(last.data) >= 4, f"node {node}: short last RPDO1: {tail}"
            word, permille = struct.unpack_from("<Hh", bytes(last.data))
            assert permille == 0 and disables(word), \
                (f"node {node}: the last RPDO1 is controlword 0x{word:04x}, target torque "
                 f"{permille} per mille, not zero torque with shutdown/disable voltage: {tail}")


def assert_was_driving(frames: list[can.Message], protocol: str, nodes: tuple[int, ...]) -> None:
    """The monitor saw non-zero torque commands to every node before the fault."""
    for node in nodes:
        if protocol == "odrive":
            values = [p.decode_torque(bytes(m.data), 1.0) for m in odrive_commands(frames, node)
                      if p.split_id(m.arbitration_id)[1] == p.SET_INPUT_TORQUE
                      and len(m.data) == 8]
        else:
            values = [struct.unpack_from("<Hh", bytes(m.data))[1]
                      for m in cia_rpdo1(frames, node) if len(m.data) >= 4]
        assert any(v != 0 for v in values), f"node {node}: never driven (monitor)"


def assert_drives_off(bench: Bench) -> None:
    """The emulated drives (and any duplicate) hold no torque and are out of operation."""
    for emu in [bench.emu, *bench.extra]:
        for node, axis in emu.axes.items():
            if bench.protocol == "odrive":
                assert axis.state != p.AXIS_CLOSED_LOOP and axis.torque == 0.0, \
                    f"emulated node {node}: state {axis.state}, torque {axis.torque}"
            else:
                assert axis.state != State.OPERATION_ENABLED, \
                    f"emulated node {node}: still {axis.state.value}, target {axis.torque}"


# -- fault injections -------------------------------------------------------------------------
Inject = Callable[[Bench], None]


def frame(ident: int, data: bytes) -> Inject:
    return lambda b: b.send(ident, data)


def f32x2(a: float, v: float) -> bytes:
    return struct.pack("<ff", a, v)


def error_frame(b: Bench) -> None:
    b.other.send(can.Message(is_error_frame=True, arbitration_id=0x20000004,
                             data=bytes([0, 0x10, 0, 0, 0, 0, 0, 0])))


def odrive_silent(b: Bench) -> None:
    b.emu.silent = True


def cia_silent(b: Bench) -> None:
    b.emu.network.unsubscribe(0x080)  # the drives stop answering SYNC


def odrive_heartbeat_stops(b: Bench) -> None:
    b.emu.heartbeat_period = 1e9  # estimates go on, heartbeats stop after the next one


def cia_heartbeat_stops(b: Bench) -> None:
    b.emu.axes[2].node.nmt.stop_heartbeat()


def odrive_axis_error(b: Bench) -> None:
    b.emu.axes[1].error |= 0x1  # INITIALIZING / any bit: reported in the next heartbeat


def cia_emcy(b: Bench) -> None:
    b.emu.axes[2].inject_fault(0x2310)


def bus_off(b: Bench) -> None:
    bus = b.drive.link.bus if b.protocol == "odrive" else b.drive.link.network.bus

    def dead(msg: can.Message, timeout: float | None = None) -> None:
        raise can.CanOperationError("Bus-off")

    bus.send = dead
    b.restore.append(lambda: bus.__dict__.pop("send", None))


def duplicate_odrive(closed_loop: bool) -> Inject:
    def inject(b: Bench) -> None:
        from twmr.hw.emulator import OdriveEmulator

        dup = OdriveEmulator((1,), b.options)
        if closed_loop:
            with dup.lock:
                dup.axes[1].state, dup.axes[1].control_mode = p.AXIS_CLOSED_LOOP, \
                    p.CONTROL_TORQUE
        b.extra.append(dup)
    return inject


def duplicate_cia(b: Bench) -> None:
    from twmr.hw.cia402_emulator import Cia402Emulator
    from twmr.hw.cia402_link import eds_path

    b.extra.append(Cia402Emulator((2,), eds_path(b.drive.spec()), b.options, 1.0,
                                  int(b.drive.rated_torque), int(b.drive.increments_per_rev)))


@dataclass(frozen=True)
class Case:
    id: str
    protocol: str
    inject: Inject
    expect: tuple[str, ...]   # every one of these is in the error's message
    within: int               # host periods from the fault to the HardwareError
    params: tuple[tuple[str, Any], ...] = ()
    settle: float = 0.03      # before the drives' state is checked [s]
    frame_fault: bool = True  # a frame on the bus: the host's notifier must live on


HB_PERIOD = 0.1  # the ODrive emulator's heartbeat period [s]
AFTER_BEAT = int(HB_PERIOD / H) + 2  # a fault an ODrive reports in its next heartbeat


def _cases() -> list[Case]:
    cases: list[Case] = []
    # short DLC on every identifier a drive sends
    for cmd, name in ((p.HEARTBEAT, "heartbeat"), (p.GET_ENCODER_ESTIMATES, "encoder")):
        ident = p.can_id(1, cmd)
        for dlc in range(8):
            cases.append(Case(f"odrive-short-{name}-dlc{dlc}", "odrive",
                              frame(ident, bytes(range(1, dlc + 1))),
                              ("drive node 1", f"malformed frame 0x{ident:03x} [{dlc}]"), 2))
    for base, name, full in ((0x180, "tpdo1", 6), (0x280, "tpdo2", 4), (0x700, "heartbeat", 1),
                             (0x080, "emcy", 8)):
        ident = base + 2
        for dlc in range(full):
            cases.append(Case(f"cia402-short-{name}-dlc{dlc}", "cia402",
                              frame(ident, bytes(range(1, dlc + 1))),
                              ("drive node 2", f"malformed frame 0x{ident:03x} [{dlc}]"), 2))
    # wrong payloads
    enc = p.can_id(1, p.GET_ENCODER_ESTIMATES)
    for tag, data in (("nan-position", f32x2(math.nan, 0.0)), ("nan-speed", f32x2(0.0, math.nan)),
                      ("inf-speed", f32x2(0.0, math.inf))):
        cases.append(Case(f"odrive-encoder-{tag}", "odrive", frame(enc, data),
                          ("drive node 1", f"0x{enc:03x}"), 2))
    hb_idle = p.encode_heartbeat(1, p.Heartbeat(0, p.AXIS_IDLE), "0.6.10")
    cases.append(Case("odrive-heartbeat-reports-idle", "odrive", frame(*hb_idle),
                      ("drive node 1", "state 1"), 2))
    cases.append(Case("cia402-tpdo1-statusword-matches-no-state", "cia402",
                      frame(0x182, struct.pack("<Hi", 0x0001, 0)),
                      ("drive node 2", "0x182"), 2))
    cases.append(Case("cia402-tpdo1-statusword-fault", "cia402",
                      frame(0x182, struct.pack("<Hi", c.statusword(State.FAULT), 0)),
                      ("drive node 2", "fault"), 2))
    # the bus itself
    for proto in ("odrive", "cia402"):
        cases.append(Case(f"{proto}-error-frame", proto, error_frame,
                          ("the CAN bus", "error frame"), 2))
        cases.append(Case(f"{proto}-bus-off", proto, bus_off,
                          ("the CAN bus", "send failed", "Bus-off"), 1,
                          settle=0.25 if proto == "odrive" else 0.45, frame_fault=False))
    # third parties
    cases.append(Case("odrive-estop-from-a-third-party", "odrive", frame(*p.encode_estop(1)),
                      ("drive node 1", "axis error 0x2000000"), AFTER_BEAT))
    cases.append(Case("cia402-quick-stop-from-a-third-party", "cia402",
                      frame(0x202, struct.pack("<Hh", c.QUICK_STOP, 0)),
                      ("drive node 2", "quick stop"), 3))
    cases.append(Case("cia402-nmt-stop-from-a-third-party", "cia402", frame(0x000, b"\x02\x02"),
                      ("drive node 2",), int(0.05 / H) + N + 2))
    cases.append(Case("cia402-emcy-from-a-third-party", "cia402",
                      frame(0x081, struct.pack("<HB5s", 0x3210, 0x04, b"")),
                      ("drive node 1", "EMCY 0x3210"), 2))
    # drives that fail
    cases.append(Case("odrive-silent-drive", "odrive", odrive_silent,
                      ("drive node 0", "no feedback frame"), N + 1, settle=0.15,
                      frame_fault=False))
    cases.append(Case("cia402-silent-drive", "cia402", cia_silent,
                      ("drive node 1", "no feedback frame"), N + 1, frame_fault=False))
    cases.append(Case("odrive-heartbeat-loss", "odrive", odrive_heartbeat_stops,
                      ("drive node", "heartbeat lost"), int((0.3 + HB_PERIOD) / H) + 2,
                      params=(("heartbeat_timeout", 0.3),), frame_fault=False))
    cases.append(Case("cia402-heartbeat-loss", "cia402", cia_heartbeat_stops,
                      ("drive node 2", "heartbeat lost"), int((0.3 + 0.05) / H) + 2,
                      params=(("heartbeat_timeout", 0.3),), frame_fault=False))
    cases.append(Case("odrive-axis-error", "odrive", odrive_axis_error,
                      ("drive node 1", "axis error 0x1"), AFTER_BEAT, frame_fault=False))
    cases.append(Case("cia402-emcy-from-the-drive", "cia402", cia_emcy,
                      ("drive node 2", "EMCY 0x2310"), 2, frame_fault=False))
    # a second device answering as node 1 / 2
    cases.append(Case("odrive-duplicate-node-idle", "odrive", duplicate_odrive(False),
                      ("drive node 1", "state 1"), AFTER_BEAT))
    return cases


CASES = _cases()


@pytest.mark.parametrize("case", CASES, ids=[k.id for k in CASES])
def test_fault_stops_the_run_with_zero_torque_and_the_drives_disabled(case: Case,
                                                                     deaths: list[str]) -> None:
    # a case that is not about missing feedback gives the host's watchdog ten times its room:
    # on a loaded machine an emulated drive's thread can be held back past N periods, and the
    # host would trip on that first (it did, in CI, before node 1's heartbeat reported IDLE)
    silent = any("no feedback frame" in e for e in case.expect)
    room = {} if silent else {"watchdog_periods": 10 * N}
    for attempt in range(3):
        if _checked(case, room, deaths, last=attempt == 2):
            return


def _checked(case: Case, room: dict[str, Any], deaths: list[str], last: bool) -> bool:
    """One run of `case`; False (to run it again) when, on a case about a drive that falls
    silent, the host's watchdog tripped on another drive first: a thread of that emulated drive
    held back past the watchdog by a loaded machine, not the fault."""
    bench = open_bench(case.protocol, **{**room, **dict(case.params)})
    nodes = ODRIVE_NODES if case.protocol == "odrive" else CIA_NODES
    mon = Monitor(bench.ch)
    loop = Paced(bench.drive)
    try:
        loop.run(10)
        case.inject(bench)
        steps, err = run_to_trip(loop, case.within + 60)
        text = str(err)
        assert "component 'motor'" in text, text
        if not last and "no feedback frame" in text and case.expect[0] not in text:
            return False
        for part in case.expect:
            assert part in text, f"{part!r} not in: {text}"
        link = bench.drive.link
        latched = link.fault_at if link is not None else math.nan
        if math.isfinite(latched):  # a frame the host latched: the next step that looks trips
            after = sum(s >= latched for s in loop.starts[-steps:])
            assert after <= 2, f"{after} steps began after the fault was latched: {text}"
        else:  # the host watchdog, on the wall clock
            # + 1: the bus thread may hand the frame over just after a step looked; a late
            # step delays the frame and the trip
            bound = case.within + 1 + 2 * loop.behind
            assert steps <= bound, f"tripped after {steps} host periods (> {case.within} + " \
                f"{loop.behind} the machine held the loop back): {text}"
        if case.frame_fault:
            threads = notifier_threads(bench)
            assert threads and all(t.is_alive() for t in threads), "the host's notifier died"
        time.sleep(case.settle)
        assert_drives_off(bench)
        bench.close()  # terminate(): zero torque and disable again, bus and emulators closed
        frames = mon.frames()
        assert_was_driving(frames, case.protocol, nodes)
        assert_zero_then_disabled(frames, case.protocol, nodes)
        assert_no_thread_died(deaths)
        return True
    finally:
        bench.close()
        mon.close()


DUPLICATES = [("odrive-duplicate-node-closed-loop", "odrive", duplicate_odrive(True)),
              ("cia402-duplicate-node", "cia402", duplicate_cia)]


@pytest.mark.parametrize("name, protocol, inject", DUPLICATES, ids=[d[0] for d in DUPLICATES])
def test_duplicate_node_never_crashes_the_host(name: str, protocol: str, inject: Inject,
                                               deaths: list[str]) -> None:
    """A second emulated drive answering under a node id of the pair: ODrive node 1 already in
    closed loop without error (its heartbeats look right, its estimates do not); CiA 402 node 2
    not started (pre-operational, switch on disabled). Decided: no crash, and the run either goes
    on for 200 periods with the host's notifier alive, or trips with a HardwareError naming
    'motor' and a node or the bus; either way terminate() ends in zero torque and disable."""
    bench = open_bench(protocol)
    nodes = ODRIVE_NODES if protocol == "odrive" else CIA_NODES
    mon = Monitor(bench.ch)
    loop = Paced(bench.drive)
    try:
        loop.run(10)
        inject(bench)
        try:
            loop.run(200)
        except HardwareError as err:
            text = str(err)
            assert "component 'motor'" in text and ("drive node" in text or "CAN bus" in text), \
                text
            time.sleep(0.03)
            assert_drives_off(bench)
        else:
            threads = notifier_threads(bench)
            assert threads and all(t.is_alive() for t in threads), "the host's notifier died"
        bench.close()
        assert_zero_then_disabled(mon.frames(), protocol, nodes)
        assert_no_thread_died(deaths)
    finally:
        bench.close()
        mon.close()


# -- malformed frames sent TO the emulated drives ---------------------------------------------
@dataclass(frozen=True)
class ToDrive:
    id: str
    protocol: str
    ident: int
    data: bytes


TO_DRIVE = [
    ToDrive("odrive-1-byte-set-input-torque", "odrive", p.can_id(0, p.SET_INPUT_TORQUE), b"\x01"),
    ToDrive("odrive-empty-set-axis-state", "odrive", p.can_id(0, p.SET_AXIS_STATE), b""),
    ToDrive("odrive-3-byte-set-limits", "odrive", p.can_id(0, p.SET_LIMITS), b"\x00\x00\x80"),
    ToDrive("cia402-1-byte-rpdo1", "cia402", 0x201, b"\x0f"),
    ToDrive("cia402-3-byte-rpdo1-disable-voltage", "cia402", 0x201, b"\x00\x00\x05"),
    ToDrive("cia402-sync-with-1-byte", "cia402", 0x080, b"\x07"),
    ToDrive("cia402-sync-with-8-bytes", "cia402", 0x080, bytes(range(8))),
    ToDrive("cia402-1-byte-nmt", "cia402", 0x000, b"\x02"),
    ToDrive("cia402-empty-sdo-request", "cia402", 0x601, b""),
]


def answers(bench: Bench) -> list[str]:
    """Probes from the third party, and what the emulated drives send back within 0.2 s:
    ODrive an encoder request (RTR) to node 0; CiA 402 a SYNC and an SDO upload of the
    statusword of node 1. Returns the frames missing from the answers."""
    while bench.other.recv(timeout=0) is not None:
        pass  # what the third-party bus queued so far
    if bench.protocol == "odrive":
        enc = p.can_id(0, p.GET_ENCODER_ESTIMATES)
        bench.send(enc, is_remote_frame=True, dlc=8)
        wanted = {enc: 8}
    else:
        bench.send(0x080)
        bench.send(0x601, bytes([0x40, 0x41, 0x60, 0x00, 0, 0, 0, 0]))
        wanted = {0x181: 6, 0x182: 6, 0x281: 4, 0x282: 4, 0x581: 8}
    deadline = time.monotonic() + 0.2
    while wanted and time.monotonic() < deadline:
        msg = bench.other.recv(timeout=0.01)
        if msg is not None and not msg.is_remote_frame and \
                wanted.get(msg.arbitration_id) == len(msg.data):
            del wanted[msg.arbitration_id]
    return [f"0x{k:03x} [{v}]" for k, v in wanted.items()]


@pytest.mark.parametrize("case", TO_DRIVE, ids=[k.id for k in TO_DRIVE])
def test_malformed_frame_to_an_emulated_drive_leaves_it_running(case: ToDrive,
                                                                deaths: list[str]) -> None:
    """The emulated drive drops the frame: its threads live on, it keeps its state and keeps
    tracking the host's torque (50 more periods without a trip), and it answers probes. The host
    itself may refuse a malformed frame it decodes too (NMT reaches every node), but only by
    naming that frame; any other trip means the drive reacted to the frame."""
    bench = open_bench(case.protocol)
    loop = Paced(bench.drive)
    try:
        loop.run(10)
        emu = bench.emu
        limits = {n: (a.speed_limit, a.current_limit) for n, a in emu.axes.items()} \
            if case.protocol == "odrive" else {}
        bench.send(case.ident, case.data)
        tripped: HardwareError | None = None
        try:
            loop.run(50, torque=(0.5, -0.5))
        except HardwareError as err:
            tripped = err
        if tripped is not None:
            assert f"malformed frame 0x{case.ident:03x} [{len(case.data)}]" in str(tripped), \
                f"the run tripped after a malformed frame to the drive: {tripped}"
        else:
            now = time.monotonic()
            ages = [now - fb[2] for fb in bench.drive.link.feedback()]
            assert max(ages) < N * H, f"the drive stopped answering: feedback ages {ages}"
        if case.protocol == "odrive":
            assert emu._thread.is_alive(), "the emulator's thread died"
            for n, axis in emu.axes.items():
                assert (axis.speed_limit, axis.current_limit) == limits[n], f"node {n}: limits"
                if tripped is None:
                    assert axis.state == p.AXIS_CLOSED_LOOP, f"node {n}: state {axis.state}"
            if tripped is None:
                assert [emu.axes[n].command for n in ODRIVE_NODES] == [0.5, -0.5]
        else:
            assert emu._watch.is_alive(), "the emulator's watchdog thread died"
            readers = [t for t in emu.network.notifier._readers if isinstance(t, threading.Thread)]
            assert readers and all(t.is_alive() for t in readers), "the emulator's notifier died"
            if tripped is None:
                for n, axis in emu.axes.items():
                    assert axis.state == State.OPERATION_ENABLED, f"node {n}: {axis.state.value}"
                torques = [emu.axes[n].torque for n in CIA_NODES]
                assert all(abs(t - w) < 0.05
                           for t, w in zip(torques, (0.5, -0.5), strict=True)), torques
        missing = answers(bench)
        assert not missing, f"the emulated drive no longer answers: no {', '.join(missing)}"
        assert_no_thread_died(deaths)
    finally:
        bench.close()


# -- the frame log ------------------------------------------------------------------------------
def run_logging(protocol: str, ch: str, folder: Any, fail_log: bool = False) -> Any:
    """A drive pair on virtual channel `ch` with its frame log in `folder`, stepped 100 times
    and terminated (its log failing at its first frame, as on a full disk, when `fail_log`)."""
    from types import SimpleNamespace

    from twmr.hw.drive import CanMotorDrive

    gc.collect()
    gc.freeze()
    sys.setswitchinterval(2e-4)
    drive = CanMotorDrive("motor", protocol=protocol, channel=ch,
                          watchdog_periods=N, log_file="auto",
                          node_ids=ODRIVE_NODES if protocol == "odrive" else CIA_NODES)
    drive.prepare(SimpleNamespace(folder=folder, step=H, paced=True))
    loop = Paced(drive)
    try:
        drive.setup(0.0, None)
        if fail_log:
            def full(msg: can.Message) -> None:
                raise OSError(28, "No space left on device")

            drive.log._writer.on_message_received = full
        drive.initialize()
        loop.t0 = time.perf_counter()
        try:
            loop.run(100)
        except HardwareError as err:
            pytest.fail(f"the run stopped while logging frames: {err}", pytrace=False)
    finally:
        drive.terminate()
    return drive


@pytest.mark.parametrize("protocol", ["odrive", "cia402"])
@pytest.mark.parametrize("name", ["ending-in-70000", "digits"])
def test_frame_log_on_a_channel_named_with_a_large_number(protocol: str, name: str,
                                                          tmp_path: Any,
                                                          deaths: list[str]) -> None:
    """A virtual channel (or any interface's channel) whose name ends in a number above 65535
    (python-can's BLF writer turns the trailing digits into a 16-bit channel number), or is
    that number (python-can makes the channel an int). Logging must not stop the run, and never
    as a 'malformed frame' of a drive; the log holds every frame sent and received."""
    from twmr.hw.replay import Decoder, decode_log

    ch = str(10**9 + uuid.uuid4().int % 10**9) if name == "digits" else f"{channel()}-70000"
    mon = Monitor(ch)
    drive = run_logging(protocol, ch, tmp_path)
    assert "frame_log_error" not in drive.report()
    decoder = Decoder(protocol=protocol)
    decoded = decode_log(tmp_path / "motor_frames.blf", decoder)
    torques = [d for d in decoded if d.direction == "Tx" and d.signal == "torque_command"]
    assert len(torques) >= 100 * 2, f"{len(torques)} torque commands in the log"
    # the speeds on the wire (an independent listener) from the log's first frame to the last
    # one the host received are those the log holds: how many the drives sent in that time
    # depends on how the machine schedules their threads, that the log misses none does not
    speeds = sorted(d.time for d in decoded if d.direction == "Rx" and d.signal == "speed")
    first = min(d.time for d in decoded)
    wire = sorted(m.timestamp for m in mon.frames() if first <= m.timestamp <= speeds[-1]
                  and any(signal == "speed" for _, signal, _ in decoder(m)))
    assert len(speeds) > 20 and speeds == wire, (len(speeds), len(wire))
    assert_no_thread_died(deaths)


def test_frame_log_that_cannot_be_written_is_reported_and_the_run_goes_on(
        tmp_path: Any, caplog: pytest.LogCaptureFixture, deaths: list[str]) -> None:
    """A frame log that fails (a full disk) ends there; the run goes on, and its report and a
    warning at terminate name the log and the error (a run once left an empty log unnoticed)."""
    import logging

    with caplog.at_level(logging.WARNING, logger="twmr.hw"):
        drive = run_logging("odrive", channel(), tmp_path, fail_log=True)
    error = "OSError: [Errno 28] No space left on device"
    assert drive.report()["frame_log_error"] == error
    warned = [r.getMessage() for r in caplog.records if r.name == "twmr.hw"]
    assert warned == [f"motor: the frame log {tmp_path / 'motor_frames.blf'} ended early "
                      f"({error}); the frames after that are not in it"]
    assert_no_thread_died(deaths)
