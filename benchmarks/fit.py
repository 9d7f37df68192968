"""`twmr.fit` against the runs it makes: the paper plant's scale recovered from a run recorded
with scale 1.4 (the plant driven open loop by a closed-loop run's recorded torques, 3 s at
1 ms, matching pose x, y and a wheel speed), then the same number of `Built.run` calls of the
same system at the same parameter values, interleaved over rounds: runs per second of each and
their ratio (target >= 0.9), the fit's wall time and the scale it found.

    python benchmarks/fit.py [--rounds 3]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STOP = 3.0
#: the paper's plant, motor and slip, the controller's torques played from the closed-loop run
OPEN_LOOP = f"""components:
  tq:
    kind: data
    parameters: {{file: closed, columns: ['ctrl.torque[1]', 'ctrl.torque[2]']}}
  motor: {{kind: motor_driver, parameters: {{mode: ideal, torque_max: 48.0}}}}
  plant:
    kind: twmr_plant
    parameters: {{scale: 1.25}}
    initial: {{pose: [0.5, 0.0, -0.7853981633974483]}}
  slip: {{kind: slip_disturbance, parameters: {{profile: paper}}}}
connections:
  - tq.y -> motor.torque_command
  - plant.wheel_speed -> motor.wheel_speed
  - motor.torque -> plant.torque
  - slip.slip_rate -> plant.slip_rate
  - slip.slip_accel -> plant.slip_accel
  - slip.disturbance -> plant.disturbance
  - plant.pose -> slip.pose
  - slip.model -> plant.slip_model
experiment: {{start: 0.0, stop: {STOP}, step: 1.0e-3, algorithm: gauss_seidel}}
record: {{signals: [tq.y, plant.pose, plant.wheel_speed, motor.torque]}}
"""


def scenario(folder: Path) -> Path:
    """The recorded closed-loop run, the open-loop scenario playing its torques, the
    measurement."""
    import twmr

    text = (ROOT / "scenarios" / "paper_trajectory1_asmc.yaml").read_text()
    text = text.replace("stop: 30.0", f"stop: {STOP}").replace("decimation: 10", "decimation: 1")
    (folder / "closed.yaml").write_text(text)
    twmr.simulate(folder / "closed.yaml", folder / "closed")
    (folder / "open.yaml").write_text(OPEN_LOOP)
    twmr.simulate(twmr.load(folder / "open.yaml", ["plant.scale=1.4"]), folder / "bench")
    return folder / "open.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import twmr
    from twmr.fitting import fit

    fits, runs_alone, found, counts = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        open_yaml = scenario(folder)
        match = ["plant.pose[1]", "plant.pose[2]", "plant.wheel_speed[1]"]
        for _ in range(args.rounds):
            t0 = time.perf_counter()
            result = fit(open_yaml, folder / "bench", ["plant.scale=0.5:2"], match)
            fits.append(time.perf_counter() - t0)
            found.append(result.estimates["plant.scale"])
            counts.append(result.runs)
            built = twmr.build(open_yaml)
            points = [1.25 + 0.01 * k for k in range(result.runs)]
            t0 = time.perf_counter()
            for value in points:
                built.run({"plant.scale": value})
            runs_alone.append(time.perf_counter() - t0)
    fit_rate = [n / w for n, w in zip(counts, fits, strict=True)]
    run_rate = [n / w for n, w in zip(counts, runs_alone, strict=True)]
    ratio = [f / r for f, r in zip(fit_rate, run_rate, strict=True)]
    print(f"fit: {counts[0]} runs in {statistics.median(fits):.2f} s (median of {args.rounds}); "
          f"the same number of Built.run calls: {statistics.median(runs_alone):.2f} s; "
          f"ratio of run rates {statistics.median(ratio):.3f} "
          f"({min(ratio):.3f}-{max(ratio):.3f}); scale found {found[0]:.9f} (true 1.4)")
    print(json.dumps({"runs": counts[0], "fit_s": statistics.median(fits),
                      "runs_alone_s": statistics.median(runs_alone),
                      "fit_runs_per_s": statistics.median(fit_rate),
                      "built_runs_per_s": statistics.median(run_rate),
                      "ratio": statistics.median(ratio), "ratio_min": min(ratio),
                      "ratio_max": max(ratio), "scale_found": found[0]}))


if __name__ == "__main__":
    main()
