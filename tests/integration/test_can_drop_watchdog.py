"""A lost torque frame on purpose: the bench scenario (emulated ODrives 0.6.10 on a `can_bus`
block) with the bus's drop fault on node 0's Set_Input_Torque from t = 0.3 s. The frame log,
decoded with cantools from the firmware's own DBC, shows the drive's axis watchdog (0.1 s, set
by the host) tripping — WATCHDOG_TIMER_EXPIRED, axis IDLE (no torque) — and the host stopping
the run on that heartbeat with zero torque and the drives disabled."""
from __future__ import annotations

from pathlib import Path

import cantools
import pytest

from tests.hw_bench import WATCHDOG
from tests.integration.test_hw_canbus import bench, last_commands
from twmr.api import simulate
from twmr.hw import protocol as p
from twmr.hw.canbus import read_log

pytestmark = pytest.mark.timeout(120)

DROP_AT = 0.3  # [s]
TORQUE_0 = p.can_id(0, p.SET_INPUT_TORQUE)


def test_a_dropped_torque_frame_trips_the_drive_watchdog(tmp_path: Path) -> None:
    # the host's watchdogs for a loaded machine (0.5 s, 2 s), so the drive's (0.1 s) trips first
    text = bench(3.0, True).replace(f"watchdog_periods: {WATCHDOG}", "watchdog_periods: 250, "
                                    "heartbeat_timeout: 2.0").replace(
        "parameters: {bitrate: 1000000}",
        f"parameters: {{bitrate: 1000000, fault_ids: '{TORQUE_0:#x}', fault_start: {DROP_AT}}}")
    (tmp_path / "drop.yaml").write_text(text)
    with pytest.raises(Exception, match=r"drive node 0: axis error 0x1000000 "
                                        r"\(WATCHDOG_TIMER_EXPIRED\), state 1") as err:
        simulate(tmp_path / "drop.yaml", out=tmp_path / "run")
    assert "Torque set to zero and drives disabled" in str(err.value)
    # the fix is the watchdog's, not a generic one
    assert "Fix: the drive heard no torque command within its axis watchdog" in str(err.value)
    assert "drive_watchdog: 0.5" in str(err.value)

    log = read_log(tmp_path / "run.incomplete" / "can0_frames.arrows")
    lost = log[log.event == "dropped"]
    assert len(lost) > 10 and set(lost.id.astype(int)) == {TORQUE_0}
    assert lost.time.min() >= DROP_AT and set(lost.sender) == {"motor"}
    # node 1's torque frames pass: the fault takes only the identifier named
    sent = log[log.event == "transmit"]
    torque_1 = sent[sent.id.astype(int) == p.can_id(1, p.SET_INPUT_TORQUE)]
    assert (torque_1.time > DROP_AT).sum() > 10

    # the drive's side, read from its heartbeats with cantools and the DBC of its firmware
    db = cantools.database.load_file(str(p.dbc_path("0.6.10")))
    beats = sent[sent.id.astype(int) == p.can_id(0, p.HEARTBEAT)]
    decoded = [(t, db.decode_message(p.HEARTBEAT, bytes(d), decode_choices=False))
               for t, d in zip(beats.time, beats.data, strict=True)]
    tripped = [(t, m) for t, m in decoded if m["Axis_Error"]]
    assert tripped, "no heartbeat of node 0 reports an axis error"
    t_trip, first = tripped[0]
    assert first["Axis_Error"] == p.error_bit("watchdog", "0.6.10")
    assert first["Axis_State"] == p.AXIS_IDLE
    # the watchdog (0.1 s) runs on the drive's clock from the last torque frame it received
    assert t_trip >= DROP_AT + 0.1 - 0.01
    assert all(m["Axis_Error"] == 0 for t, m in decoded if t < DROP_AT)

    # the stop: the bus's fault ends as the run stops, so the host's last frames to each node,
    # zero torque and Estop, both reach the drive (the trip's own, sent inside the fault's
    # window, may have been lost with node 0's other torque frames)
    host = sent[sent.sender == "motor"]
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):
        assert per_node[node][-2:] == [(p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1]),
                                       (p.ESTOP, p.encode_estop(node)[1])]
