"""Drives left in closed loop when the bus is lost: only the drive's own watchdog can stop them.

With ODrive firmware 0.6.x the host sets the axis watchdog through RxSdo at start-up
(`axis0.config.watchdog_timeout` = `drive_watchdog`, `enable_watchdog` = true) and reads both
back through TxSdo; the emulated ODrive arrives with its watchdog off, as from the factory. The
bus is then lost mid-run (every send of the host fails, as after bus-off or an unplugged
adapter): the host's zero torque and Estop never arrive, so the axes must stop by themselves.
Asserted on the emulator's own log of state changes: the axis went to IDLE with
WATCHDOG_TIMER_EXPIRED and zero torque, no earlier than the watchdog time after the host's last
frame and within one watchdog time plus the emulator's slack on a loaded machine. Without the
host's setting (drive_watchdog: 0) the same loss leaves the axes in closed loop with torque: the
protection is the host's doing. The run summary (`report()`) names the protected drives."""
from __future__ import annotations

import gc
import sys
import time
from collections.abc import Iterator
from typing import Any

import can
import pytest

from tests.hw_bench import H, Paced, started
from twmr.core import HardwareError
from twmr.hw import protocol as p

WATCHDOG = 0.1  # drive_watchdog [s]
SLACK = 0.2  # emulator thread delay tolerated on a loaded machine [s]
WAIT = 3.0  # longest wait for the emulator's log entry [s]


@pytest.fixture(autouse=True)
def _paced_like_the_master() -> Iterator[None]:
    """What the master does before a paced run (full collection, gc.freeze, 0.2 ms thread
    switch interval), undone after the case."""
    switch = sys.getswitchinterval()
    gc.collect()
    gc.freeze()
    sys.setswitchinterval(2e-4)
    yield
    gc.unfreeze()
    sys.setswitchinterval(switch)


def lose_the_bus(drive: Any) -> None:
    """Every send of the host fails from now on (bus-off, adapter unplugged)."""
    def dead(msg: can.Message, timeout: float | None = None) -> None:
        raise can.CanOperationError("Bus-off")

    drive.link.bus.send = dead


def watchdog_trips(emu: Any, node: int) -> list[Any]:
    bit = p.error_bit("watchdog", emu.firmware)
    return [e for e in list(emu.events) if e.node == node and e.error & bit]


def run_then_lose_the_bus(drive: Any) -> None:
    loop = Paced(drive)
    loop.run(20, torque=(2.0, -2.0))
    lose_the_bus(drive)
    with pytest.raises(HardwareError, match="Bus-off"):
        loop.run(5, torque=(2.0, -2.0))


def test_the_emulated_odrive_watchdog_stops_the_motors_after_a_bus_off_when_the_host_enabled_it(
) -> None:
    d = started(drive_watchdog=WATCHDOG)
    emu = d.emulators[0]
    try:
        for axis in emu.axes.values():
            assert axis.watchdog_enabled and axis.watchdog_timeout == pytest.approx(WATCHDOG)
        report = d.report()
        assert set(report["protected_by_drive"]) == {"0", "1"}, report
        assert "read back" in report["protected_by_drive"]["0"]
        assert report["not_protected_by_drive"] == {}
        run_then_lose_the_bus(d)
        deadline = time.monotonic() + WAIT
        while time.monotonic() < deadline and not all(watchdog_trips(emu, n) for n in (0, 1)):
            time.sleep(0.01)
        for node in (0, 1):
            trips = watchdog_trips(emu, node)
            assert trips, f"node {node}: no watchdog trip logged within {WAIT} s: " \
                          f"{list(emu.events)[-3:]}"
            first = trips[0]
            assert first.state == p.AXIS_IDLE and first.torque == 0.0, first
            quiet = first.time - first.last_command
            assert WATCHDOG <= quiet <= WATCHDOG + SLACK, \
                f"node {node}: tripped {quiet:.3f} s after the host's last frame"
            assert emu.axes[node].torque == 0.0 and emu.axes[node].state == p.AXIS_IDLE
    finally:
        d.link.bus.__dict__.pop("send", None)
        d.terminate()


