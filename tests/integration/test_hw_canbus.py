"""The bus block (`kind: can_bus`) in scenarios and on its own: the bench scenario through it gives
the rows it gives without it (timing does not reach them), its frame log agrees with the drive's
own python-can log and with bus timing, every stop ends in zero torque and disable on it, and no
participant's or gateway's bad frame ends its thread."""
from __future__ import annotations

import threading
import uuid
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import can
import numpy as np
import pytest

from tests.hw_bench import WATCHDOG, H, Paced
from twmr.api import read_result, simulate
from twmr.core import HardwareError
from twmr.hw import protocol as p
from twmr.hw.canbus import BlockBus, BusRunner, Gateway, read_log
from twmr.hw.canbus_block import CanBus
from twmr.hw.cansim import BusEvent, CanBusModel
from twmr.hw.drive import CanMotorDrive

BENCH = Path(__file__).resolve().parents[2] / "scenarios" / "bench_odrive_trajectory1.yaml"
OWN_BUS = "interface: virtual, channel: bench,"


def bench(stop: float, on_bus: bool) -> str:
    text = BENCH.read_text().replace("stop: 10.0", f"stop: {stop}")
    text = text.replace("emulate: true}", f"emulate: true, watchdog_periods: {WATCHDOG}}}")
    assert OWN_BUS in text
    if not on_bus:
        return text.replace(OWN_BUS, f"interface: virtual, channel: t-{uuid.uuid4().hex[:10]},")
    text = text.replace(OWN_BUS, "bus: can0,").replace(
        "  signals: [", "  signals: [can0.frames, can0.errors, can0.load, ", 1)
    return text.replace("  plant:\n", "  can0:\n    kind: can_bus\n    parameters: {bitrate: "
                        "1000000}\n  plant:\n", 1)


def sent_as_logged(blf: list[Any], log: Any, sender: str) -> bool:
    """Whether the frames a host's own python-can log has as sent are those the bus log has
    it transmit, in order, once the frames it discarded unsent as it stopped (a frame already
    on the wire then is transmitted after them) are taken out from the end."""
    sent = [(m.arbitration_id, bytes(m.data)) for m in blf]
    mine = log[log.sender == sender]
    discarded = list(zip(mine[mine.event == "discarded"].id.astype(int),
                         mine[mine.event == "discarded"].data, strict=True))
    for frame in reversed(discarded):
        where = len(sent) - 1 - sent[::-1].index((frame[0], bytes(frame[1])))
        del sent[where]
    transmitted = mine[mine.event == "transmit"]
    return sent == list(zip(transmitted.id.astype(int), transmitted.data, strict=True))


def last_commands(frames: Any) -> dict[int, list[tuple[int, bytes]]]:
    """Per node, the (command, data) of the host's frames in order."""
    out: dict[int, list[tuple[int, bytes]]] = {}
    for ident, data in frames:
        node, cmd = p.split_id(int(ident))
        out.setdefault(node, []).append((cmd, bytes(data)))
    return out


def test_the_bench_through_the_bus_block_gives_the_same_rows(tmp_path: Path) -> None:
    for name, on_bus in (("alone", False), ("run", True)):
        (tmp_path / f"{name}.yaml").write_text(bench(0.6, on_bus))
        simulate(tmp_path / f"{name}.yaml", out=tmp_path / name)
    alone = read_result(tmp_path / "alone").to_pandas()
    rows = read_result(tmp_path / "run").to_pandas()
    assert set(rows.columns) - set(alone.columns) == {"can0.frames", "can0.errors", "can0.load"}
    assert len(rows) == len(alone) > 10
    for name in alone.columns:
        np.testing.assert_array_equal(rows[name].to_numpy(), alone[name].to_numpy(),
                                      err_msg=name)

    log = read_log(tmp_path / "run" / "can0_frames.arrows")
    sent = log[log.event == "transmit"]
    assert set(sent.sender) == {"motor", "motor (emulated)"}
    assert (log.event == "bus_error").sum() == 0 and rows["can0.errors"].max() == 0
    # the bus outputs: frames carried so far (never more than the log holds), bus load in (0, 1]
    carried = rows["can0.frames"].to_numpy()
    assert np.all(np.diff(carried) >= 0) and 0 < carried[-1] <= len(sent)
    load = rows["can0.load"].to_numpy()[1:]
    assert np.all((load >= 0) & (load <= 1)) and load.max() > 0
    # no two frames on the wire at once: each starts after the last ended and its 3
    # intermission bits (3 us at 1 Mbit/s) passed
    starts, ends = sent.start.to_numpy(), sent.time.to_numpy()
    assert np.all(starts[1:] >= ends[:-1] + 3e-6 - 1e-9)
    # each lasts at least its unstuffed bits (44 + 8 n to the end of EOF) and at most the
    # worst-case stuffed ones (g + 8 n + 10 + floor((g + 8 n - 1) / 4), g = 34)
    n = sent.dlc.where(~sent.remote, 0).to_numpy()
    took = (ends - starts) * 1e6
    assert np.all(took >= 44 + 8 * n - 1e-6)
    assert np.all(took <= 34 + 8 * n + 10 + (33 + 8 * n) // 4 + 1e-6)
    # every frame the host's own python-can log has as sent is on the bus, in the same order,
    # but those it discarded unsent as it stopped (its stop frames go out next), logged so
    host = sent[sent.sender == "motor"]
    blf = [m for m in can.LogReader(str(tmp_path / "run" / "motor_frames.blf")) if not m.is_rx]
    assert sent_as_logged(blf, log, "motor")
    # the stop: zero torque, then IDLE, the host's last frames to each node
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):
        assert per_node[node][-2:] == [(p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1]),
                                       (p.SET_AXIS_STATE, p.encode_axis_state(node,
                                                                              p.AXIS_IDLE)[1])]


