"""Real-time bench loop: the bench scenario (trajectory 1, ASMC, simulated plant, motor block as
two drives on CAN, emulated on python-can's virtual bus) paced to the wall clock.

    python benchmarks/realtime_loop.py --rate 500 --duration 60 [--protocol odrive|cia402]

Reports the pacer's period error (|interval between two step releases - h|) and lateness (release
past the deadline) p50/p99/max, missed deadlines (a step released more than one period late), and
the CAN round trip measured inside the run (ODrive: remote request of the encoder estimates ->
reply; CiA 402: SYNC -> the TPDOs answering it) p50/p99, with the drive's late replies. Figures
are measured, not asserted. Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import tempfile
import uuid
from dataclasses import replace
from pathlib import Path

from twmr.master import Execution
from twmr.scenario import load

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "bench_odrive_trajectory1.yaml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=500.0, help="steps per second [Hz]")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of real time")
    ap.add_argument("--protocol", choices=("odrive", "cia402"), default="odrive")
    args = ap.parse_args()
    overrides = [f"motor.channel=bench-{uuid.uuid4().hex[:6]}", f"motor.protocol={args.protocol}"]
    if args.protocol == "cia402":
        overrides += ["motor.node_ids=[1, 2]", "motor.rated_torque=100000",
                      "motor.torque_limit=3000.0"]
    with tempfile.TemporaryDirectory() as tmp:
        system = load(SCENARIO, overrides)
        system.experiment = replace(system.experiment, stop=args.duration, step=1.0 / args.rate,
                                    realtime=True)
        ex = Execution(system, Path(tmp) / "result.npy", progress=True)
        ex.run()
        log_mb = (Path(tmp) / "motor_frames.blf").stat().st_size / 1e6
    extra = ex.info.extra
    figures = {"rate_hz": args.rate, "duration_s": args.duration, "protocol": args.protocol,
               "steps": ex.info.steps_done,
               **{k: round(v, 2) if isinstance(v, float) else v for k, v in extra.items()},
               "period_error_target_p99_us": 200, "frame_log_mb": round(log_mb, 2)}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
