"""`can_io` and `can_device` on public CAN databases (cantools' test files: a real IMU and ABS,
a vehicle bus, multiplexing, floats, signed 64-bit signals, J1939, KCD, ARXML, CAN FD).

The values sent are drawn from what each signal can carry exactly (a whole raw value times the
scale plus the offset; a float32 for a 32-bit float), so the value a receiver decodes must be
the one sent, to rounding; which value that is comes from the file's signal definitions, read
here with cantools, not from the project's code."""
from __future__ import annotations

import os
import random
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import cantools
import numpy as np
import pandas as pd
import pytest

from twmr.api import load, simulate
from twmr.core.errors import CosimError, ScenarioError
from twmr.hw.canbus import read_log

pytestmark = pytest.mark.timeout(180)

TWMR = [sys.executable, "-m", "twmr.cli"]

FILES = Path(__file__).resolve().parents[1] / "fixtures" / "dbc"
ROUND_TRIP = ["abs.dbc", "vehicle.dbc", "multiplex_2.dbc", "floating_point.dbc", "signed.dbc",
              "j1939.dbc", "open_actuator.dbc", "choices.dbc", "the_homer.kcd",
              "system-4.2.arxml"]
#: files that describe several buses, with one identifier used on two: the bus taken
NETWORK = {"the_homer.kcd": "Motor"}


def exact_value(signal: Any, rng: random.Random) -> float:
    """A physical value `signal` carries exactly, inside its range."""
    if signal.is_float:
        lo = -1e3 if signal.minimum is None else max(-1e3, signal.minimum)
        hi = 1e3 if signal.maximum is None else min(1e3, signal.maximum)
        value = rng.uniform(lo, hi)
        return float(np.float32(value)) if signal.length == 32 else value
    n = signal.length
    lo, hi = (-(1 << (n - 1)), (1 << (n - 1)) - 1) if signal.is_signed else (0, (1 << n) - 1)
    hi = min(hi, 1 << 50)
    lo = max(lo, -(1 << 50))
    scale, offset = float(signal.scale), float(signal.offset)
    for _ in range(200):
        raw = rng.randint(lo, hi)
        value = raw * scale + offset
        if (signal.minimum is None or value >= signal.minimum) and \
                (signal.maximum is None or value <= signal.maximum) and \
                (value - offset) / scale == raw:
            return value
    return 0.0 * scale + offset if lo <= 0 <= hi else lo * scale + offset


def multiplexers(message: Any) -> set[str]:
    return {s.name for s in message.signals if s.is_multiplexer}


def round_trip_scenario(path: Path, values: dict[str, float], stop: float = 0.1,
                        messages: str = "*") -> dict:
    network = {"network": NETWORK[path.name]} if path.name in NETWORK else {}
    return {
        "components": {
            "can0": {"kind": "can_bus", "parameters": {"bitrate": 1_000_000, "fd": True,
                                                        "data_bitrate": 4_000_000}},
            "dev": {"kind": "can_io", "parameters": {
                "dbc": str(path), "send": messages, "bus": "can0",
                "send_mode": "on_change", **network}, "initial": values},
            "io": {"kind": "can_io", "parameters": {"dbc": str(path), "receive": messages,
                                                    "bus": "can0", **network}},
        },
        "experiment": {"start": 0.0, "stop": stop, "step": 0.01},
        "record": {"signals": [f"io.{k}" for k in values]},
    }


@pytest.mark.parametrize("name", ROUND_TRIP)
def test_every_message_of_a_public_database_round_trips_on_the_simulated_bus(
        name: str, tmp_path: Path) -> None:
    path = FILES / name
    db = cantools.database.load_file(str(path))
    rng = random.Random(name)
    values: dict[str, float] = {}
    for message in db.messages:
        if message.is_container or (name in NETWORK and message.bus_name != NETWORK[name]):
            continue
        mux = multiplexers(message)
        for signal in message.signals:
            if signal.name not in mux:
                values[f"{message.name}.{signal.name}"] = exact_value(signal, rng)
    assert values
    result = simulate(round_trip_scenario(path, values), out=tmp_path / "run")
    last = {k: float(result[f"io.{k}"][-1]) for k in values}
    wrong = {k: (v, last[k]) for k, v in values.items()
             if abs(last[k] - v) > 1e-9 * max(1.0, abs(v))}
    assert not wrong, f"{len(wrong)} of {len(values)} signals differ: {list(wrong.items())[:5]}"
    frames = pd.read_parquet(tmp_path / "run" / "io_frames.parquet")
    pages = sum(len({tuple(sorted(p.items())) for p in _pages(m)}) for m in db.messages
                if not m.is_container and (name not in NETWORK or m.bus_name == NETWORK[name]))
    assert (frames.direction == "rx").sum() >= pages  # every page of every message was seen