def test_a_fault_through_the_bus_block_ends_in_zero_torque_and_estop(tmp_path: Path) -> None:
    """The emulated drives go quiet mid-run: the host watchdog trips; the bus log's last host
    frames to each node are zero torque then Estop, as on a bus of the drive's own."""
    run = SimpleNamespace(folder=tmp_path)
    block = CanBus("can0")
    drive = CanMotorDrive("motor", bus="can0", log_file="", watchdog_periods=WATCHDOG)
    for c in (drive, block):  # the drive first: the order of set-up does not matter
        c.prepare(run)
    try:
        drive.setup(0.0, None)
        block.setup(0.0, None)
        drive.initialize()
        loop = Paced(drive)
        loop.run(20)
        block.do_step(0.0, H)
        drive.emulators[0].silent = True
        with pytest.raises(HardwareError, match=r"'motor'.*no feedback frame"):
            loop.run(400)
    finally:
        block.terminate()  # before the drive: the bus waits for its participants to leave
        drive.terminate()
    log = read_log(tmp_path / "can0_frames.arrows")
    host = log[(log.event == "transmit") & (log.sender == "motor")]
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):
        assert per_node[node][-2:] == [(p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1]),
                                       (p.ESTOP, p.encode_estop(node)[1])]
    assert block.report()["bus_errors"] == 0


def runner_with(*names: str) -> tuple[BusRunner, list[BlockBus]]:
    channel = f"test-{uuid.uuid4().hex[:8]}"
    bus = BusRunner("can0", channel, CanBusModel(bitrate=1e6))
    return bus, [BlockBus(channel, participant=n) for n in names]


def test_a_frame_longer_than_classic_can_is_refused_naming_bus_participant_and_time() -> None:
    bus, (ecu, monitor) = runner_with("ecu", "monitor")
    try:
        bad = can.Message(arbitration_id=0x10, data=bytes(9), is_extended_id=False, check=False)
        with pytest.raises(can.CanOperationError, match=r"longer than classic CAN allows"):
            ecu.send(bad)
        short_dlc = can.Message(arbitration_id=0x10, data=bytes(4), dlc=2, is_extended_id=False)
        with pytest.raises(can.CanOperationError, match=r"DLC says 2 bytes and it carries 4"):
            ecu.send(short_dlc)
        ecu.send(can.Message(arbitration_id=0x11, data=b"\x2a", is_extended_id=False))
        got = monitor.recv(timeout=2.0)
        assert got is not None and got.arbitration_id == 0x11 and bytes(got.data) == b"\x2a"
        assert bus.counts["bus_error"] == 2
        first = bus.problems()[0]
        assert "bus 'can0'" in first and "participant 'ecu'" in first
        assert "0x010 [9]" in first and "at t = " in first
    finally:
        ecu.shutdown()
        monitor.shutdown()
        bus.close()


def test_a_participant_that_fails_does_not_stop_the_bus() -> None:
    bus, (ecu, monitor) = runner_with("ecu", "monitor")

    class Broken:
        name = "broken"

        def deliver(self, event: BusEvent) -> None:
            raise RuntimeError("cannot take it")

    bus.join(Broken())
    try:
        for i in range(3):
            ecu.send(can.Message(arbitration_id=0x20 + i, data=bytes([i]), is_extended_id=False))
        got = [monitor.recv(timeout=2.0) for _ in range(3)]
        assert [m.arbitration_id for m in got if m is not None] == [0x20, 0x21, 0x22]
        assert bus._thread.is_alive()
        assert sum("participant 'broken' failed" in f for f in bus.failures) == 3
    finally:
        bus.leave("broken")
        ecu.shutdown()
        monitor.shutdown()
        bus.close()


