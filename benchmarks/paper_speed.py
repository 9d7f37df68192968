"""Speed of the paper's scenario: the 30 s trajectory-1 run (ASMC) at a 1 ms step.

Reports the wall time of the run and the real-time factor (simulated / wall time; target >= 100),
the median of several runs, and the per-call cost of each component measured by stepping it alone
(the profile that says where the time goes). Last line: one JSON object.
"""
from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from twmr.master import Execution
from twmr.scenario import load

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "paper_trajectory1_asmc.yaml"


def per_component_us(n: int = 20000) -> dict[str, dict[str, float]]:
    system = load(SCENARIO)
    out = {}
    for name in system.order:
        c = system.components[name]
        c.setup(0.0, 30.0)
        c.initialize()
        t0 = time.perf_counter()
        for k in range(n):
            c.evaluate(k * 1e-3)
        t1 = time.perf_counter()
        for k in range(n):
            c.do_step(k * 1e-3, 1e-3)
        t2 = time.perf_counter()
        out[name] = {"evaluate_us": round((t1 - t0) / n * 1e6, 3),
                     "do_step_us": round((t2 - t1) / n * 1e6, 3)}
    return out


def main() -> None:
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    walls = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            ex = Execution(load(SCENARIO), Path(tmp) / f"r{i}.npy")
            ex.run()
            walls.append(ex.info.wall_time)
            print(f"run {i + 1}/{repeats}: {ex.info.wall_time:.3f} s "
                  f"({ex.info.realtime_factor:.0f}x real time)", flush=True)
    steps = ex.info.n_steps
    wall = statistics.median(walls)
    figures = {
        "scenario": SCENARIO.name, "simulated_s": 30.0, "step_s": 1e-3, "steps": steps,
        "wall_s_median": round(wall, 4), "wall_s_min": round(min(walls), 4),
        "realtime_factor": round(30.0 / wall, 1), "target_realtime_factor": 100,
        "us_per_step": round(wall / steps * 1e6, 2), "components": per_component_us(),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