def _pages(message: Any) -> list[dict[str, int]]:
    """Multiplexer value combinations of a message, from cantools' signal tree."""
    def walk(tree: list[Any]) -> list[dict[str, int]]:
        out: list[dict[str, int]] = [{}]
        for node in tree:
            if isinstance(node, dict):
                out = [{**o, mux: v, **sub} for o in out for mux, branches in node.items()
                       for v, subtree in branches.items() for sub in walk(subtree)]
        return out
    return walk(message.signal_tree)


def test_the_imu_answers_across_processes_over_udp_multicast(tmp_path: Path) -> None:
    dbc = FILES / "abs.dbc"
    channel = f"239.74.{os.getpid() % 200 + 20}.{random.randrange(2, 250)}"
    sent = {"MM5_10_TX1.Yaw_Rate": 12.5, "MM5_10_TX1.AY1": -0.000127465 * 1000 + 4.1768 - 4.1768,
            "MM5_10_TX2.Roll_Rate": -40.0, "MM5_10_TX3.AZ": 0.000127465 * 32768 - 4.1768}
    device = subprocess.Popen(
        [*TWMR, "emulate-device", str(dbc), "--node", "DRS_MM5_10",
         "--interface", "udp_multicast", "--channel", channel, "--duration", "60",
         *[a for k, v in sent.items() for a in ("--set", f"{k}={v!r}")]],
        stderr=subprocess.PIPE, text=True)
    try:
        line = device.stderr.readline() if device.stderr else ""
        assert "emulating node DRS_MM5_10" in line, line
        scenario = {
            "components": {"io": {"kind": "can_io", "parameters": {
                "dbc": str(dbc), "node": "ABS", "receive": "MM5_10_TX1, MM5_10_TX2, MM5_10_TX3",
                "interface": "udp_multicast", "channel": channel}}},
            "experiment": {"start": 0.0, "stop": 20.0, "step": 0.02},
            "record": {"signals": [f"io.{k}" for k in sent] + ["io.MM5_10_TX3.frames"]},
        }
        # the device process takes a few seconds to start: wait for its frames (bounded)
        deadline = time.monotonic() + 60
        while True:
            result = simulate({**scenario, "experiment": {**scenario["experiment"], "stop": 1.0}})
            if result["io.MM5_10_TX3.frames"][-1] > 0 or time.monotonic() > deadline:
                break
        assert result["io.MM5_10_TX3.frames"][-1] > 10
        db = cantools.database.load_file(str(dbc))
        for key, value in sent.items():
            message, signal = key.split(".")
            s = db.get_message_by_name(message).get_signal_by_name(signal)
            want = round((value - s.offset) / s.scale) * s.scale + s.offset
            assert float(result[f"io.{key}"][-1]) == pytest.approx(want, abs=1e-9)
    finally:
        device.terminate()
        device.wait(timeout=30)


def imu_bus(tmp_path: Path, extra: str = "", io: str = "") -> Path:
    (tmp_path / "abs.dbc").write_bytes((FILES / "abs.dbc").read_bytes())
    text = f"""
components:
  yaw: {{kind: ramp, parameters: {{slope: 10.0}}}}
  can0: {{kind: can_bus, parameters: {{bitrate: 500000{extra}}}}}
  imu: {{kind: can_device, parameters: {{dbc: abs.dbc, node: DRS_MM5_10, bus: can0}}}}
  abs: {{kind: can_io, parameters: {{dbc: abs.dbc, receive: 'MM5_10_TX1, MM5_10_TX2',
                                    bus: can0, timeout: 0.05{io}}}}}
connections: [yaw.y -> imu.MM5_10_TX1.Yaw_Rate]
experiment: {{start: 0.0, stop: 0.6, step: 0.01}}
record:
  signals: [abs.MM5_10_TX1.Yaw_Rate, abs.MM5_10_TX1.age, abs.MM5_10_TX1.timed_out,
            abs.MM5_10_TX2.timed_out, abs.MM5_10_TX1.frames]
"""
    path = tmp_path / "imu.yaml"
    path.write_text(text)
    return path


