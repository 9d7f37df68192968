"""Ctrl-C during a bench run (`twmr run` in a subprocess, SIGINT): zero torque and IDLE reach both
drives before the process exits, and the results and frame log computed so far are on disk."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

from tests.hw_bench import WATCHDOG
from twmr.hw import protocol as p
from twmr.hw.replay import Decoder, decode_log
from twmr.result import read_result

BENCH = Path(__file__).resolve().parents[2] / "scenarios" / "bench_odrive_trajectory1.yaml"


def test_ctrl_c_zeroes_the_torque_disables_the_drives_and_keeps_the_results(tmp_path) -> None:
    out = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", "run", str(BENCH), "--quiet",
                             "--out", str(out), "--set", f"motor.channel={uuid.uuid4().hex}",
                             "--set", f"motor.watchdog_periods={WATCHDOG}"],
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("run.partial-*/motor_frames.blf")) and \
            time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(1.0)  # in the paced run, the drives under torque
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "run.incomplete" in err
    out = tmp_path / "run.incomplete"
    log = out / "motor_frames.blf"
    decoded = decode_log(log, Decoder())
    for node in (0, 1):
        sent = [d for d in decoded if d.direction == "Tx" and d.node == node
                and d.signal in ("torque_command", "requested_state")]
        torques = [d.value for d in sent if d.signal == "torque_command"]
        assert any(abs(v) > 1.0 for v in torques)  # it was driving
        assert [(d.signal, d.value) for d in sent[-2:]] == [("torque_command", 0.0),
                                                            ("requested_state", p.AXIS_IDLE)]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["error"].startswith("interrupted (Ctrl-C)")
    data = read_result(out)
    # how far it got depends on the machine's load; that it stepped, and kept those rows, does not
    assert 0 < data["time"][-1] < 10.0 and summary["steps_done"] > 0
