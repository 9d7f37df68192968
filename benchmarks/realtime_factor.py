"""Real-time factors: a 2-block scenario (1 s at 1 ms) paced at factors 0.5, 1 and 2, interleaved,
three rounds: the wall time of each, its ratio to factor 1 (expected 2, 1, 0.5) and the pacer's
median and worst lateness (how far past its deadline a step was released).

    python benchmarks/realtime_factor.py [--rounds 3]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

SCENARIO = """components:
  src: {kind: sine}
  g: {kind: gain}
connections: [src.y -> g.u]
experiment: {stop: 1.0, step: 0.001, realtime: %s}
"""
FACTORS = (0.5, 1.0, 2.0)


def run(factor: float) -> tuple[float, float, float]:
    import numpy as np

    import twmr
    from twmr.master import Execution

    system = twmr.load(SCENARIO % factor).fresh_system()
    ex = Execution(system, [])
    t0 = time.perf_counter()
    ex.run()
    wall = time.perf_counter() - t0
    late = ex.pacer.lateness_us() if ex.pacer is not None else np.zeros(1)
    return wall, float(np.median(late)), float(np.max(late))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    args = ap.parse_args()
    run(1.0)  # imports and the first build: not counted
    walls: dict[float, list[float]] = {f: [] for f in FACTORS}
    lateness: dict[float, list[tuple[float, float]]] = {f: [] for f in FACTORS}
    for _ in range(args.rounds):
        for f in FACTORS:
            wall, median, worst = run(f)
            walls[f].append(wall)
            lateness[f].append((median, worst))
    out: dict[str, object] = {"rounds": args.rounds, "simulated_s": 1.0}
    for f in FACTORS:
        ratios = [w / one for w, one in zip(walls[f], walls[1.0], strict=True)]
        out[f"factor_{f:g}"] = {
            "wall_s": round(statistics.median(walls[f]), 4),
            "ratio_to_factor_1": round(statistics.median(ratios), 3),
            "ratio_min": round(min(ratios), 3), "ratio_max": round(max(ratios), 3),
            "expected_ratio": 1.0 / f,
            "lateness_median_us": round(statistics.median(m for m, _ in lateness[f]), 1),
            "lateness_worst_us": round(max(w for _, w in lateness[f]), 1)}
        print(f"factor {f:g}: {out[f'factor_{f:g}']}", flush=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
