"""`emulated_drives` guards its ODrives as real ones set up for a bench: the axis watchdog is armed
from power-up (`watchdog`, as saved with odrivetool), so a host that enables the axes and then
falls silent (a crash, a bus lost, an importer that never sends the FMU's last frames) sees them
go to IDLE with WATCHDOG_TIMER_EXPIRED and zero torque. The host here is plain python-can frames
encoded by twmr.hw.protocol on a virtual bus; asserted on the emulator's own log of state
changes. `watchdog: 0` leaves the axes as from the factory: they stay in closed loop."""
from __future__ import annotations

import time
import uuid

import can
import pytest

from twmr.hw import protocol as p
from twmr.hw.emulated_drives import EmulatedDrives
from twmr.hw.link import protocol

WATCHDOG = 0.1  # [s]
SLACK = 0.3  # emulator thread delay tolerated on a loaded machine [s]
WAIT = 3.0  # longest wait for the emulator's log entry [s]


def drives(watchdog: float) -> tuple[object, can.BusABC]:
    """The emulated drives `emulated_drives` starts (its spec), and a host bus beside them."""
    block = EmulatedDrives("drives", watchdog=watchdog, torque_constant=0.8, encoder_period=0.0)
    options = {"interface": "virtual", "channel": f"w-{uuid.uuid4().hex[:10]}"}
    emu, _ = protocol("odrive").emulate(block._spec(), options)  # noqa: SLF001 - its spec
    return emu, can.Bus(interface="virtual", channel=options["channel"])


def enable_then_fall_silent(host: can.BusABC) -> None:
    for node in (0, 1):
        for ident, data in (p.encode_controller_mode(node, p.CONTROL_TORQUE, 1),
                            p.encode_axis_state(node, p.AXIS_CLOSED_LOOP)):
            host.send(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
    for _ in range(10):
        for node, tau in ((0, 2.0), (1, -2.0)):
            ident, data = p.encode_torque(node, tau, 1.0)
            host.send(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
        time.sleep(0.01)


def trips(emu: object, node: int) -> list[object]:
    bit = p.error_bit("watchdog", "0.6.10")
    return [e for e in list(emu.events) if e.node == node and e.error & bit]  # type: ignore[attr-defined]


@pytest.mark.timeout(60)
def test_the_armed_watchdog_stops_the_axes_when_the_host_falls_silent() -> None:
    emu, host = drives(WATCHDOG)
    try:
        enable_then_fall_silent(host)
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not (trips(emu, 0) and trips(emu, 1)):
            time.sleep(0.01)
        for node in (0, 1):
            found = trips(emu, node)
            assert found, f"node {node}: no watchdog trip within {WAIT} s"
            first = found[0]
            assert first.state == p.AXIS_IDLE and first.torque == 0.0  # type: ignore[attr-defined]
            quiet = first.time - first.last_command  # type: ignore[attr-defined]
            assert WATCHDOG <= quiet <= WATCHDOG + SLACK, quiet
    finally:
        emu.close()  # type: ignore[attr-defined]
        host.shutdown()


@pytest.mark.timeout(60)
def test_watchdog_zero_leaves_the_axes_in_closed_loop() -> None:
    emu, host = drives(0.0)
    try:
        enable_then_fall_silent(host)
        time.sleep(3 * WATCHDOG)
        assert not trips(emu, 0) and not trips(emu, 1)
        assert [a.state for a in emu.axes.values()] == [p.AXIS_CLOSED_LOOP] * 2  # type: ignore[attr-defined]
    finally:
        emu.close()  # type: ignore[attr-defined]
        host.shutdown()