DROP = 0.3  # [s] from when the bus loses MM5_10_TX1 (0x70)


def test_a_missing_message_times_out_at_the_step_its_age_passes_the_timeout(
        tmp_path: Path) -> None:
    path = imu_bus(tmp_path, f", fault_ids: '0x70', fault_start: {DROP}")
    result = simulate(path, out=tmp_path / "run")
    t = result.time
    age = result["abs.MM5_10_TX1.age"]
    late = result["abs.MM5_10_TX1.timed_out"].astype(bool)
    assert not result["abs.MM5_10_TX2.timed_out"].any()  # the other message flows
    # the frames the block saw (its log) and the bus's own log agree on the last one
    frames = pd.read_parquet(tmp_path / "run" / "abs_frames.parquet")
    tx1 = frames[(frames.direction == "rx") & (frames.message == "MM5_10_TX1")]
    last_seen = float(tx1.run_time.max())
    bus = read_log(tmp_path / "run" / "can0_frames.arrows")
    # (a frame queued at the last step goes on the wire as the bus ends, after the fault)
    delivered = bus[(bus.event == "transmit") & (bus.id == 0x70) & (bus.start < t[-1])]
    assert float(delivered.time.max()) < DROP <= float(bus[bus.event == "dropped"].time.min())
    assert 0.1 < last_seen <= DROP + 0.03  # (a loaded machine runs behind the bus clock)
    # age is run time since that frame; the flag rises at the first step beyond the timeout
    np.testing.assert_allclose(age[t >= last_seen], t[t >= last_seen] - last_seen, atol=1e-9)
    first = int(np.argmax(late))
    assert late[first:].all() and not late[:first].any()
    assert t[first] - last_seen > 0.05 >= t[first - 1] - last_seen - 1e-9


def test_a_delay_fault_makes_the_reader_see_the_values_that_much_later(tmp_path: Path
                                                                       ) -> None:
    """The bus delays MM5_10_TX1 (0x70) by 20 ms, two steps: the reader's yaw rate is the
    undelayed run's two rows later, row for row; the other message is on time; the bus's log
    holds each delayed frame as received 20 ms after it ended on the wire."""
    for sub in "ab":
        (tmp_path / sub).mkdir()
    plain = simulate(imu_bus(tmp_path / "a"), out=tmp_path / "a" / "run")
    late = simulate(imu_bus(tmp_path / "b", ", fault: delay, fault_ids: '0x70', "
                            "fault_delay: 0.02"), out=tmp_path / "b" / "run")
    y0, y1 = (np.asarray(r["abs.MM5_10_TX1.Yaw_Rate"]) for r in (plain, late))
    np.testing.assert_array_equal(y1[2:], y0[:-2])
    logs = [read_log(tmp_path / sub / "run" / "can0_frames.arrows") for sub in "ab"]
    on_time, delayed = ((log[(log.event == "transmit") & (log.id == 0x70) &  # inside the run
                             (log.start > 0.0) & (log.start < 0.55)]).sort_values("start")
                        for log in logs)
    n = min(len(on_time), len(delayed))
    assert n > 40
    np.testing.assert_array_equal(delayed.start[:n], on_time.start[:n])
    np.testing.assert_allclose(delayed.time[:n].to_numpy() - on_time.time[:n].to_numpy(), 0.02,
                               atol=1e-12)
    assert (logs[1].event == "faulted").sum() >= n


