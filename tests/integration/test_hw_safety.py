"""Every safety path triggered on purpose, on python-can's virtual bus with emulated drives: each
ends in zero torque with the drives disabled, within the stated number of host periods.

The host watchdog is `watchdog_periods` = N = `WATCHDOG` periods of H = 2 ms (sized for a loaded
machine). The paced loop spends at least H of wall time per step, so a fault the host detects by
time (stale feedback, heartbeat loss) trips within N + 1 steps of its cause; a fault the bus
reports (EMCY, error frame, bus-off) trips at the first step after the frame arrives (asserted:
within 2 steps); an ODrive axis error is reported by its next heartbeat (every 100 ms: within 52
steps). Each bound adds the steps a loaded machine made the loop run late (`Paced.behind`, 0 on
a machine that keeps the pace)."""
from __future__ import annotations

import time
from typing import Any

import can
import pytest

from tests.hw_bench import WATCHDOG, H, Monitor, Paced, channel, eventually, started
from twmr.core import HardwareError
from twmr.hw import cia402 as c402
from twmr.hw import protocol as p
from twmr.hw.cia402 import State

N = WATCHDOG  # watchdog_periods


def steps_to_trip(loop: Paced, limit: int = 400) -> tuple[int, HardwareError]:
    """Steps run until the drive stops the run (HardwareError), less those a loaded machine made
    run late (`Paced.behind`), and the error."""
    before = loop.steps
    loop.mark()
    with pytest.raises(HardwareError) as info:
        loop.run(limit)
    return loop.steps - before + 1 - 2 * loop.behind, info.value


def steps_after_fault(loop: Paced, link: Any, limit: int = 400) -> tuple[int, HardwareError]:
    """Steps run until the drive stops the run, counting only those that started after the
    link's bus thread latched the fault (`link.fault`: when that thread got the frame depends
    on the machine's load, what the host does next does not), and the error."""
    counted = 0
    with pytest.raises(HardwareError) as info:
        for _ in range(limit):
            counted += link.fault is not None
            loop.run(1)
    return counted, info.value


def last_commands(frames: list[can.Message]) -> dict[int, tuple[float, int]]:
    """Per ODrive node: the last torque sent and the last state-changing command id."""
    out: dict[int, tuple[float, int]] = {}
    for m in frames:
        node, cmd = p.split_id(m.arbitration_id)
        torque, last = out.get(node, (float("nan"), 0))
        if cmd == p.SET_INPUT_TORQUE:
            out[node] = (p.decode_torque(m.data, 1.0), last)
        elif cmd in (p.ESTOP, p.SET_AXIS_STATE):
            out[node] = (torque, cmd)
    return out


def test_silent_drive_trips_the_host_watchdog_within_n_plus_one_periods() -> None:
    ch = channel()
    d = started(channel=ch, watchdog_periods=N)
    loop = Paced(d)
    try:
        loop.run(20)
        mon = Monitor(ch)
        d.emulators[0].silent = True
        _, err = steps_to_trip(loop)
        assert "drive node 0: no feedback frame" in str(err) and "'motor'" in str(err)
        # counted from the last frame the host's bus thread stamped (when that thread ran on a
        # loaded machine is not the host's doing), the tripping step included
        last = d.link.estimates[0][2] + time.perf_counter() - time.monotonic()  # on starts' clock
        steps = sum(start > last for start in loop.starts) - 2 * loop.behind
        assert steps <= N + 1, steps
        assert last_commands(mon.frames()) == {0: (0.0, p.ESTOP), 1: (0.0, p.ESTOP)}
    finally:
        d.terminate()


def test_heartbeat_loss_is_a_hardware_error_and_disables_the_drives() -> None:
    d = started(heartbeat_timeout=0.3)
    loop = Paced(d)
    try:
        loop.run(10)
        d.emulators[0].heartbeat_period = 1e9  # estimates go on, heartbeats stop
        steps, err = steps_to_trip(loop)
        assert "heartbeat lost" in str(err)
        assert steps <= (0.3 + 0.1) / H + 1  # timeout plus the last beat's age (<= 100 ms)
        axes = d.emulators[0].axes.values()
        assert eventually(lambda: all(a.torque == 0.0 and a.state == p.AXIS_IDLE for a in axes))
        assert all(a.error & p.error_bit("estop", "0.6.10") for a in axes)
    finally:
        d.terminate()


