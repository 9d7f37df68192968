"""A paused bench (emulated ODrives 0.6.10 on a `can_bus` block, the host's drive watchdog
0.1 s) stays safe: with `on_pause: hold` the host sends zero torque to both nodes every step
period while paused 0.6 s (six watchdog periods), no heartbeat reports an axis error, and the
run completes; with `on_pause: trip` the host sends nothing, node 0's watchdog trips and the
run stops on it, the drives disabled. Heartbeats decoded with cantools from the firmware's
DBC."""
from __future__ import annotations

import threading
from pathlib import Path

import cantools
import pytest

import twmr
from tests.hw_bench import WATCHDOG
from tests.integration.test_hw_canbus import bench, last_commands
from twmr.core.errors import CosimError
from twmr.hw import protocol as p
from twmr.hw.canbus import read_log

pytestmark = pytest.mark.timeout(180)
PAUSE = 0.6  # [s] of wall time


def _paused_run(tmp_path: Path, how: str) -> tuple[twmr.Result | None, str]:
    # the host's own watchdogs for a loaded machine (0.5 s, 2 s), as the drop-frame test
    text = bench(1.0, True).replace(
        f"watchdog_periods: {WATCHDOG}",
        f"watchdog_periods: 250, heartbeat_timeout: 2.0, on_pause: {how}")
    path = tmp_path / f"{how}.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        with twmr.Stepping(twmr.load(path), tmp_path / how) as run:
            run.simulate_until(0.3)
            threading.Event().wait(PAUSE)  # paused: the gate calls the drives' hold
            return run.finish(), ""
    except CosimError as err:
        return None, str(err)


def _heartbeats(log) -> list[dict]:
    db = cantools.database.load_file(str(p.dbc_path("0.6.10")))
    sent = log[log.event == "transmit"]
    beats = sent[sent.id.astype(int).isin([p.can_id(n, p.HEARTBEAT) for n in (0, 1)])]
    return [db.decode_message(p.HEARTBEAT, bytes(d), decode_choices=False) for d in beats.data]


def test_a_paused_bench_holds_zero_torque_with_its_watchdogs_fed(tmp_path: Path) -> None:
    result, error = _paused_run(tmp_path, "hold")
    assert error == "" and result is not None
    assert result.summary["status"] == "completed"
    assert result.summary["pacing"]["paused_s"] >= PAUSE
    log = read_log(tmp_path / "hold" / "can0_frames.arrows")
    beats = _heartbeats(log)
    assert beats and all(m["Axis_Error"] == 0 for m in beats)
    host = log[(log.event == "transmit") & (log.sender == "motor")]
    zero = {n: p.encode_torque(n, 0.0, 1.0)[1] for n in (0, 1)}
    for node in (0, 1):
        torque = host[host.id.astype(int) == p.can_id(node, p.SET_INPUT_TORQUE)]
        zeros = sum(bytes(d) == zero[node] for d in torque.data)
        # about one a millisecond while paused; a loaded machine sends fewer, far above the
        # six the drive's 0.1 s watchdog needs over 0.6 s
        assert zeros > 60, (node, zeros)


def test_a_paused_bench_set_to_trip_stops_on_the_drives_watchdog(tmp_path: Path) -> None:
    result, error = _paused_run(tmp_path, "trip")
    assert result is None
    assert "WATCHDOG_TIMER_EXPIRED" in error and "on_pause: trip" in error
    assert "Torque set to zero and drives disabled" in error
    log = read_log(tmp_path / "trip.incomplete" / "can0_frames.arrows")
    assert any(m["Axis_Error"] == p.error_bit("watchdog", "0.6.10") for m in _heartbeats(log))
    host = log[(log.event == "transmit") & (log.sender == "motor")]
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):  # the stop: zero torque, then Estop, to each node
        assert per_node[node][-1] == (p.ESTOP, p.encode_estop(node)[1])