def test_a_corrupted_counter_is_caught_by_the_counter_check(tmp_path: Path) -> None:
    """The bus flips the lowest bit of BREMSE_53's rolling counter (a valid CRC: the reader
    cannot tell on the wire) in 5 frames: the reader's counter check counts the jumps."""
    (tmp_path / "abs.dbc").write_bytes((FILES / "abs.dbc").read_bytes())
    db = cantools.database.load_file(str(FILES / "abs.dbc"))
    counter = db.get_message_by_name("BREMSE_53").get_signal_by_name("Bremse_53_cnt")
    assert counter.byte_order == "little_endian"
    bit = counter.start
    text = f"""
components:
  can0: {{kind: can_bus, parameters: {{bitrate: 500000, fault: corrupt, fault_ids: '0x5c0',
                                      fault_bit: {bit}, fault_count: 5, fault_start: 0.1}}}}
  abs: {{kind: can_device, parameters: {{dbc: abs.dbc, node: ABS, send: BREMSE_53, bus: can0,
                                        counters: BREMSE_53.Bremse_53_cnt}}}}
  ecu: {{kind: can_io, parameters: {{dbc: abs.dbc, receive: BREMSE_53, bus: can0,
                                    counters: BREMSE_53.Bremse_53_cnt}}}}
experiment: {{start: 0.0, stop: 0.4, step: 0.01}}
"""
    (tmp_path / "c.yaml").write_text(text)
    result = simulate(tmp_path / "c.yaml", out=tmp_path / "run")
    assert result.summary["pacing"]["ecu.BREMSE_53"]["jumps"] >= 5
    assert result.summary["pacing"]["can0.faulted"] == 5
    bus = read_log(tmp_path / "run" / "can0_frames.arrows")
    wire = [db.decode_message(0x5C0, bytes(d))["Bremse_53_cnt"]
            for d in bus[(bus.event == "transmit") & (bus.id == 0x5C0)].data]
    assert sum(a == b for a, b in zip(wire, [k % 4 for k in range(len(wire))],
                                      strict=True)) == len(wire) - 5


def test_stop_on_timeout_names_the_message(tmp_path: Path) -> None:
    path = imu_bus(tmp_path, f", fault_ids: '0x70', fault_start: {DROP}",
                   ", stop_on_timeout: true")
    with pytest.raises(CosimError, match=r"message MM5_10_TX1 \(0x70\) timed out: none seen for "
                                         r"0\.06 s \(timeout 0\.05 s\)"):
        simulate(path, out=tmp_path / "run")


def test_rolling_counter_checked_on_receipt(tmp_path: Path) -> None:
    (tmp_path / "abs.dbc").write_bytes((FILES / "abs.dbc").read_bytes())

    def run(extra: str) -> dict[str, Any]:
        text = f"""
components:
  can0: {{kind: can_bus, parameters: {{bitrate: 500000{extra}}}}}
  abs: {{kind: can_device, parameters: {{dbc: abs.dbc, node: ABS, send: BREMSE_53, bus: can0,
                                        counters: BREMSE_53.Bremse_53_cnt}}}}
  ecu: {{kind: can_io, parameters: {{dbc: abs.dbc, receive: BREMSE_53, bus: can0,
                                    counters: BREMSE_53.Bremse_53_cnt}}}}
experiment: {{start: 0.0, stop: 0.4, step: 0.01}}
record: {{signals: [ecu.BREMSE_53.Bremse_53_cnt, ecu.BREMSE_53.frames]}}
"""
        (tmp_path / "c.yaml").write_text(text)
        result = simulate(tmp_path / "c.yaml", out=tmp_path / f"run{min(len(extra), 1)}")
        return {"report": result.summary["pacing"]}

    clean = run("")
    assert "jumps" not in clean["report"]["ecu.BREMSE_53"]
    assert clean["report"]["ecu.BREMSE_53"]["seen"] > 20
    # the counter as the frames on the wire carry it, decoded with cantools: 0 1 2 3 0 1 ...
    db = cantools.database.load_file(str(FILES / "abs.dbc"))
    bus = read_log(tmp_path / "run0" / "can0_frames.arrows")
    wire = [db.decode_message(0x5C0, bytes(d))["Bremse_53_cnt"]
            for d in bus[(bus.event == "transmit") & (bus.id == 0x5C0)].data]
    assert len(wire) > 20 and wire == [k % 4 for k in range(len(wire))]
    lossy = run(", fault_ids: '0x5c0', fault_probability: 0.5, fault_seed: 3")
    assert lossy["report"]["ecu.BREMSE_53"]["jumps"] > 3


def test_can_fd_frames_keep_their_data_phase_timing(tmp_path: Path) -> None:
    path = FILES / "system-4.2.arxml"  # Message1: 9 bytes, CAN FD (12 on the wire)
    message = cantools.database.load_file(str(path)).get_message_by_name("Message1")
    assert message.is_fd and message.length == 9
    values = {f"Message1.{s.name}": exact_value(s, random.Random(1)) for s in message.signals}
    result = simulate(round_trip_scenario(path, values, 0.05, "Message1"), out=tmp_path / "run")
    assert result.status == "completed"
    for key, value in values.items():
        assert float(result[f"io.{key}"][-1]) == pytest.approx(value, rel=1e-9, abs=1e-12)
    bus = read_log(tmp_path / "run" / "can0_frames.arrows")
    fd = bus[(bus.event == "transmit") & (bus.id == message.frame_id)]
    assert len(fd) >= 1 and fd.fd.all() and fd.brs.all() and (fd.dlc == 12).all()
    duration = float((fd.time - fd.start).iloc[0])
    # at 1 Mbit/s nominal and 4 Mbit/s in the data phase: more than the 96 payload bits at the
    # data rate, less than the payload alone would take at the nominal rate
    assert 96 / 4e6 < duration < 96 / 1e6


