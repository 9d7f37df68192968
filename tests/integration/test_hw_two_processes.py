"""The bench in two processes, as docs/bench.md describes it: `twmr emulate-drive` in one,
`twmr run` with `emulate: false` in another, over python-can's `udp_multicast` on loopback (a
group and port of this test's own, in a python-can config file both read). Watchdogs are sized
for a loaded machine (start-up 20 s, feedback 250 periods, heartbeat 2 s); what is asserted is
what the frame log and the emulator show, not deadlines."""
from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import can
import pytest

from tests.hostile.runner import BENCH, assert_clean_error, assert_ok, run_cli
from tests.integration.test_hw_canbus import sent_as_logged
from twmr.hw import protocol as p
from twmr.hw.canbus import read_log

OWN_BUS = "interface: virtual, channel: bench,"


def config(folder: Path) -> Path:
    rng = random.Random()
    ini = folder / "can.ini"
    ini.write_text(f"[default]\ninterface = udp_multicast\nchannel = 239.74.{rng.randint(1, 254)}."
                   f"{rng.randint(1, 254)}\nport = {rng.randint(40000, 60000)}\n")
    return ini


def bench(folder: Path, stop: float = 1.0, start_timeout: float = 20.0,
          through_bus: bool = False) -> str:
    """The bench scenario on can.ini: the drive's own bus, or (`through_bus`) a can_bus block
    `can0` bridging it, which the drive joins."""
    text = BENCH.read_text().replace("stop: 10.0", f"stop: {stop}")
    assert OWN_BUS in text and "emulate: true}" in text
    if through_bus:
        text = text.replace(OWN_BUS, "bus: can0,").replace(
            "  plant:\n", "  can0:\n    kind: can_bus\n    parameters: {can_config: can.ini}\n"
            "  plant:\n", 1)
    text = text.replace(OWN_BUS, "can_config: can.ini,").replace(
        "emulate: true}", f"emulate: false, watchdog_periods: 250, heartbeat_timeout: 2.0, "
        f"start_timeout: {start_timeout}}}")
    (folder / "bench.yaml").write_text(text)
    return "bench.yaml"


class Emulator:
    """`twmr emulate-drive --can-config can.ini` as a child process, its stderr in a file."""

    def __init__(self, cwd: Path):
        self.err = cwd / "emulator.err"
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        with self.err.open("wb") as sink:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "twmr.cli", "emulate-drive", "--can-config", "can.ini"],
                cwd=cwd, stdout=subprocess.DEVNULL, stderr=sink, env=env)
        deadline = time.monotonic() + 120
        while "emulating odrive drives" not in self.text():
            assert self.proc.poll() is None, f"emulate-drive ended: {self.text()}"
            assert time.monotonic() < deadline, f"emulate-drive did not start: {self.text()}"
            time.sleep(0.2)

    def text(self) -> str:
        return self.err.read_text(errors="replace")

    def status_lines(self) -> list[str]:
        return [line for line in self.text().splitlines() if line.startswith("0: state")]

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()


def config_of(folder: Path) -> str:
    return next(line.split(" = ")[1] for line in (folder / "can.ini").read_text().splitlines()
                if line.startswith("channel"))


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    folder = tmp_path / "cwd"
    folder.mkdir()
    config(folder)
    return folder