def test_estop_from_the_bus_is_a_hardware_error() -> None:
    ch = channel()
    # the estop shows in the next heartbeat (<= 100 ms): the host's and the drives' watchdogs
    # get ten times that, so a loaded machine's late step trips neither first
    d = started(channel=ch, watchdog_periods=10 * N, drive_watchdog=1.0)
    other = can.Bus(interface="virtual", channel=ch)
    loop = Paced(d)
    try:
        loop.run(10)
        other.send(can.Message(arbitration_id=p.can_id(1, p.ESTOP), data=b"",
                               is_extended_id=False))
        steps, err = steps_to_trip(loop)
        assert "drive node 1: axis error 0x2000000" in str(err)
        assert steps <= 0.1 / H + 2  # seen in the next heartbeat (every 100 ms)
        assert eventually(lambda: all(a.torque == 0.0 and a.state == p.AXIS_IDLE
                                      for a in d.emulators[0].axes.values()))
    finally:
        d.terminate()
        other.shutdown()


@pytest.mark.parametrize("protocol", ["odrive", "cia402"])
def test_error_frame_on_the_bus_stops_the_run(protocol: str) -> None:
    ch = channel()
    d = started(protocol, channel=ch)
    other = can.Bus(interface="virtual", channel=ch)
    loop = Paced(d)
    try:
        loop.run(10)
        other.send(can.Message(is_error_frame=True, arbitration_id=0x20000004,
                               data=bytes([0, 0x10, 0, 0, 0, 0, 0, 0])))
        steps, err = steps_after_fault(loop, d.link)
        assert "the CAN bus: error frame received" in str(err) and steps <= 1
        emu = d.emulators[0]
        if protocol == "odrive":
            assert eventually(lambda: all(a.torque == 0.0 and a.state == p.AXIS_IDLE
                                          for a in emu.axes.values()))
        else:
            assert eventually(lambda: all(a.state == State.SWITCH_ON_DISABLED
                                          for a in emu.axes.values()))
            assert all(a.torque == 0.0 or a.state != State.OPERATION_ENABLED
                       for a in emu.axes.values())
    finally:
        d.terminate()
        other.shutdown()


def test_bus_off_stops_the_run_and_the_drives_stop_themselves() -> None:
    d = started()
    loop = Paced(d)
    try:
        loop.run(10, torque=(2.0, 2.0))

        def bus_off(msg: can.Message, timeout: float | None = None) -> None:
            raise can.CanOperationError("Bus-off")

        d.link.bus.send = bus_off
        steps, err = steps_to_trip(loop)
        assert "send failed (Bus-off): bus-off or adapter lost" in str(err) and steps == 1
        time.sleep(0.2)  # nothing reaches the drives: their command watchdog (0.1 s) acts
        for axis in d.emulators[0].axes.values():
            assert axis.torque == 0.0 and axis.error & p.error_bit("watchdog", "0.6.10")
    finally:
        d.terminate()


def test_quiet_host_makes_the_odrive_stop_itself() -> None:
    d = started()
    try:
        Paced(d).run(10, torque=(2.0, 2.0))
        time.sleep(0.3)  # host sends nothing: the drive's own watchdog (0.1 s) must act
        axis = d.emulators[0].axes[0]
        assert axis.state == p.AXIS_IDLE and axis.torque == 0.0
        assert axis.error & p.error_bit("watchdog", "0.6.10")
    finally:
        d.terminate()


def test_emcy_trips_within_two_periods_and_disables_every_cia402_drive() -> None:
    d = started("cia402")
    loop = Paced(d)
    try:
        loop.run(10)
        d.emulators[0].axes[2].inject_fault(0x2310)
        steps, err = steps_to_trip(loop)
        assert "drive node 2: EMCY 0x2310" in str(err) and steps <= 2
        axes = d.emulators[0].axes
        assert eventually(lambda: axes[2].state == State.FAULT
                          and axes[1].state == State.SWITCH_ON_DISABLED)
        assert axes[1].torque == 0.0 and axes[2].torque == 0.0
    finally:
        d.terminate()


