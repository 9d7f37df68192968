"""The `data` block plays a CAN frame log decoded with a CAN database (`database:`): a candump
.log, a .blf and an .asc written by python-can's own writers from frames encoded with cantools
give, at each step, the signals of the last frame of their message at or before it (CAN is
sample and hold) — the values cantools decodes; a run's own bus log (`<bus>_frames.arrows`)
plays too; bad input names the file, the message or the signal."""
from __future__ import annotations

from pathlib import Path

import can
import cantools
import numpy as np
import pytest

from twmr.api import load, simulate
from twmr.core.errors import CosimError

pytestmark = pytest.mark.timeout(300)

DBC = Path(__file__).resolve().parents[1] / "fixtures" / "dbc" / "abs.dbc"
T0 = 1_700_000_000.0  # wall-clock stamps of the log, as a logger writes them


def frames() -> list[tuple[float, int, dict[str, float]]]:
    """(time since the log's start, message id, physical values) of a yaw and roll log: TX1
    every 10 ms with a yaw rate of 5 t, TX2 every 25 ms (from 3 ms) with a roll rate of -2 t."""
    out = [(0.01 * k, 0x70, {"Yaw_Rate": round(5 * 0.01 * k / 0.005) * 0.005 - 0.0,
                             "AY1": 0.0}) for k in range(60)]
    out += [(0.003 + 0.025 * k, 0x80, {"Roll_Rate": round(-2 * 0.025 * k / 0.005) * 0.005,
                                       "AX1": 0.0}) for k in range(24)]
    return sorted(out)


def write_log(path: Path) -> None:
    db = cantools.database.load_file(str(DBC))
    with can.Logger(str(path)) as writer:
        for t, ident, values in frames():
            data = db.get_message_by_frame_id(ident).encode(values)
            writer.on_message_received(can.Message(timestamp=T0 + t, arbitration_id=ident,
                                                   data=data, is_extended_id=False))


def scenario(tmp_path: Path, log: str, extra: str = "") -> Path:
    (tmp_path / "abs.dbc").write_bytes(DBC.read_bytes())
    path = tmp_path / "play.yaml"
    path.write_text(f"""
components:
  imu: {{kind: data, parameters: {{file: {log}, database: abs.dbc, interpolation: hold,
                                  columns: [MM5_10_TX1.Yaw_Rate, MM5_10_TX2.Roll_Rate]{extra}}}}}
experiment: {{start: 0.0, stop: 0.55, step: 0.005}}
record: {{signals: [imu.y]}}
""")
    return path


def expected(times: np.ndarray) -> np.ndarray:
    """The hold of each column's last frame at or before each time (the samples start at the
    first frame after which both messages have been seen: 3 ms)."""
    db = cantools.database.load_file(str(DBC))
    log = [(t, db.get_message_by_frame_id(i).decode(db.get_message_by_frame_id(i).encode(v)))
           for t, i, v in frames()]
    out = []
    for t in times:
        yaw = [v["Yaw_Rate"] for s, v in log if s <= t + 1e-12 and "Yaw_Rate" in v]
        roll = [v["Roll_Rate"] for s, v in log if s <= t + 1e-12 and "Roll_Rate" in v]
        out.append((yaw[-1] if yaw else np.nan, roll[-1] if roll else np.nan))
    return np.array(out)


@pytest.mark.parametrize("suffix", [".log", ".blf", ".asc"])
def test_a_frame_log_plays_its_decoded_signals(tmp_path: Path, suffix: str) -> None:
    write_log(tmp_path / f"trace{suffix}")
    result = simulate(scenario(tmp_path, f"trace{suffix}"), out=tmp_path / "run")
    t = np.asarray(result.time)
    y = np.column_stack([result["imu.y[1]"], result["imu.y[2]"]])
    want = expected(t)
    late = t >= 0.003  # before both messages were seen the first samples are held back
    np.testing.assert_allclose(y[late], want[late], atol=1e-9)
    assert result.units["imu.y[1]"] == "deg/s"
    assert np.ptp(y[:, 0]) > 2.0 and np.ptp(y[:, 1]) > 0.5  # the signals move


