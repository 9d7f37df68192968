"""The controller exported as a CAN node FMU (`twmr export asmc --fmi 3 --can odrive|cia402`)
stops its drives itself: at fmi3Terminate (the frames readable on Tx_Data in the Terminated
state, `FmuComponent.last_sent`) and on every fault it sees — a Bus Error or a bus-off Status on
Rx_Data, malformed Rx_Data, `drive.watchdog_periods` steps without the drives' feedback. The
frames are checked against the Python host's own (`OdriveLink.disable`, `Cia402Link.disable`:
zero torque, then IDLE / SHUTDOWN, or Estop / DISABLE VOLTAGE on a fault), encoded by
twmr.hw.protocol and twmr.hw.cia402, not by the C under test."""
from __future__ import annotations

from pathlib import Path

import pytest

from twmr.core import CosimError
from twmr.fmi.cexport import export_c_fmu
from twmr.fmi.lsbus import operations as ops
from twmr.hw import cia402 as c
from twmr.hw import protocol as p
from twmr.testing import Harness

H = 2e-3
RX, RX_CLOCK, TX = "CanChannel.Rx_Data", "CanChannel.Rx_Clock", "CanChannel.Tx_Data"
NODES = {"odrive": (0, 1), "cia402": (1, 2)}
GEAR = 1.0


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("can_stops")
    return {proto: export_c_fmu("asmc", d / f"asmc_{proto}.fmu",
                                {"drive.watchdog_periods": 5}, fmi=3, can=proto)
            for proto in ("odrive", "cia402")}


def stop_frames(proto: str, fault: bool) -> list[tuple[int, bytes]]:
    """What the Python host sends to stop its drives (its Link.disable)."""
    nodes = NODES[proto]
    if proto == "odrive":
        out = []
        for n in nodes:
            out.append(p.encode_torque(n, 0.0, GEAR))
            out.append(p.encode_estop(n) if fault else p.encode_axis_state(n, p.AXIS_IDLE))
        return out
    word = c.DISABLE_VOLTAGE if fault else c.SHUTDOWN
    return [c.encode_rpdo1(n, word, 0) for n in nodes] + [(0x080, b"")]


def frames(raw: bytes) -> list[tuple[int, bytes]]:
    return [(op.id, bytes(op.data)) for op in ops.decode(raw)
            if isinstance(op, ops.CanTransmit)]


def feedback(proto: str) -> bytes:
    """One period of the drives' feedback (both axes), as the drives send it."""
    if proto == "odrive":
        raw = [p.encode_encoder(n, 0.0, 1.0, GEAR) for n in NODES[proto]]
    else:
        enabled = c.statusword(c.State.OPERATION_ENABLED)
        raw = [c.encode_tpdo1(n, enabled, 10) for n in NODES[proto]]
    return ops.encode([ops.CanTransmit(i, d) for i, d in raw])


def started(path: Path) -> Harness:
    h = Harness("fmu", parameters={"path": str(path)}, step=H)
    h.set(**{RX: b"", RX_CLOCK: False})
    return h.initialize()


@pytest.mark.parametrize("proto", ["odrive", "cia402"])
def test_terminate_leaves_zero_torque_and_the_normal_stop_on_tx_data(fmus, proto) -> None:
    h = started(fmus[proto])
    for _ in range(3):
        h.step(**{RX: feedback(proto), RX_CLOCK: True})
    assert h.component.last_sent("CanChannel") == b""
    h.terminate()
    assert frames(h.component.last_sent("CanChannel")) == stop_frames(proto, fault=False)


@pytest.mark.parametrize("proto", ["odrive", "cia402"])
def test_the_host_watchdog_stops_the_drives_and_asks_to_terminate(fmus, proto) -> None:
    """drive.watchdog_periods = 5: four steps without feedback send torques, the fifth the
    stop on a fault; the FMU asks to terminate, naming the watchdog."""
    h = started(fmus[proto])
    h.step(**{RX: feedback(proto), RX_CLOCK: True})
    with pytest.raises(CosimError) as err:
        for _ in range(5):
            h.step(**{RX: b"", RX_CLOCK: False})
    assert h.n == 5  # the fifth step without feedback
    assert "asked to terminate" in str(err.value)
    assert any("host watchdog" in line for line in h.component.log.tail())
    h.terminate()
    assert frames(h.component.last_sent("CanChannel")) == stop_frames(proto, fault=True)


@pytest.mark.parametrize("proto", ["odrive", "cia402"])
@pytest.mark.parametrize("told, words", [
    (ops.encode([ops.BusError(0x0E, ops.ERROR_ACK, ops.FLAG_PRIMARY, True)]),
     "a bus error (code 5) on frame 0xe"),
    (ops.encode([ops.Status(ops.STATUS_BUS_OFF)]), "bus-off"),
])
def test_a_bus_fault_on_rx_data_stops_the_drives(fmus, proto, told, words) -> None:
    h = started(fmus[proto])
    h.step(**{RX: feedback(proto), RX_CLOCK: True})
    with pytest.raises(CosimError):
        h.step(**{RX: told, RX_CLOCK: True})
    assert any(words in line for line in h.component.log.tail()), h.component.log.tail()
    h.terminate()
    assert frames(h.component.last_sent("CanChannel")) == stop_frames(proto, fault=True)


def test_a_status_other_than_bus_off_changes_nothing(fmus) -> None:
    h = started(fmus["odrive"])
    h.step(**{RX: ops.encode([ops.Status(ops.STATUS_ERROR_PASSIVE)]), RX_CLOCK: True})
    h.step(**{RX: feedback("odrive"), RX_CLOCK: True})
    h.terminate()
    assert frames(h.component.last_sent("CanChannel")) == stop_frames("odrive", fault=False)


def test_malformed_rx_data_is_an_error_and_a_fault_stop(fmus) -> None:
    h = started(fmus["odrive"])
    h.step(**{RX: feedback("odrive"), RX_CLOCK: True})
    with pytest.raises(CosimError):
        h.step(**{RX: feedback("odrive")[:-3], RX_CLOCK: True})
    h.terminate()
    assert frames(h.component.last_sent("CanChannel")) == stop_frames("odrive", fault=True)


def test_watchdog_periods_below_one_is_refused(fmus) -> None:
    """By our importer from the model description's min, and by the FMU itself for any other
    importer (fmpy here)."""
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Slave

    with pytest.raises(ValueError, match="below the minimum"):
        Harness("fmu", parameters={"path": str(fmus["odrive"]), "drive.watchdog_periods": 0})
    md = read_model_description(str(fmus["odrive"]))
    vr = next(v.valueReference for v in md.modelVariables if v.name == "drive.watchdog_periods")
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=extract(str(fmus["odrive"])),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate(eventModeUsed=True)
    fmu.enterInitializationMode()
    with pytest.raises(Exception, match=r"fmi3SetFloat64|fmi3ExitInitializationMode"):
        fmu.setFloat64([vr], [0.0])  # the FMU checks the min itself
        fmu.exitInitializationMode()
    fmu.freeInstance()
