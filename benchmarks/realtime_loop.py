"""Real-time bench loop: the bench scenario (trajectory 1, ASMC, simulated plant, motor block as
two drives on CAN, emulated on python-can's virtual bus) paced to the wall clock.

    python benchmarks/realtime_loop.py --rate 500 --duration 60 [--protocol odrive|cia402]

Reports the pacer's period error (|interval between two step releases - h|) and lateness (release
past the deadline) p50/p99/max, missed deadlines (a step released more than one period late), and
the CAN round trip measured inside the run (ODrive: remote request of the encoder estimates ->
reply; CiA 402: SYNC -> the TPDOs answering it) p50/p99, with the drive's late replies. Figures
are measured, not asserted. Last line: one JSON object.

In the same time window a second process runs a bare pacer at the same rate (no components, no
threads): its missed deadlines are the machine's floor (this shared VM takes the CPU away for 2-4 ms
a few times a minute, even from a busy loop), so `missed_deadlines - bare_missed_deadlines` is what
the bench itself costs.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import uuid
from dataclasses import replace
from pathlib import Path

from twmr.core import CosimError
from twmr.master import Execution
from twmr.scenario import load

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "bench_odrive_trajectory1.yaml"
BARE = """
import gc, json, sys
from twmr.master.execution import Pacer
rate, duration = float(sys.argv[1]), float(sys.argv[2])
gc.collect(); gc.freeze(); sys.setswitchinterval(2e-4)
pacer = Pacer(1.0 / rate)
pacer.start()
for n in range(1, int(round(rate * duration)) + 1):
    pacer(n)
print(json.dumps(pacer.stats()))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rate", type=float, default=500.0, help="steps per second [Hz]")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds of real time")
    ap.add_argument("--protocol", choices=("odrive", "cia402"), default="odrive")
    ap.add_argument("--set", action="append", default=[], help="parameter override, e.g. motor.encoder=cyclic")
    args = ap.parse_args()
    overrides = [f"motor.channel=bench-{uuid.uuid4().hex[:6]}", f"motor.protocol={args.protocol}",
                 *args.set]
    if args.protocol == "cia402":
        overrides += ["motor.node_ids=[1, 2]", "motor.rated_torque=100000",
                      "motor.torque_limit=3000.0"]
    with tempfile.TemporaryDirectory() as tmp:
        system = load(SCENARIO, overrides)
        system.experiment = replace(system.experiment, stop=args.duration, step=1.0 / args.rate,
                                    realtime=True)
        ex = Execution(system, Path(tmp) / "result.npy", progress=True)
        bare = subprocess.Popen([sys.executable, "-c", BARE, str(args.rate), str(args.duration)],
                                stdout=subprocess.PIPE, text=True)  # starts with the run's steps
        try:
            ex.run()
        except CosimError as err:  # e.g. the host watchdog tripped on a stall: report it
            print(f"run stopped: {err}", file=sys.stderr)
        floor = json.loads(bare.communicate()[0].strip().splitlines()[-1])
        log = Path(tmp) / "motor_frames.blf"
        log_mb = log.stat().st_size / 1e6 if log.exists() else 0.0
    extra = ex.info.extra
    figures = {"rate_hz": args.rate, "duration_s": args.duration, "protocol": args.protocol,
               "steps": ex.info.steps_done, "error": ex.info.error[:200],
               **{k: round(v, 2) if isinstance(v, float) else v for k, v in extra.items()},
               "period_error_target_p99_us": 200, "frame_log_mb": round(log_mb, 2),
               "bare_missed_deadlines": floor["missed_deadlines"],
               "bare_lateness_max_us": round(floor["lateness_max_us"], 2),
               "bare_period_error_p99_us": round(floor["period_error_p99_us"], 2)}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
