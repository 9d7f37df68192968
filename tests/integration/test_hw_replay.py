"""The frame log written beside a bench run's results: it decodes to the values the run recorded,
and played back onto a bus it decodes to the same values again."""
from __future__ import annotations

import subprocess
import sys
import uuid
from pathlib import Path

import can
import numpy as np
import pytest

from tests.hw_bench import WATCHDOG
from twmr.hw.replay import Decoder, decode_frames, decode_log, play
from twmr.master import simulate
from twmr.scenario import loads

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "scenarios" / "bench_odrive_trajectory1.yaml"


@pytest.fixture(scope="module")
def bench_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[np.ndarray, Path]:
    """0.3 s of the bench scenario (paced, polled ODrive estimates), every step recorded."""
    out = tmp_path_factory.mktemp("bench")
    text = BENCH.read_text().replace("stop: 10.0", "stop: 0.3").replace(
        "decimation: 5", "decimation: 1").replace(
        "ctrl.torque,", "ctrl.torque, motor.torque, motor.measured_speed,").replace(
        "channel: bench", f"channel: bench-{uuid.uuid4().hex[:8]}, watchdog_periods: {WATCHDOG}")
    data = np.array(simulate(loads(text, source="bench.yaml"), out))
    return data, out / "motor_frames.blf"


def test_log_is_beside_the_results_and_decodes_to_the_recorded_values(bench_run) -> None:
    data, log = bench_run
    assert log.is_file()
    decoded = decode_log(log, Decoder("odrive", 1.0, (("firmware", "0.6.10"),)))
    for col, node in (("motor.torque[1]", 0), ("motor.torque[2]", 1)):
        sent = [d.value for d in decoded if d.direction == "Tx" and d.node == node
                and d.signal == "torque_command"]
        rec = list(data[col])
        start = sent.index(rec[0])
        assert sent[start:start + len(rec)] == rec, col  # every step's command, in order
        assert sent[-1] == 0.0  # terminate: zero torque
    for col, node in (("motor.measured_speed[1]", 0), ("motor.measured_speed[2]", 1)):
        received = {d.value for d in decoded if d.direction == "Rx" and d.node == node
                    and d.signal == "speed"}
        assert set(data[col][1:]) <= received, col  # each published speed came in a frame


def test_played_back_log_decodes_to_the_same_values(bench_run) -> None:
    _, log = bench_run
    ch = f"replay-{uuid.uuid4().hex[:8]}"
    listener = can.Bus(interface="virtual", channel=ch)
    sent = play(log, {"interface": "virtual", "channel": ch}, paced=False)
    frames = []
    msg = listener.recv(timeout=0.2)
    while msg is not None:
        frames.append(msg)
        msg = listener.recv(timeout=0.05)
    listener.shutdown()
    decoder = Decoder()
    again = [(d.node, d.signal, d.value) for d in decode_frames(frames, decoder)]
    original = [(d.node, d.signal, d.value) for d in decode_log(log, decoder)]
    assert len(frames) == sent > 500
    assert again == original


def test_cli_writes_the_decoded_log_as_csv(bench_run, tmp_path: Path) -> None:
    _, log = bench_run
    out = tmp_path / "frames.csv"
    run = subprocess.run([sys.executable, "-m", "twmr.cli", "replay", str(log), "--out",
                          str(out)], capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    lines = out.read_text().splitlines()
    assert lines[0] == "time_s,direction,node,signal,value"
    decoded = decode_log(log, Decoder())
    assert len(lines) - 1 == len(decoded)
    times = [float(line.split(",")[0]) for line in lines[1:]]
    assert times[0] == 0.0 and times[-1] == round(decoded[-1].time - decoded[0].time, 6)
    assert "seconds since the log's first frame, at 20" in run.stderr
    assert any(",Tx,0,torque_command," in line for line in lines)