def test_silent_cia402_drive_trips_the_host_watchdog() -> None:
    d = started("cia402", watchdog_periods=N)
    loop = Paced(d)
    try:
        loop.run(10)
        d.emulators[0].network.unsubscribe(0x080)  # the drives stop answering SYNC
        steps, err = steps_to_trip(loop)
        assert "no feedback frame" in str(err) and steps <= N + 1
    finally:
        d.terminate()


def test_quiet_host_makes_the_cia402_drive_fault_itself() -> None:
    d = started("cia402")
    try:
        Paced(d).run(10)
        time.sleep(0.6)  # no SYNC: the drive-side watchdog (0.25 s) faults the drive
        assert d.emulators[0].axes[1].state == State.FAULT
        assert d.emulators[0].axes[1].torque == 0.0
        with pytest.raises(HardwareError, match="EMCY 0x8130"):
            Paced(d).run(10)
    finally:
        d.terminate()


@pytest.mark.parametrize("protocol", ["odrive", "cia402"])
def test_terminate_sends_zero_torque_and_disables(protocol: str) -> None:
    ch = channel()
    d = started(protocol, channel=ch)
    Paced(d).run(10, torque=(2.0, 2.0))
    mon = Monitor(ch)
    emu = d.emulators[0]
    d.terminate()
    frames = mon.frames()
    if protocol == "odrive":
        assert last_commands(frames) == {0: (0.0, p.SET_AXIS_STATE), 1: (0.0, p.SET_AXIS_STATE)}
        idle = [m for m in frames if p.split_id(m.arbitration_id)[1] == p.SET_AXIS_STATE]
        assert all(int.from_bytes(m.data[:4], "little") == p.AXIS_IDLE for m in idle)
    else:
        assert [a.state for a in emu.axes.values()] == [State.READY, State.READY]
        assert [a.torque for a in emu.axes.values()] == [0.0, 0.0]


def test_short_torque_frame_is_dropped_and_the_emulated_drive_keeps_running() -> None:
    ch = channel()
    d = started(channel=ch)
    other = can.Bus(interface="virtual", channel=ch)
    loop = Paced(d)
    try:
        loop.run(10)
        other.send(can.Message(arbitration_id=p.can_id(0, p.SET_INPUT_TORQUE), data=b"\x01",
                               is_extended_id=False))
        loop.run(50)  # the emulator still answers: no trip
        emu = d.emulators[0]
        assert emu.malformed == 1 and emu._thread.is_alive()
        assert emu.axes[0].state == p.AXIS_CLOSED_LOOP and emu.axes[0].command == 1.0
    finally:
        d.terminate()
        other.shutdown()


@pytest.mark.parametrize("cmd", [p.GET_ENCODER_ESTIMATES, p.HEARTBEAT])
def test_short_frame_from_a_drive_trips_naming_the_frame_and_the_notifier_lives(cmd) -> None:
    ch = channel()
    d = started(channel=ch)
    other = can.Bus(interface="virtual", channel=ch)
    loop = Paced(d)
    try:
        loop.run(10)
        mon = Monitor(ch)
        other.send(can.Message(arbitration_id=p.can_id(1, cmd), data=b"\x00\x01",
                               is_extended_id=False))
        steps, err = steps_after_fault(loop, d.link)
        text = str(err)
        assert f"drive node 1: malformed frame 0x{p.can_id(1, cmd):03x} [2] 00 01" in text
        assert steps <= 1
        readers = [t for t in d.link.notifier._readers if hasattr(t, "is_alive")]
        assert d.link.guard.count == 1 and readers and all(t.is_alive() for t in readers)
        d.terminate()  # the emulated drives stop sending, so the monitor's queue ends
        assert last_commands(mon.frames()) == {0: (0.0, p.ESTOP), 1: (0.0, p.ESTOP)}
    finally:
        d.terminate()
        other.shutdown()


def test_short_heartbeat_from_a_cia402_drive_trips_naming_it() -> None:
    ch = channel()
    d = started("cia402", channel=ch)
    other = can.Bus(interface="virtual", channel=ch)
    loop = Paced(d)
    try:
        loop.run(10)
        other.send(can.Message(arbitration_id=0x700 + 2, data=b"", is_extended_id=False))
        steps, err = steps_after_fault(loop, d.link)
        assert "drive node 2: malformed frame 0x702 [0]" in str(err) and steps <= 1
        time.sleep(0.05)
        for axis in d.emulators[0].axes.values():
            assert axis.state != State.OPERATION_ENABLED
    finally:
        d.terminate()
        other.shutdown()