def test_the_gateway_bridges_a_python_can_bus_and_refuses_its_bad_frames() -> None:
    bus, (ecu,) = runner_with("ecu")
    outside = f"gw-{uuid.uuid4().hex[:8]}"
    gateway = Gateway(bus, {"interface": "virtual", "channel": outside}, f"virtual:{outside}")
    other = can.Bus(interface="virtual", channel=outside)
    try:
        other.send(can.Message(arbitration_id=0x55, data=bytes(12), is_extended_id=False,
                               check=False))
        other.send(can.Message(arbitration_id=0x56, data=b"\x01\x02", is_extended_id=False))
        got = ecu.recv(timeout=2.0)
        assert got is not None and got.arbitration_id == 0x56
        ecu.send(can.Message(arbitration_id=0x57, data=b"\x03", is_extended_id=False))
        out = other.recv(timeout=2.0)
        assert out is not None and out.arbitration_id == 0x57
        assert any(f"participant 'virtual:{outside}'" in f and "0x055 [12]" in f
                   for f in bus.problems()), bus.problems()
        assert all(t.is_alive() for t in threading.enumerate() if t.name.startswith("can-"))
    finally:
        gateway.close()
        ecu.shutdown()
        other.shutdown()
        bus.close()


def test_a_drive_naming_no_running_bus_is_a_clear_hardware_error() -> None:
    d = CanMotorDrive("motor", bus="can0", log_file="")
    d.prepare(SimpleNamespace(folder=None))
    try:
        with pytest.raises(HardwareError, match=r"no can_bus 'can0' is running.*bus:"):
            d.setup(0.0, None)
    finally:
        d.terminate()


def test_frames_sent_after_the_block_stopped_still_go_out_through_the_gateway() -> None:
    """The block's terminate may come before its participants' (the run's order): a drive's
    last frames (zero torque, disable) then still reach the bus outside, and the log is written
    once the last participant has left."""
    bus, (host,) = runner_with("host")
    outside = f"gw-{uuid.uuid4().hex[:8]}"
    closed: list[str] = []
    bus.on_close = lambda b: (gateway.close(), closed.append(b.name))
    gateway = Gateway(bus, {"interface": "virtual", "channel": outside}, f"virtual:{outside}")
    other = can.Bus(interface="virtual", channel=outside)
    try:
        bus.close()  # the block is done; its participant is not
        last = [p.encode_torque(0, 0.0, 1.0), p.encode_axis_state(0, p.AXIS_IDLE)]
        for ident, data in last:
            host.send(can.Message(arbitration_id=ident, data=data, is_extended_id=False))
        assert not closed
        host.shutdown()
        assert closed == ["can0"]
        got = [other.recv(timeout=2.0) for _ in last]
        assert [(m.arbitration_id, bytes(m.data)) for m in got if m is not None] == last
    finally:
        other.shutdown()


def test_ctrl_c_through_the_bus_block_zeroes_and_disables_the_drives(tmp_path: Path) -> None:
    import signal
    import struct
    import subprocess
    import sys
    import time

    text = bench(10.0, True).replace(f"watchdog_periods: {WATCHDOG}",
                                     "watchdog_periods: 250, heartbeat_timeout: 2.0")
    (tmp_path / "bus.yaml").write_text(text)  # watchdogs for a loaded machine: only Ctrl-C stops
    proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", "run", str(tmp_path / "bus.yaml"),
                             "--quiet", "--out", str(tmp_path / "run")],
                            stderr=subprocess.PIPE, text=True)
    def stored() -> int:
        return sum(f.stat().st_size for f in tmp_path.glob("run.partial-*/result.arrows"))

    deadline = time.monotonic() + 120
    while not stored() and time.monotonic() < deadline:
        time.sleep(0.05)
    first = stored()
    while stored() == first and time.monotonic() < deadline:
        time.sleep(0.05)  # rows came: the paced run steps, the drives under torque
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    log = read_log(tmp_path / "run.incomplete" / "can0_frames.arrows")
    host = log[(log.event == "transmit") & (log.sender == "motor")]
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):
        torques = [struct.unpack_from("<f", d)[0] for c, d in per_node[node]
                   if c == p.SET_INPUT_TORQUE]
        assert any(abs(v) > 1.0 for v in torques), (max(map(abs, torques)), err)  # driving
        assert per_node[node][-2:] == [(p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1]),
                                       (p.SET_AXIS_STATE, p.encode_axis_state(node,
                                                                              p.AXIS_IDLE)[1])]