def test_a_runs_own_bus_log_plays_at_its_run_times(tmp_path: Path) -> None:
    """The IMU bench of test_can_io: its bus log's MM5_10_TX1 yaw rates, played back, equal the
    values on the wire (decoded with cantools) at each frame's end."""
    from tests.integration.test_can_io import imu_bus
    from twmr.hw.canbus import read_log

    (tmp_path / "bench").mkdir()
    simulate(imu_bus(tmp_path / "bench"), out=tmp_path / "bench" / "run")
    bus = read_log(tmp_path / "bench" / "run" / "can0_frames.arrows")
    sent = bus[(bus.event == "transmit") & (bus.id == 0x70)]
    db = cantools.database.load_file(str(DBC))
    wire = [(float(t), db.decode_message(0x70, bytes(d))["Yaw_Rate"])
            for t, d in zip(sent.time, sent.data, strict=True)]
    path = scenario(tmp_path, "bench/run/can0_frames.arrows",
                    ", extrapolation: hold")
    text = path.read_text().replace("columns: [MM5_10_TX1.Yaw_Rate, MM5_10_TX2.Roll_Rate]",
                                    "columns: [MM5_10_TX1.Yaw_Rate]")
    path.write_text(text)
    result = simulate(path, out=tmp_path / "run")
    t = np.asarray(result.time)
    y = np.asarray(result["imu.y"], dtype=float)
    for k in range(len(t)):
        before = [v for s, v in wire if s <= t[k] + 1e-9]
        if before and t[k] >= wire[0][0]:
            assert y[k] == pytest.approx(before[-1], abs=1e-9), t[k]


def test_bad_input_names_the_file_message_and_signal(tmp_path: Path) -> None:
    write_log(tmp_path / "trace.log")

    def edited(old: str, new: str) -> Path:
        path = scenario(tmp_path, "trace.log")
        path.write_text(path.read_text().replace(old, new))
        return path

    with pytest.raises(CosimError, match=r"column 'MM5_10_TX1.Yaw': message MM5_10_TX1 has "
                                         r"no signal 'Yaw'.*Yaw_Rate"):
        load(edited("MM5_10_TX1.Yaw_Rate", "MM5_10_TX1.Yaw"))
    with pytest.raises(CosimError, match=r"no message 'MM5_10_TX9'.*did you mean 'MM5_10_TX\d'"):
        load(edited("MM5_10_TX1.Yaw_Rate", "MM5_10_TX9.Yaw_Rate"))
    (tmp_path / "empty.log").write_text("")
    with pytest.raises(CosimError, match=r"empty.log: no frame gives MM5_10_TX1.Yaw_Rate"):
        load(scenario(tmp_path, "empty.log"))


ODRIVE_DBC = Path(__file__).resolve().parents[2] / "hw" / "data" / "odrive-cansimple-0.6.10.dbc"


def test_a_drive_log_plays_as_its_protocol_decodes_it(tmp_path: Path) -> None:
    """A .blf of ODrive CAN Simple frames (encoded with cantools from the firmware's own DBC):
    node 0's Set_Input_Torque every 10 ms and node 1's Get_Encoder_Estimates every 10 ms from
    5 ms; `protocol: odrive` plays '0.torque_command' [N.m] and '1.speed' [rad/s] (2 pi times
    the rev/s of the frame), each held from its last frame; a column the log lacks or cannot
    name is refused with the fix."""
    db = cantools.database.load_file(str(ODRIVE_DBC))
    torque, encoder = db.get_message_by_name("Axis0_Set_Input_Torque"), \
        db.get_message_by_name("Axis1_Get_Encoder_Estimates")
    sent = sorted([(0.01 * k, torque, {"Input_Torque": 0.5 * k}) for k in range(40)] +
                  [(0.005 + 0.01 * k, encoder, {"Pos_Estimate": 0.0, "Vel_Estimate": -0.25 * k})
                   for k in range(40)], key=lambda f: f[0])
    with can.Logger(str(tmp_path / "drive.blf")) as writer:
        for t, message, values in sent:
            writer.on_message_received(can.Message(
                timestamp=T0 + t, arbitration_id=message.frame_id,
                data=message.encode(values), is_extended_id=False))
    path = tmp_path / "play.yaml"
    text = """
components:
  tq: {kind: data, parameters: {file: drive.blf, protocol: odrive, interpolation: hold,
                                columns: ['0.torque_command']}}
  w: {kind: data, parameters: {file: drive.blf, protocol: odrive, interpolation: hold,
                               columns: ['1.speed']}}
experiment: {start: 0.0, stop: 0.3, step: 0.001}
record: {signals: [tq.y, w.y]}
"""
    path.write_text(text)
    system = load(path)
    units = [system.system.components[n].variables["y"].unit for n in ("tq", "w")]
    assert units == ["N.m", "rad/s"]
    result = simulate(system)
    t = np.asarray(result["time"])
    # the samples start at 5 ms (both columns of a block seen: each block its own); a step's
    # value is the last frame at or before it
    np.testing.assert_array_equal(result["tq.y"], 0.5 * np.floor(t / 0.01 + 1e-9))
    np.testing.assert_allclose(result["w.y"], -0.25 * np.floor(
        np.maximum(t - 0.005, 0.0) / 0.01 + 1e-9) * 2 * np.pi, rtol=1e-6)
    for columns, said in (("['0.torque']", "did you mean '0.torque_command'"),
                          ("['node0.speed']", "is not '<node>.<signal>'")):
        path.write_text(text.replace("['0.torque_command']", columns))
        with pytest.raises(CosimError, match="Fix:") as caught:
            load(path)
        assert said in str(caught.value), str(caught.value)
