"""Real-time bench loop: the bench scenario (trajectory 1, ASMC, simulated plant, motor block as
two ODrive drives on CAN, emulated on python-can's virtual bus) paced to the wall clock.

    python benchmarks/realtime_loop.py --rate 500 --duration 60

Reports step lateness (release time past the deadline) p50/p99/max, missed deadlines (released
more than one period late), and the CAN round trip (RTR Get_Encoder_Estimates -> reply from the
emulated drive) p50/p99. Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
import uuid
from pathlib import Path

import can
import numpy as np

from twmr.hw import protocol as p
from twmr.hw.emulator import OdriveEmulator
from twmr.master import Execution
from twmr.scenario import load

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "bench_odrive_trajectory1.yaml"


def round_trip_us(samples: int = 2000) -> list[float]:
    ch = f"rtt-{uuid.uuid4().hex[:6]}"
    emu = OdriveEmulator((0,), channel=ch, heartbeat_period=10.0, period=10.0)
    bus = can.Bus(interface="virtual", channel=ch)
    out = []
    try:
        for _ in range(samples):
            t0 = time.perf_counter_ns()
            bus.send(can.Message(arbitration_id=p.can_id(0, p.GET_ENCODER_ESTIMATES),
                                 is_remote_frame=True, is_extended_id=False, dlc=8))
            while True:
                msg = bus.recv(timeout=0.1)
                if msg is None or p.split_id(msg.arbitration_id)[1] == p.GET_ENCODER_ESTIMATES:
                    break
            out.append((time.perf_counter_ns() - t0) / 1e3)
    finally:
        bus.shutdown()
        emu.close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=500.0, help="steps per second [Hz]")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of real time")
    args = ap.parse_args()
    h = 1.0 / args.rate
    with tempfile.TemporaryDirectory() as tmp:
        system = load(SCENARIO, [f"motor.channel=bench-{uuid.uuid4().hex[:6]}",
                                 f"motor.log_file={tmp}/frames.asc"])
        from dataclasses import replace

        system.experiment = replace(system.experiment, stop=args.duration, step=h, realtime=True)
        ex = Execution(system, Path(tmp) / "r.npy", progress=True)
        ex.run()
    rtt = round_trip_us()
    figures = {"rate_hz": args.rate, "duration_s": args.duration, "steps": ex.info.steps_done,
               **{k: round(v, 2) for k, v in ex.info.extra.items()},
               "period_error_target_p99_us": 200,
               "can_rtt_p50_us": round(statistics.median(rtt), 1),
               "can_rtt_p99_us": round(float(np.percentile(rtt, 99)), 1)}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