def test_a_can_fd_message_on_a_classic_bus_is_refused_at_check(tmp_path: Path) -> None:
    scenario = round_trip_scenario(FILES / "motohawk_fd.dbc", {})
    scenario["components"]["can0"]["parameters"] = {"bitrate": 500000}
    with pytest.raises(ScenarioError, match=r"ExampleMessage are CAN FD and can_bus 'can0' is a "
                                            r"classic bus.*set fd: true"):
        load(scenario)


def test_one_identifier_for_two_messages_is_refused_at_check() -> None:
    scenario = round_trip_scenario(FILES / "the_homer.kcd", {})
    del scenario["components"]["dev"]["parameters"]["network"]
    with pytest.raises(ScenarioError, match=r"messages SteeringInfo \(bus Motor\) and "
                                            r"DriverSeat \(bus Comfort\) have the same "
                                            r"identifier 0x55b.*network:"):
        load(scenario)


def test_a_broken_database_is_named_with_its_line(tmp_path: Path) -> None:
    lines = (FILES / "abs.dbc").read_text(encoding="cp1252").splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith(" SG_ Yaw_Rate"))
    lines[k] = lines[k].replace("(0.005,-163.84)", "(0.005,-163.84")
    (tmp_path / "broken.dbc").write_text("\n".join(lines), encoding="cp1252")
    (tmp_path / "s.yaml").write_text(
        "components:\n  imu: {kind: can_io, parameters: {dbc: broken.dbc, node: ABS}}\n"
        "experiment: {stop: 0.1, step: 0.01}\n")
    out = subprocess.run([*TWMR, "check", str(tmp_path / "s.yaml")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    text = out.stdout + out.stderr
    assert "Traceback" not in text
    assert f"broken.dbc: line {k + 1}, column" in text and "component 'imu' (can_io)" in text
    assert "s.yaml:2" in text


BENCH = Path(__file__).resolve().parents[2] / "scenarios" / "bench_imu_trajectory1.yaml"


def test_the_paper_bench_imu_on_the_wire_and_at_the_receiver(tmp_path: Path) -> None:
    """The bench scenario's gyro as the MM5.10 of abs.dbc: the frames on the wire, decoded with
    cantools, carry the gyro's yaw rate in deg/s every 10 ms (the file's cycle time) quantised to
    the file's 0.005 deg/s; the receiving node's output is, at each step, the frame last ended on
    the wire. Nothing on the wall clock joins the bus: the run is not paced and is the same
    twice."""
    runs = [simulate(load(BENCH, ["experiment.stop=1.0"]), out=tmp_path / f"run{k}")
            for k in range(2)]
    result = runs[0]
    assert "lateness_p50_us" not in result.summary["pacing"]
    np.testing.assert_array_equal(runs[0].data, runs[1].data)
    t = result.time
    db = cantools.database.load_file(str(BENCH.parent / "can" / "abs.dbc"))
    bus = read_log(tmp_path / "run0" / "can0_frames.arrows")
    tx = bus[(bus.event == "transmit") & (bus.id == 0x70) & (bus.start < t[-1])]
    wire = np.array([db.decode_message(0x70, bytes(d))["Yaw_Rate"] for d in tx.data])
    gyro = np.degrees(result["imu.yaw_rate"][::10])
    assert len(wire) == 100
    np.testing.assert_allclose(wire, np.round(gyro[:100] / 0.005) * 0.005, atol=1e-9)
    last = np.searchsorted(tx.time.to_numpy(), t, side="right") - 1
    want = np.where(last >= 0, wire[np.maximum(last, 0)], 0.0)
    np.testing.assert_array_equal(result["ecu.MM5_10_TX1.Yaw_Rate"], want)
    assert not result["ecu.MM5_10_TX1.timed_out"].any()
    assert result.summary["pacing"]["imu_can.MM5_10_TX1"]["period_ms"] == pytest.approx(10.0)
