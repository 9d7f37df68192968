"""The ASMC's loop margins along trajectory 1 (docs/linear.md): the loop broken at each wheel's
torque command (`twmr linearize --loop "motor.torque_command[i]"`, the other wheel's loop
closed) at points of the paper run, with what the linear model says of itself and whether the
controller is saturated there. Writes docs/studies/robot_margins_numbers.md; prints its wall time.

    .venv/bin/python docs/studies/robot_margins.py
"""
from __future__ import annotations

import math
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENARIO = HERE.parent.parent / "scenarios" / "paper_trajectory1_asmc.yaml"
TIMES = (1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 25.0)
HORIZON = 200  # steps of 1 ms of impulse response
LIMIT = 48.0  # [N.m] the controller's and the drive's torque limit


def main() -> None:
    import control
    import numpy as np

    import twmr
    from twmr.linear_analysis import linearize, loop_at, source_of

    started = time.perf_counter()
    scenario = twmr.load(SCENARIO)
    run = twmr.simulate(scenario)
    t = np.asarray(run["time"])
    lines = ["# Numbers of docs/studies/robot_margins.py", "",
             "Written by `.venv/bin/python docs/studies/robot_margins.py`; do not edit.", "",
             "| t [s] | wheel | |τ| / limit | order | fit error | nonlinearity | gain margin "
             "[dB] | at [rad/s] | phase margin [deg] | at [rad/s] |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for at in TIMES:
        for wheel in (1, 2):
            port = f"motor.torque_command[{wheel}]"
            model = linearize(scenario, [port], [source_of(scenario, port)], at=at,
                              horizon=HORIZON)
            gm, pm, wcg, wcp = control.margin(loop_at(model))
            row = int(np.argmin(np.abs(t - at)))
            share = abs(float(run[f"ctrl.torque[{wheel}]"][row])) / LIMIT
            db = f"{20 * math.log10(gm):.3g}" if math.isfinite(gm) and gm > 0 else "inf"
            lines.append(f"| {at:g} | {wheel} | {share:.2f} | {model.order} | "
                         f"{model.fit_error:.1e} | {model.nonlinearity:.1e} | {db} | "
                         f"{wcg:.4g} | {pm:.4g} | {wcp:.4g} |")
    lines += ["", f"Wall time: {time.perf_counter() - started:.0f} s.", ""]
    (HERE / "robot_margins_numbers.md").write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