def test_cia402_drives_consume_the_host_heartbeat_and_fault_when_it_stops() -> None:
    """The host writes 0x1016 (consumer of its heartbeat) and 0x6007 = fault at start-up; when
    the host falls silent (bus-off, crash) the drives fault by themselves. The SYNC watchdog is
    switched off here so that only the heartbeat consumer can act."""
    from twmr.hw import cia402 as c

    d = started("cia402", heartbeat_timeout=0.3)  # a loaded machine keeps 0.3 s
    loop = Paced(d)
    try:
        emu = d.emulators[0]
        emu.sync_timeout = 1e9
        loop.run(200)  # several of the host's beats (every 75 ms) heard by the drives
        for n, axis in emu.axes.items():
            assert int(axis.node.sdo[c.HEARTBEAT_CONSUMER][1].raw) == (c.HOST_NODE << 16) | 300
            assert int(axis.node.sdo[c.ABORT_CONNECTION].raw) == c.ABORT_FAULT
            assert axis.state == State.OPERATION_ENABLED and d.link.protected[n]
        d.link.host_beat.stop()  # the host is gone: no heartbeat, no SYNC, no torque frames
        time.sleep(1.0)
        for axis in emu.axes.values():
            assert axis.state == State.FAULT and axis.torque == 0.0
    finally:
        d.terminate()


def test_a_lost_stop_frame_is_sent_again_until_the_heartbeat_reports_idle() -> None:
    """The first IDLE request to node 0 is lost on the way (as a UDP bus may lose it): the stop
    is sent again until the drive's heartbeat reports IDLE, and no axis is left running."""
    ch = channel()
    d = started(channel=ch)
    Paced(d).run(10, torque=(2.0, 2.0))
    link, emu = d.link, d.emulators[0]
    send, lost = link._send, []

    def lossy(ident: int, data: bytes) -> None:
        if p.split_id(ident) == (0, p.SET_AXIS_STATE) and not lost:
            lost.append(ident)
            return
        send(ident, data)

    link._send = lossy
    try:
        assert link.disable() == []
        # node 0's first IDLE never left: it is idle because the stop was sent again
        assert lost and [a.state for a in emu.axes.values()] == [p.AXIS_IDLE, p.AXIS_IDLE]
        assert [a.torque for a in emu.axes.values()] == [0.0, 0.0]
    finally:
        d.terminate()


def test_drives_that_do_not_confirm_the_stop_are_named(caplog: pytest.LogCaptureFixture
                                                        ) -> None:
    ch = channel()
    d = started(channel=ch)
    Paced(d).run(10)
    d.emulators[0].silent = True  # dead drives: no heartbeat confirms anything
    t0 = time.monotonic()
    assert d.link.disable(confirm=0.3) == [0, 1]
    assert time.monotonic() - t0 >= 0.3  # it waited for them, and no longer than asked for
    with caplog.at_level("ERROR"):
        d.terminate()
    assert "drive node(s) 0, 1 did not confirm the stop" in caplog.text


def test_a_cia402_stop_is_sent_again_until_every_statusword_leaves_operation() -> None:
    """The first SHUTDOWN to node 1 is lost: the stop goes out again with SYNC until node 1's
    statusword (TPDO1) is out of OPERATION ENABLED; dead drives are named after the wait."""
    d = started("cia402")
    Paced(d).run(10, torque=(2.0, 2.0))
    link, emu = d.link, d.emulators[0]
    pdo = link.rx[1][0]
    transmit, lost = pdo.transmit, []

    def lossy() -> None:
        if not lost and link.rx[1][1].raw == c402.SHUTDOWN:
            lost.append(True)
            return
        transmit()

    pdo.transmit = lossy
    try:
        assert link.disable() == []
        assert lost and [a.state for a in emu.axes.values()] == [State.READY, State.READY]
        assert [a.torque for a in emu.axes.values()] == [0.0, 0.0]
    finally:
        d.terminate()
    dead = started("cia402")
    Paced(dead).run(10)
    dead.emulators[0].close()  # no TPDO answers any more
    try:
        assert dead.link.disable(confirm=0.3) == [1, 2]
    finally:
        dead.terminate()
