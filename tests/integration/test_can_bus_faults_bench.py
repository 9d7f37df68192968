"""Faults of the bus itself on the emulated ODrive bench (`can_bus` block, from t = 0.3 s): an
error frame destroying node 0's torque frame stops the run on the host's side (every node sees
it), the host bus-off stops it on its first refused frame, and a babbling node flooding the bus
with identifier 0 is caught by the bus's flood watch, which names it; each stop leaves the drives
at zero torque and disabled: the fault ends as the run stops and the host's backlog is discarded,
so its zero torque and Estop (or IDLE) go out next and the drives hear them."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from tests.hw_bench import WATCHDOG
from tests.integration.test_hw_canbus import bench, last_commands
from twmr.api import simulate
from twmr.hw import protocol as p
from twmr.hw.canbus import read_log

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize(("fault", "said"), [
    ("fault: error_frame, fault_ids: '0x00E'", "component 'motor' at t = "),
    ("fault: bus_off, fault_ids: all, fault_node: motor", "component 'motor' at t = "),
    ("fault: babble, fault_ids: '0x000'", "participant 'babbling node' sent"),
])
def test_a_fault_of_the_bus_stops_the_bench_safely(tmp_path: Path, fault: str,
                                                   said: str) -> None:
    text = bench(2.0, True).replace(
        f"watchdog_periods: {WATCHDOG}", "watchdog_periods: 250, heartbeat_timeout: 2.0"
    ).replace("parameters: {bitrate: 1000000}",
              f"parameters: {{bitrate: 1000000, {fault}, fault_start: 0.3}}")
    (tmp_path / "bus.yaml").write_text(text)
    with pytest.raises(Exception, match="Fix:") as err:
        simulate(tmp_path / "bus.yaml", out=tmp_path / "run")
    assert said in str(err.value), str(err.value)
    if said.endswith("t = "):  # the host's step that noticed it: the fault's start, or a few
        # ms either side when the host's bus thread hands it over late or the bus runs ahead
        found = re.search(r"at t = ([0-9.]+) s", str(err.value))
        assert found is not None and abs(float(found.group(1)) - 0.3) <= 0.01, str(err.value)
    assert "zero" in str(err.value) and "disabled" in str(err.value)
    log = read_log(tmp_path / "run.incomplete" / "can0_frames.arrows")
    host = log[(log.event == "transmit") & (log.sender == "motor")]
    per_node = last_commands(zip(host.id, host.data, strict=True))
    for node in (0, 1):  # zero torque, then Estop (a drive's trip) or IDLE (another stop)
        assert per_node[node][-2] == (p.SET_INPUT_TORQUE, p.encode_torque(node, 0.0, 1.0)[1])
        assert per_node[node][-1] in ((p.ESTOP, p.encode_estop(node)[1]),
                                      (p.SET_AXIS_STATE,
                                       p.encode_axis_state(node, p.AXIS_IDLE)[1])), node
    # the drives heard them: the stop's frames went on the wire, none left unheard
    assert not ((log.event == "unheard") & (log.sender == "motor")).any()
    if "error_frame" in fault:  # every participant saw the error frames
        errors = log[log.event == "bus_error"]
        assert {"motor", "motor (emulated)"} <= set(errors.sender)
