"""A run's fixed cost from Python: the 30 s paper scenario (trajectory 1, ASMC, 30,000 steps)
run in memory, beside the hand-written numba loop of the same model
(`compiled_schedule.hand_loop`, its stepping alone), all in this one process:

- `fresh`: `twmr.simulate(twmr.load(path, ["ctrl.k=20"]))`, as a script does it;
- `built`: `built.run({"ctrl.k": 20})` of `built = twmr.build(path)` (the system built once,
  set back and given the value at each run).

fixed cost = the run's wall time - the hand loop's stepping time; per phase (medians of the
same repeats): load (read, check, build), set-up of a built system (restore, new values),
`Execution` (algorithm prepared), the run (set-up and initialize of the components, the
compiled-loop lookup, stepping, observers) and what `simulate` adds (summary, result);
`built_outside_stepping_ms`: a `built.run` minus its own stepping (`summary['wall_time_s']`). With
`TWMR_COMPILED` unset (auto) the 30,000 steps run compiled after a first Python chunk.

    python benchmarks/fixed_cost.py [--repeats 15] [--clock cpu]

`--clock cpu` times everything by this process's CPU time (`time.process_time`) instead of the
wall clock: on a machine other processes keep busy, the wall times grow with the load and the
CPU times much less (the stepping phase, timed by the engine on the wall clock, is then left
out).

Last line: one JSON object (times in ms).
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import types
from pathlib import Path
from typing import Any

import numpy as np

import twmr

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
SCENARIO = HERE.parent / "scenarios" / "paper_trajectory1_asmc.yaml"


CLOCK = time.perf_counter


def phases_fresh() -> tuple[dict[str, float], Any]:
    from twmr.master.execution import Execution
    from twmr.observers.store import ResultStore

    t0 = CLOCK()
    scenario = twmr.load(SCENARIO, ["ctrl.k=20"])
    t1 = CLOCK()
    ex = Execution(scenario.fresh_system(), [ResultStore()])
    t2 = CLOCK()
    outcome = ex.run()
    t3 = CLOCK()
    return {"load": t1 - t0, "execution_init": t2 - t1, "run": t3 - t2,
            "stepping": outcome.wall_time}, None


def main() -> None:
    global CLOCK
    import compiled_schedule
    from compiled_schedule import hand_run

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    args = ap.parse_args()
    if args.clock == "cpu":
        CLOCK = time.process_time
        compiled_schedule.time = types.SimpleNamespace(perf_counter=CLOCK)  # its loop too
    built = twmr.build(SCENARIO)
    reference = twmr.simulate(twmr.load(SCENARIO, ["ctrl.k=20"]))  # caches warm
    same = np.array_equal(built.run({"ctrl.k": 20}).values, reference.values)
    hand_rows, _ = hand_run()
    walls: dict[str, list[float]] = {k: [] for k in (
        "hand_loop", "fresh", "built", "load", "execution_init", "run", "stepping",
        "built_setup", "built_stepping")}
    for _ in range(args.repeats):
        walls["hand_loop"].append(hand_run()[1])
        t0 = CLOCK()
        twmr.simulate(twmr.load(SCENARIO, ["ctrl.k=20"]))
        walls["fresh"].append(CLOCK() - t0)
        t0 = CLOCK()
        result = built.run({"ctrl.k": 20})
        walls["built"].append(CLOCK() - t0)
        walls["built_stepping"].append(result.summary["wall_time_s"])
        t0 = CLOCK()
        built.system_for(["ctrl.k=20"])
        walls["built_setup"].append(CLOCK() - t0)
        for key, value in phases_fresh()[0].items():
            walls[key].append(value)
    ms = {k: 1e3 * statistics.median(v) for k, v in walls.items()}
    hand = ms["hand_loop"]
    figures: dict[str, Any] = {
        "repeats": args.repeats, "steps": 30_000, "clock": args.clock,
        "hand_loop_ms": round(hand, 2),
        "fresh_ms": round(ms["fresh"], 2), "built_ms": round(ms["built"], 2),
        "fixed_fresh_ms": round(ms["fresh"] - hand, 2),
        "fixed_built_ms": round(ms["built"] - hand, 2),
        "target_fixed_ms": 2.0,
        "phase_load_ms": round(ms["load"], 2),
        "phase_built_setup_ms": round(ms["built_setup"], 2),
        "phase_execution_init_ms": round(ms["execution_init"], 2),
        "phase_run_ms": round(ms["run"], 2),
        "built_rows_equal_fresh": bool(same),
        "hand_rows_equal_master": bool(np.array_equal(
            hand_rows, twmr.simulate(twmr.load(SCENARIO)).values)),
    }
    if args.clock == "wall":
        figures.update({"phase_stepping_ms": round(ms["stepping"], 2),
                        "phase_run_outside_stepping_ms": round(ms["run"] - ms["stepping"], 2),
                        "phase_stepping_over_hand": round(ms["stepping"] / hand, 2),
                        "built_outside_stepping_ms": round(ms["built"] - ms["built_stepping"],
                                                           2)})
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
