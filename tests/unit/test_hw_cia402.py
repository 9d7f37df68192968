"""CiA 402 state machine through every transition, and the objects it uses in real EDS files."""
from __future__ import annotations

import math
from pathlib import Path

import canopen
import pytest

from twmr.hw import cia402 as c
from twmr.hw.cia402 import State

SHARED = Path(__file__).resolve().parents[3] / "shared" / "can"


@pytest.mark.parametrize("state", list(State))
def test_statusword_round_trip(state: State) -> None:
    assert c.decode_statusword(c.statusword(state)) == state
    assert c.decode_statusword(c.statusword(state) | 0x0210) == state  # other bits ignored


def test_host_walks_the_drive_to_operation_enabled_from_every_state() -> None:
    for start in State:
        state, prev, steps = start, 0, 0
        while state != State.OPERATION_ENABLED:
            word = c.next_controlword(state)
            state, prev = c.drive_transition(state, word, prev), word
            steps += 1
            assert steps < 8, f"stuck from {start}"


def test_transitions_of_the_standard() -> None:
    t = c.drive_transition
    assert t(State.SWITCH_ON_DISABLED, c.SHUTDOWN) == State.READY  # 2
    assert t(State.READY, c.SWITCH_ON) == State.SWITCHED_ON  # 3
    assert t(State.SWITCHED_ON, c.ENABLE_OPERATION) == State.OPERATION_ENABLED  # 4
    assert t(State.OPERATION_ENABLED, c.DISABLE_OPERATION) == State.SWITCHED_ON  # 5
    assert t(State.SWITCHED_ON, c.SHUTDOWN) == State.READY  # 6
    assert t(State.READY, c.DISABLE_VOLTAGE) == State.SWITCH_ON_DISABLED  # 7
    assert t(State.OPERATION_ENABLED, c.SHUTDOWN) == State.READY  # 8
    assert t(State.OPERATION_ENABLED, c.DISABLE_VOLTAGE) == State.SWITCH_ON_DISABLED  # 9
    assert t(State.SWITCHED_ON, c.DISABLE_VOLTAGE) == State.SWITCH_ON_DISABLED  # 10
    assert t(State.OPERATION_ENABLED, c.QUICK_STOP) == State.QUICK_STOP  # 11
    assert t(State.QUICK_STOP, c.DISABLE_VOLTAGE) == State.SWITCH_ON_DISABLED  # 12
    assert t(State.FAULT_REACTION, 0) == State.FAULT  # 14
    assert t(State.FAULT, c.FAULT_RESET, previous_control=0) == State.SWITCH_ON_DISABLED  # 15
    assert t(State.FAULT, c.FAULT_RESET, previous_control=c.FAULT_RESET) == State.FAULT  # no edge


def test_units() -> None:
    assert c.torque_to_permille(2.0, gear=10.0, rated_torque_mNm=200) == 1000
    assert c.permille_to_torque(500, 10.0, 200) == pytest.approx(1.0)
    assert c.torque_to_permille(1e6, 1.0, 100) == 32767
    assert c.velocity_to_si(600, gear=10.0) == pytest.approx(2 * math.pi)
    assert c.position_to_si(4096, gear=2.0, increments_per_rev=4096) == pytest.approx(math.pi)


@pytest.mark.parametrize("name", ["maxon_epos4_module_50-5.eds",
                                  "epos4_50_15_can_ec90flat_gp52c_mile800_node1.dcf",
                                  "canopen_example_e35_cia402.eds"])
def test_real_descriptions_hold_the_objects_with_their_types(name: str) -> None:
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"{path} not present")
    od = canopen.import_od(str(path), node_id=1)
    types = {c.CONTROLWORD: canopen.objectdictionary.UNSIGNED16,
             c.STATUSWORD: canopen.objectdictionary.UNSIGNED16,
             c.MODES_OF_OPERATION: canopen.objectdictionary.INTEGER8,
             c.TARGET_TORQUE: canopen.objectdictionary.INTEGER16,
             c.VELOCITY_ACTUAL: canopen.objectdictionary.INTEGER32,
             c.POSITION_ACTUAL: canopen.objectdictionary.INTEGER32}
    for index, dtype in types.items():
        if index not in od and name.startswith("canopen_example"):
            continue  # the generic example lacks some objects
        var = od[index]
        assert var.data_type == dtype, hex(index)
    raw = od[c.TARGET_TORQUE].encode_raw(c.torque_to_permille(-1.5, 1.0, 3000))
    assert od[c.TARGET_TORQUE].decode_raw(raw) == -500
