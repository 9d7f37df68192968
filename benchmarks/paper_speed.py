"""Speed of the paper's scenario: the 30 s trajectory-1 run (ASMC) at a 1 ms step.

Each run goes through `twmr.simulate` into a temporary folder exactly as `twmr run` does it
(staged folder, `result.arrows`, `summary.json`, CSV and MAT exports); the measured figure is the
stepping wall time the engine reports (`Outcome.wall_time`: set-up, stepping and recording, not
the scenario build nor the exports, which are reported apart). Reports the median of several runs,
the real-time factor (simulated / wall time; target >= 100), and the per-call cost of each
component measured by stepping it alone (the profile that says where the time goes), right
after `initialize` and after a first step.
Last line: one JSON object.
"""
from __future__ import annotations

import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import twmr
from twmr.observers.base import Observer, Outcome
from twmr.scenario import load

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "paper_trajectory1_asmc.yaml"


class Capture(Observer):
    """Keeps the run's `Outcome` (its exact wall time; the summary rounds it)."""

    def __init__(self) -> None:
        self.outcome: Outcome | None = None

    def finished(self, outcome: Outcome) -> None:
        self.outcome = outcome


def per_component_us(n: int = 20000, warm: bool = False) -> dict[str, dict[str, float]]:
    """Per-call cost [us] of each component's `evaluate` and `do_step`, each called `n` times
    alone; `warm`: after one `evaluate` and `do_step` of 1 ms, as a run calls them after its
    first step (a block's kernel is then made for that step: a long run's Python forms, see
    `twmr.core.kernel`), else right after `initialize` (before any step)."""
    system = load(SCENARIO)
    out = {}
    for name in system.order:
        c = system.components[name]
        c.setup(0.0, 30.0)
        c.initialize()
        if warm:
            c.evaluate(0.0)
            c.do_step(0.0, 1e-3)
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
    walls, totals, builds = [], [], []
    steps = 0
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            t0 = time.perf_counter()
            scenario = twmr.load(SCENARIO)
            t1 = time.perf_counter()
            capture = Capture()
            result = twmr.simulate(scenario, Path(tmp) / f"r{i}", formats=("csv", "mat"),
                                   observers=[capture])
            t2 = time.perf_counter()
            outcome = capture.outcome
            assert outcome is not None and outcome.status == "completed", outcome
            assert len(result) == outcome.n_steps // 10 + 1, len(result)
            walls.append(outcome.wall_time)
            totals.append(t2 - t1)
            builds.append(t1 - t0)
            steps = outcome.n_steps
            print(f"run {i + 1}/{repeats}: {outcome.wall_time:.3f} s "
                  f"({outcome.realtime_factor:.0f}x real time); simulate() with exports "
                  f"{t2 - t1:.3f} s, load {t1 - t0:.3f} s", flush=True)
    wall = statistics.median(walls)
    total = statistics.median(totals)
    figures = {
        "scenario": SCENARIO.name, "simulated_s": 30.0, "step_s": 1e-3, "steps": steps,
        "wall_s_median": round(wall, 4), "wall_s_min": round(min(walls), 4),
        "realtime_factor": round(30.0 / wall, 1), "target_realtime_factor": 100,
        "us_per_step": round(wall / steps * 1e6, 2),
        "simulate_with_exports_s_median": round(total, 4),
        "exports_and_folder_s_median": round(total - wall, 4),
        "load_s_median": round(statistics.median(builds), 4),
        "components": per_component_us(),
        "components_after_first_step": per_component_us(warm=True),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