@pytest.mark.parametrize("through_bus", [False, True], ids=["own-bus", "through-can_bus"])
def test_the_bench_runs_against_drives_emulated_in_another_process(cwd: Path,
                                                                   through_bus: bool) -> None:
    name = bench(cwd, through_bus=through_bus)
    emulator = Emulator(cwd)
    try:
        o = run_cli(["run", name, "-q"], cwd, timeout=300)
        assert_ok(o)
        seen = len(emulator.status_lines())
        deadline = time.monotonic() + 30
        while len(emulator.status_lines()) < seen + 2 and time.monotonic() < deadline:
            time.sleep(0.2)  # the emulator reports its axes every second
        after = emulator.status_lines()[-1]
    finally:
        emulator.stop()
    # the drives in the other process are left idle (state 1) without torque
    assert after == "0: state 1 torque 0 N.m, 1: state 1 torque 0 N.m", emulator.text()
    frames = list(can.LogReader(str(cwd / "results" / "bench" / "motor_frames.blf")))
    heard = {p.split_id(m.arbitration_id) for m in frames if m.is_rx}
    for node in (0, 1):
        assert (node, p.HEARTBEAT) in heard and (node, p.GET_ENCODER_ESTIMATES) in heard
    closed = [p.decode_heartbeat(m.data, "0.6.10").axis_state for m in frames if m.is_rx and
              p.split_id(m.arbitration_id)[1] == p.HEARTBEAT]
    assert p.AXIS_CLOSED_LOOP in closed
    sent: dict[int, list[tuple[int, bytes]]] = {}
    for m in frames:
        if not m.is_rx:
            node, cmd = p.split_id(m.arbitration_id)
            sent.setdefault(node, []).append((cmd, bytes(m.data)))
    for node in (0, 1):
        assert sent[node][-2:] == [(p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1]),
                                   (p.SET_AXIS_STATE, p.encode_axis_state(node, p.AXIS_IDLE)[1])]
        assert sum(cmd == p.SET_INPUT_TORQUE for cmd, _ in sent[node]) >= 500  # every step
    if through_bus:
        log = read_log(cwd / "results" / "bench" / "can0_frames.arrows")
        moved = log[log.event == "transmit"]
        outside = moved[moved.sender != "motor"]
        assert set(moved.sender) == {"motor", f"udp_multicast:{config_of(cwd)}"}
        # what came in through the gateway is the drives' (no echo of the host's own frames)
        assert not any(p.split_id(int(i))[1] == p.SET_INPUT_TORQUE for i in outside.id)
        assert sent_as_logged([m for m in frames if not m.is_rx], log, "motor")
        assert (log.event == "bus_error").sum() == 0


def test_no_drive_on_the_bus_says_no_heartbeat_arrived(cwd: Path) -> None:
    name = bench(cwd, stop=0.1, start_timeout=1.0)
    o = run_cli(["run", name, "-q"], cwd, timeout=120)
    para = "\n".join(assert_clean_error(o, mentions=("'motor'", "drive node 0")))
    assert "no heartbeat arrived within 1 s on udp_multicast:239.74." in para, o.describe()
    assert "Heartbeat(" not in para, o.describe()


def test_a_lost_torque_frame_on_a_bus_to_another_process_trips_that_drive(cwd: Path) -> None:
    """The bus block between the host and drives emulated in another process (real frames over
    udp_multicast) loses node 0's Set_Input_Torque from 0.3 s (`fault: drop`): the drive in the
    other process hears no torque, its own axis watchdog trips, and the host stops the run on
    the heartbeat that says so — a fault on a cross-process bus, made by the block as the
    frames cross it. The drive block is given the emulator's endpoint table: without one, a
    drive in another process is not protected by its own watchdog and keeps its last torque
    (the run's report says so), which is why the table matters."""
    name = bench(cwd, stop=3.0, through_bus=True)
    # the emulator's endpoint table, so the host arms each drive's own watchdog: 0.5 s, so a
    # host a loaded machine stalls for a tenth of a second does not trip it before the fault
    table = Path(p.__file__).resolve().parent / "data" / "odrive-endpoints-emulated.json"
    text = (cwd / name).read_text().replace(
        "emulate: false,", f"emulate: false, endpoints: '{table}', drive_watchdog: 0.5,"
    ).replace(
        "parameters: {can_config: can.ini}",
        f"parameters: {{can_config: can.ini, fault_ids: "
        f"'{p.can_id(0, p.SET_INPUT_TORQUE):#x}', fault_start: 0.3}}")
    (cwd / name).write_text(text)
    emulator = Emulator(cwd)
    try:
        o = run_cli(["run", name, "-q"], cwd, timeout=300)
    finally:
        emulator.stop()
    para = "\n".join(assert_clean_error(o, mentions=("'motor'", "drive node 0")))
    assert "WATCHDOG_TIMER_EXPIRED" in para, o.describe()
    log = read_log(cwd / "results" / "bench.incomplete" / "can0_frames.arrows")
    lost = log[log.event == "dropped"]
    assert len(lost) > 10 and set(lost.id.astype(int)) == {p.can_id(0, p.SET_INPUT_TORQUE)}
    assert lost.time.min() >= 0.3
