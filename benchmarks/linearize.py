"""`twmr.linearize` against the runs it makes: a 5-block loop (gain, unit delay, first-order
plant, 10 ms steps) linearised at 2 s over 200 steps (three runs of 400 steps: the pulse's
+, - and none), against three plain `twmr.simulate` runs of the same scenario to the same stop
with the same recording, interleaved over rounds: wall times and their ratio (the cost of the
identification itself: ERA, events, loading).

    python benchmarks/linearize.py [--rounds 5]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time

LOOP = """components:
  r: {kind: constant, parameters: {value: 1.0}}
  e: {kind: sum, parameters: {signs: '+-'}}
  k: {kind: gain, parameters: {k: 3.0}}
  z: {kind: delay}
  plant: {kind: first_order, parameters: {K: 2.0, T: 0.5}}
connections: [r.y -> e.u1, plant.y -> e.u2, e.y -> k.u, k.y -> z.u, z.y -> plant.u]
experiment: {stop: 4.0, step: 0.01}
record: {signals: [z.y], decimation: 1}
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()

    import twmr

    scenario = twmr.load(LOOP)
    lin, plain = [], []
    for _ in range(args.rounds):
        t0 = time.perf_counter()
        model = twmr.linearize(scenario, ["plant.u"], ["z.y"], at=2.0, horizon=200)
        lin.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(3):
            twmr.simulate(twmr.load(LOOP))
        plain.append(time.perf_counter() - t0)
    ratio = [a / b for a, b in zip(lin, plain, strict=True)]
    print(f"linearize: {statistics.median(lin) * 1e3:.1f} ms; 3 runs alone "
          f"{statistics.median(plain) * 1e3:.1f} ms; ratio {statistics.median(ratio):.2f} "
          f"({min(ratio):.2f}-{max(ratio):.2f}); order {model.order}, fit error "
          f"{model.fit_error:.1e}")
    print(json.dumps({"linearize_s": statistics.median(lin), "runs_s": statistics.median(plain),
                      "ratio": statistics.median(ratio), "ratio_min": min(ratio),
                      "ratio_max": max(ratio), "order": model.order,
                      "fit_error": model.fit_error}))


if __name__ == "__main__":
    main()