def test_without_the_host_setting_the_watchdog_the_axes_stay_in_closed_loop() -> None:
    d = started(drive_watchdog=0.0)
    emu = d.emulators[0]
    try:
        report = d.report()
        assert report["protected_by_drive"] == {}
        assert "drive_watchdog: 0" in report["not_protected_by_drive"]["0"]
        run_then_lose_the_bus(d)
        time.sleep(3 * WATCHDOG)
        assert not watchdog_trips(emu, 0) and not watchdog_trips(emu, 1)
        assert [a.state for a in emu.axes.values()] == [p.AXIS_CLOSED_LOOP] * 2
        assert [a.torque for a in emu.axes.values()] == pytest.approx([2.0, -2.0])
    finally:
        d.link.bus.__dict__.pop("send", None)
        d.terminate()


def test_firmware_0_5_drives_are_reported_unprotected() -> None:
    d = started(firmware="0.5.6")
    try:
        Paced(d).run(5)
        report = d.report()
        assert report["protected_by_drive"] == {}
        assert set(report["not_protected_by_drive"]) == {"0", "1"}
        assert "0.5.6 has no RxSdo/TxSdo" in report["not_protected_by_drive"]["1"]
        assert not any(a.watchdog_enabled for a in d.emulators[0].axes.values())
    finally:
        d.terminate()


def test_a_drive_that_does_not_confirm_its_watchdog_is_reported_unprotected(
        tmp_path: Any) -> None:
    """The host's endpoint table has ids the drive's build does not know: no TxSdo answer."""
    table = tmp_path / "flat_endpoints.json"
    table.write_text('{"endpoints": {"axis0.config.watchdog_timeout": {"id": 900, "type": '
                     '"float"}, "axis0.config.enable_watchdog": {"id": 901, "type": "bool"}}}')
    from twmr.hw.emulator import OdriveEmulator

    original = OdriveEmulator.__init__

    def own_table(self: Any, *args: Any, **kw: Any) -> None:
        kw["endpoints"] = None  # the emulator keeps its own build's ids
        original(self, *args, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(OdriveEmulator, "__init__", own_table)
        d = started(endpoints=str(table))
    try:
        report = d.report()
        assert report["protected_by_drive"] == {}
        assert "no TxSdo answer" in report["not_protected_by_drive"]["0"]
        assert not any(a.watchdog_enabled for a in d.emulators[0].axes.values())
    finally:
        d.terminate()


def test_cia402_drives_report_their_heartbeat_consumer() -> None:
    d = started("cia402", heartbeat_timeout=1.0)  # 0.2 s was lost at load 20
    try:
        Paced(d).run(5)
        report = d.report()
        assert set(report["protected_by_drive"]) == {"1", "2"}
        assert "0x1016" in report["protected_by_drive"]["2"] and "1000 ms" in \
            report["protected_by_drive"]["2"]
    finally:
        d.terminate()


def test_the_watchdog_is_not_tripped_while_the_host_steps() -> None:
    d = started()
    try:
        Paced(d).run(int(5 * WATCHDOG / H), torque=(1.0, 1.0))
        assert not watchdog_trips(d.emulators[0], 0)
    finally:
        d.terminate()


@pytest.mark.parametrize("protocol_name", ["odrive", "cia402"])
def test_a_pause_between_initialize_and_the_first_step_leaves_the_drives_enabled(
        protocol_name: str) -> None:
    """What a run does between starting the drives and its first step (loading compiled kernels
    took 0.4 s in benchmarks/realtime_loop.py) must not trip the drives' own watchdog: the block
    holds them at zero torque until its first command (ODrive: axis watchdog 0.1 s; CiA 402: no
    SYNC for 0.25 s faults the drive)."""
    d = started(protocol_name, **({"drive_watchdog": WATCHDOG} if protocol_name == "odrive"
                                  else {}))
    emu = d.emulators[0]
    try:
        time.sleep(0.6)
        Paced(d).run(20, torque=(1.0, -1.0))
        if protocol_name == "odrive":
            assert not watchdog_trips(emu, 0) and not watchdog_trips(emu, 1)
            assert [a.state for a in emu.axes.values()] == [p.AXIS_CLOSED_LOOP] * 2
        assert d.link is not None and d.link.fault is None
    finally:
        d.terminate()
