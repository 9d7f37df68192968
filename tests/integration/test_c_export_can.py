"""`twmr export asmc --fmi 3 --can odrive|cia402`: the ASMC as an FMI-LS-BUS CAN node FMU, run
through our importer (twmr.testing.Harness, kind fmu). Encoder frames, encoded by hw's Python
encoders, go in as LS-BUS Rx operations; the frames the FMU sends are decoded with hw's Python
decoders and compared with the Python ASMC block given the same inputs (the wheel speeds the
frames carry): the start-up frames byte for byte, the torques within the wire's quantisation."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from twmr.core.errors import CosimError
from twmr.fmi.cexport import export_c_fmu
from twmr.fmi.lsbus.operations import CanTransmit, decode, encode
from twmr.hw import cia402 as c
from twmr.hw import protocol as p
from twmr.testing import Harness

H = 2e-3
STEPS = 60
#: the bench's controller (scenarios/bench_odrive_trajectory1.yaml) with a stronger adaptation
CTRL = {"drive": "backward", "lookahead": 0.05, "eta": 5.0}
RX, RX_CLOCK, TX = "CanChannel.Rx_Data", "CanChannel.Rx_Clock", "CanChannel.Tx_Data"


def _inputs(k: int) -> dict[str, Any]:
    """Trajectory 1 and a robot pose near it at step k (the bench's start pose), in SI."""
    t = k * H
    return {"ref_position": (-t, math.sin(0.5 * t) + 0.5 * t + 1.0),
            "ref_velocity": (-1.0, 0.5 * math.cos(0.5 * t) + 0.5),
            "ref_acceleration": (0.0, -0.25 * math.sin(0.5 * t)),
            "pose": (0.5 - 0.6 * t, 0.1 * t, -math.pi / 4 + 0.3 * t)}


def _speeds(rng: np.random.Generator) -> tuple[float, float]:
    return tuple(float(x) for x in rng.uniform(-30.0, 30.0, 2))  # type: ignore[return-value]


def _ctrl(**params: Any) -> Harness:
    return Harness("asmc", parameters={**CTRL, **params}, step=H)


def _fmu(path: Path) -> Harness:
    return Harness("fmu", parameters={"path": str(path)}, step=H)


def _started(path: Path) -> tuple[Harness, Harness]:
    """The node FMU and the ASMC block, both initialised at the inputs of step 0 (no frame in)."""
    fmu, ctrl = _fmu(path), _ctrl()
    fmu.set(**_inputs(0), **{RX: b"", RX_CLOCK: False})
    ctrl.set(**_inputs(0))
    fmu.initialize()
    ctrl.initialize()
    return fmu, ctrl


def _transmits(raw: bytes) -> list[CanTransmit]:
    ops = decode(raw)
    assert all(isinstance(op, CanTransmit) for op in ops), ops
    return ops  # type: ignore[return-value]


def _quantum(x: float, gear: float) -> float:
    """The float32 spacing of a wheel torque x sent as a motor torque x / gear [N.m]."""
    return float(np.spacing(np.float32(abs(x) / gear))) * gear


# -- ODrive ----------------------------------------------------------------------------------
ODRIVE = {"drive.node_ids": [3, 5], "drive.gear": 2.5, "drive.torque_limit": 40.0,
          "drive.torque_constant": 0.8, "drive.speed_limit": 50.0}


@pytest.fixture(scope="module")
def odrive_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("can_export") / "asmc_odrive.fmu"
    return export_c_fmu("asmc", out, {**CTRL, **ODRIVE}, fmi=3, can="odrive")


def test_the_odrive_fmu_is_a_valid_lsbus_can_node(odrive_fmu: Path) -> None:
    from fmpy.validation import validate_fmu

    from twmr.fmi.lsbus.terminals import VERSION, bus_terminals

    assert validate_fmu(str(odrive_fmu)) == []
    (terminal,) = bus_terminals(odrive_fmu, "ctrl")
    assert (terminal.name, terminal.version, terminal.notes) == ("CanChannel", VERSION, [])
    assert terminal.members == {"Rx_Clock": RX_CLOCK, "Rx_Data": RX,
                                "Tx_Clock": "CanChannel.Tx_Clock", "Tx_Data": TX}
    comp = _fmu(odrive_fmu).component
    assert comp.variables["wheel_speed"].kind == "output"  # the frames give it
    assert not comp.has_feedthrough  # its outputs change at its events only
    assert comp.variables[RX].kind == "input" and comp.variables[TX].kind == "output"


def test_the_odrive_fmu_sends_the_asmc_torque_as_set_input_torque(odrive_fmu: Path) -> None:
    """Each step the drives' estimates arrive at its start and the FMU answers at once with the
    block's torque at that point (`evaluate`); every seventh step no frame comes and the FMU
    sends at the end of the step what the block outputs after `do_step`."""
    nodes, gear, limit = (3, 5), 2.5, 40.0
    rng = np.random.default_rng(26)
    fmu, ctrl = _started(odrive_fmu)
    want = []
    for n in nodes:
        want += [CanTransmit(*p.encode_clear_errors(n, "0.6.10")),
                 CanTransmit(*p.encode_limits(n, 50.0, limit / (gear * 0.8), gear)),
                 CanTransmit(*p.encode_controller_mode(n)),
                 CanTransmit(*p.encode_axis_state(n, p.AXIS_CLOSED_LOOP))]
    sent = _transmits(fmu[TX])
    assert sent[:8] == want
    sent, py = sent[8:], ctrl["torque"]
    worst, fallbacks = 0.0, 0
    for k in range(STEPS + 1):
        assert sent == [CanTransmit(*p.encode_torque(n, min(limit, max(-limit, tau)), gear))
                        for n, tau in zip(nodes, py, strict=True)] + \
            [CanTransmit(p.can_id(n, p.GET_ENCODER_ESTIMATES), rtr=True, dlc=8) for n in nodes]
        for op, tau in zip(sent, py, strict=False):
            got, held = p.decode_torque(op.data, gear), min(limit, max(-limit, tau))
            assert abs(got - held) <= _quantum(held, gear), (k, got, held)
            worst = max(worst, abs(got - held))
        # its Float64 outputs are those of the period it sent last
        assert np.allclose(fmu["torque"], py, rtol=1e-12, atol=1e-12), k
        if k == STEPS:
            break
        if k % 7 == 6:  # no answer: the FMU sends at the end of the step
            fmu.step(**_inputs(k), **{RX: b"", RX_CLOCK: False})
            ctrl.step(**_inputs(k))
            py, fallbacks = ctrl["torque"], fallbacks + 1
        else:
            frames = [CanTransmit(*p.encode_encoder(n, 0.1 * k, w, gear))
                      for n, w in zip(nodes, _speeds(rng), strict=True)]
            frames.insert(1, CanTransmit(*p.encode_heartbeat(nodes[0], p.Heartbeat(0, 8),
                                                             "0.6.10")))
            carried = tuple(p.decode_encoder(f.data, gear)[1] for f in (frames[0], frames[2]))
            fmu.step(**_inputs(k), **{RX: encode(frames), RX_CLOCK: True})
            py = ctrl.set(**_inputs(k), wheel_speed=carried).evaluate()["torque"]
            ctrl.step()
            assert fmu["wheel_speed"] == carried
        sent = _transmits(fmu[TX])
        assert np.allclose(fmu["d_hat"], ctrl["d_hat"], rtol=1e-12, atol=1e-12)
    assert fallbacks == STEPS // 7
    assert worst > 0  # the wire quantised something
    assert max(abs(x) for x in ctrl["d_hat"]) > 0.01  # the adaptation ran


def test_encoder_frames_of_other_nodes_and_no_frames_leave_the_speeds(odrive_fmu: Path) -> None:
    fmu = _fmu(odrive_fmu)
    fmu.set(**_inputs(0), **{RX: b"", RX_CLOCK: False})
    fmu.initialize()
    own = CanTransmit(*p.encode_encoder(5, 0.0, 7.0, 2.5))
    other = CanTransmit(*p.encode_encoder(4, 0.0, 9.0, 2.5))
    fmu.step(**{RX: encode([own, other]), RX_CLOCK: True})  # one axis's: not complete
    assert fmu["wheel_speed"] == (0.0, p.decode_encoder(own.data, 2.5)[1])
    fmu.step(**{RX: b"", RX_CLOCK: False})
    assert fmu["wheel_speed"] == (0.0, p.decode_encoder(own.data, 2.5)[1])
    # sent when initialization ended (that counts for the first step), then at the end of the
    # second step, in which nothing was sent
    ticks = [t for t, clock in fmu.component._events.ticks if clock == "CanChannel.Tx_Clock"]
    assert ticks == pytest.approx([0.0, 2 * H])


# -- CiA 402 ---------------------------------------------------------------------------------
CIA = {"drive.node_ids": [4, 9], "drive.gear": 3.0, "drive.torque_limit": 40.0,
       "drive.rated_torque": 5000}


def test_the_cia402_fmu_enables_the_drives_then_sends_the_asmc_torque(tmp_path: Path) -> None:
    """The drives are emulated by hw's state table (`drive_transition`) from the controlwords
    the FMU sends; their TPDO1 answers carry the statusword and the speed, and the FMU answers
    them at once."""
    path = export_c_fmu("asmc", tmp_path / "asmc_cia402.fmu", {**CTRL, **CIA}, fmi=3,
                        can="cia402")
    nodes, gear, rated, limit = (4, 9), 3.0, 5000, 40.0
    rng = np.random.default_rng(402)
    fmu, ctrl = _started(path)
    sent = _transmits(fmu[TX])
    assert sent[:2] == [CanTransmit(0x000, bytes([0x01, n])) for n in nodes]
    sent, py = sent[2:], ctrl["torque"]
    states = {n: c.State.NOT_READY for n in nodes}
    previous = {n: 0 for n in nodes}
    enabled_at = None
    for k in range(STEPS + 1):
        rpdos = [op for op in sent if op.id & 0x780 == c.RPDO1]
        assert [op.id for op in rpdos] == [c.RPDO1 + n for n in nodes]
        assert sent[-1] == CanTransmit(0x080) and len(sent) == 3  # SYNC after the RPDOs
        for op, n, tau in zip(rpdos, nodes, py, strict=True):
            word, permille = c.decode_rpdo1(op.data)
            expect = c.next_controlword(states[n])
            if expect == c.FAULT_RESET and previous[n] == c.FAULT_RESET:
                expect = 0
            assert word == expect, (k, n, states[n])
            held = min(limit, max(-limit, tau)) if states[n] == c.State.OPERATION_ENABLED \
                else 0.0
            assert permille == c.torque_to_permille(held, gear, rated), (k, n)
            previous[n] = word
            states[n] = c.drive_transition(states[n], word)
        if enabled_at is None and all(s == c.State.OPERATION_ENABLED for s in states.values()):
            enabled_at = k
        if k == STEPS:
            break
        rpm = [int(x) for x in rng.integers(-3000, 3000, 2)]
        frames = [CanTransmit(*c.encode_tpdo1(n, c.statusword(states[n]), v))
                  for n, v in zip(nodes, rpm, strict=True)]
        speeds = tuple(c.velocity_to_si(v, gear) for v in rpm)
        fmu.step(**_inputs(k), **{RX: encode(frames), RX_CLOCK: True})
        py = ctrl.set(**_inputs(k), wheel_speed=speeds).evaluate()["torque"]
        ctrl.step()
        assert fmu["wheel_speed"] == speeds
        sent = _transmits(fmu[TX])
    assert enabled_at == 3  # disable voltage, shutdown, switch on, enable operation


# -- refusals --------------------------------------------------------------------------------
@pytest.mark.parametrize(("kind", "options", "message"), [
    ("asmc", {"fmi": 2, "can": "odrive"}, "FMI 3.0"),
    ("asmc", {"fmi": 3, "can": "profibus"}, "no CAN protocol"),
    ("gain", {"fmi": 3, "can": "odrive"}, "no port 'wheel_speed'"),
])
def test_refused_exports(tmp_path: Path, kind: str, options: dict[str, Any], message: str
                         ) -> None:
    with pytest.raises(CosimError, match=message):
        export_c_fmu(kind, tmp_path / "x.fmu", {}, **options)


def test_an_unknown_node_parameter_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CosimError, match=r"drive\.gearing.*drive\.gear"):
        export_c_fmu("asmc", tmp_path / "x.fmu", {"drive.gearing": 2}, fmi=3, can="odrive")


def test_repeated_node_ids_are_refused_when_initialization_ends(tmp_path: Path) -> None:
    path = export_c_fmu("asmc", tmp_path / "x.fmu", {"drive.node_ids": [2, 2]}, fmi=3,
                        can="odrive")
    fmu = _fmu(path)
    fmu.set(**{RX: b"", RX_CLOCK: False})
    with pytest.raises(CosimError, match=r"drive\.node_ids repeat"):
        fmu.initialize()


def test_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "ctrl.fmu"
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "export", "smc", "--fmi", "3", "--can",
                           "cia402", "--set", "drive.rated_torque=2000", "-o", str(out)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert out.is_file()
