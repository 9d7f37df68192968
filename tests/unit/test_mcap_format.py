"""`--format mcap`: one JSON channel per component, one message per recorded row on each, times in
integer nanoseconds; read with the `mcap` package's own reader, and back by `twmr.read_result`
equal to `result.arrows`."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

import twmr
from twmr.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"


def _run(tmp_path: Path, record: list[str] | None = None) -> Path:
    scenario = PAPER
    if record is not None:  # the paper scenario, recording `record` only
        import yaml

        data = yaml.safe_load(PAPER.read_text())
        data["record"] = {"signals": record}
        scenario = tmp_path / PAPER.name
        scenario.write_text(yaml.safe_dump(data))
        for fmu in PAPER.parent.glob("*.fmu"):
            (tmp_path / fmu.name).symlink_to(fmu)
    out = tmp_path / "run"
    assert main(["run", str(scenario), "--out", str(out), "--format", "mcap", "-q",
                 "--set", "experiment.stop=0.5"]) == 0
    return out


def test_channels_messages_and_times_as_an_mcap_reader_sees_them(tmp_path: Path) -> None:
    out = _run(tmp_path)
    stored = twmr.read_result(out)
    owners = sorted({c.rpartition(".")[0] for c in stored.columns[1:]})
    with open(out / "result.mcap", "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        topics = {ch.topic: ch for ch in summary.channels.values()
                  if ch.metadata.get("kind") != "scene"}  # the 3D scene: test_mcap_scene.py
        assert sorted(topics) == [f"/{o}" for o in owners]
        counts = summary.statistics.channel_message_counts
        assert {counts[ch.id] for ch in topics.values()} == {len(stored.values)}
        plant = next(ch for ch in topics.values() if ch.topic == "/plant")
        schema = json.loads(summary.schemas[plant.schema_id].data)
        assert schema["properties"]["pose"]["type"] == "array"
        assert schema["properties"]["pose"]["unit"] == "m" or "m" in \
            schema["properties"]["pose"]["description"]
        times, poses = [], []
        for _s, _c, message in reader.iter_messages(topics=["/plant"]):
            fields = json.loads(message.data)
            times.append(message.log_time)
            poses.append(fields["pose"])
    t = stored.values[:, 0]
    assert times == [round(v * 1e9) for v in t]
    assert isinstance(times[0], int) and times[1] - times[0] == round((t[1] - t[0]) * 1e9)
    cols = [stored.columns.index(f"plant.pose[{i}]") for i in (1, 2, 3)]
    assert np.array_equal(np.array(poses), stored.values[:, cols])


def test_read_back_equals_the_store_and_non_finite_values_survive(tmp_path: Path) -> None:
    out = _run(tmp_path, ["plant.pose", "ctrl.*"])
    stored = twmr.read_result(out)
    back = twmr.read_result(out / "result.mcap")
    assert back.columns == stored.columns and back.units == stored.units
    assert np.array_equal(back.values, stored.values)
    from twmr.observers.mcap_format import Mcap

    values = np.array([[0.0, np.inf, np.nan], [0.5, -np.inf, 1.0]])
    path = tmp_path / "odd.mcap"
    Mcap().write(path, ["time", "a.x", "a.v[2]"], ["s", "m", ""], values)
    columns, units, got = Mcap().read(path)
    assert columns == ["time", "a.x", "a.v[2]"] and units == ["s", "m", ""]
    assert np.array_equal(got, values, equal_nan=True)
    with open(path, "rb") as f:
        raw = [json.loads(m.data) for _s, _c, m in make_reader(f).iter_messages()]
    assert raw[0] == {"time_s": 0.0, "x": "Infinity", "v[2]": "NaN"}


def test_a_paced_can_run_logs_its_raw_frames_on_a_channel_on_the_runs_time_axis(
        tmp_path: Path) -> None:
    import uuid

    import can

    bench = ROOT / "scenarios" / "bench_odrive_trajectory1.yaml"
    out = tmp_path / "bench"
    assert main(["run", str(bench), "--out", str(out), "--format", "mcap", "-q",
                 "--set", "experiment.stop=0.3", "--set", f"motor.channel=mcap-{uuid.uuid4().hex}",
                 "--set", "motor.watchdog_periods=50", "--set", "motor.drive_watchdog=0.5",
                 "--set", "motor.heartbeat_timeout=1.0"]) == 0
    frames = list(can.LogReader(str(out / "motor_frames.blf")))
    assert frames
    start = json.loads((out / "summary.json").read_text())["pacing"]["start_unix_s"]
    with open(out / "result.mcap", "rb") as f:
        reader = make_reader(f)
        logged = [(c, json.loads(m.data), m.log_time) for _, c, m in reader.iter_messages()
                  if c.topic == "/can/motor_frames"]
    assert len(logged) == len(frames)
    assert logged[0][0].metadata == {"kind": "can_frames", "file": "motor_frames.blf"}
    by_sequence = sorted(logged, key=lambda item: item[1]["time_s"])
    for (_, message, stamp), frame in zip(by_sequence, sorted(frames, key=lambda f: f.timestamp),
                                          strict=True):
        assert message["id"] == frame.arbitration_id
        assert message["data"] == list(frame.data) and message["dlc"] == frame.dlc
        assert message["time_s"] == frame.timestamp - start
        assert stamp == max(0, round(message["time_s"] * 1e9))
    directions = {m["direction"] for _, m, _ in logged}
    assert directions == {"rx", "tx"}  # the host's commands and the drives' answers
    running = [m["time_s"] for _, m, _ in logged if m["time_s"] >= 0]
    assert running and max(running) < 0.3 + 1.0  # the run's frames end with the run
    assert twmr.read_result(out / "result.mcap").columns == twmr.read_result(out).columns
