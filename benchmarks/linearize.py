"""`twmr.linearize` and `twmr.linear_trim.trim` against the runs they make, interleaved over
rounds (wall times and their ratio: the cost of the identification itself — ERA, the pulse
events, loading each variant — beyond the stepping):

- `loop`: a 5-block loop (gain, unit delay, first-order plant, 10 ms steps) linearised at 2 s
  over 200 steps: three runs to 4 s (the pulse's +, - and none) against three plain runs;
- `paper`: the paper's robot under the ASMC (trajectory 1, 1 ms steps) broken at the right
  wheel's torque command at 5 s, 200 steps: three runs to 5.2 s against three plain runs;
- `chain100`: 100 first-order lags in series (100 states, time constants 2 to 6 ms, 1 ms
  steps) from the first input to the last output at 0.5 s over 800 steps: three runs to 1.3 s
  against three plain runs;
- `trim`: the upright equilibrium of an inverted pendulum built from blocks (two unknowns),
  against as many one-step runs as it made.

    python benchmarks/linearize.py [--rounds 5]

Last line: one JSON object, one entry per case.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
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
PENDULUM = """components:
  push: {kind: constant, parameters: {value: 1.0}}
  w: {kind: integrator, parameters: {x0: 0.1}}
  th: {kind: integrator, parameters: {x0: 0.3}}
  s: {kind: math, parameters: {function: sin}}
  g: {kind: gain, parameters: {k: 9.81}}
  c: {kind: gain, parameters: {k: -0.5}}
  acc: {kind: sum, parameters: {signs: "+++"}}
connections: [th.y -> s.u, s.y -> g.u, w.y -> c.u, g.y -> acc.u1, c.y -> acc.u2,
              push.y -> acc.u3, acc.y -> w.u, w.y -> th.u]
experiment: {start: 0, stop: 1, step: 0.001}
"""


def chain(n: int) -> str:
    blocks = "\n".join(f"  f{i}: {{kind: first_order, parameters: {{K: 1.0, T: "
                       f"{0.002 * (1 + i % 3)}}}}}" for i in range(n))
    wires = ", ".join(f"f{i}.y -> f{i + 1}.u" for i in range(n - 1))
    return (f"components:\n  src: {{kind: constant}}\n{blocks}\nconnections: [src.y -> f0.u, "
            f"{wires}]\nexperiment: {{stop: 1.3, step: 0.001}}\nrecord: {{signals: "
            f"[f{n - 1}.y]}}\n")


def linearize_case(text: str | Path, inputs: list[str], outputs: list[str], at: float,
                   horizon: int, rounds: int) -> dict[str, Any]:
    import twmr

    scenario = twmr.load(text)
    exp = scenario.system.experiment
    stop = at + horizon * exp.step
    plain_text = [f"experiment.stop={stop!r}"]
    runs = 2 * len(inputs) + 1
    lin, plain = [], []
    model = None
    for _ in range(rounds):
        t0 = time.perf_counter()
        model = twmr.linearize(scenario, inputs, outputs, at=at, horizon=horizon)
        lin.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(runs):
            twmr.simulate(twmr.load(text, plain_text))
        plain.append(time.perf_counter() - t0)
    assert model is not None
    ratio = [a / b for a, b in zip(lin, plain, strict=True)]
    return {"linearize_s": statistics.median(lin), "runs": runs,
            "runs_s": statistics.median(plain), "ratio": statistics.median(ratio),
            "ratio_min": min(ratio), "ratio_max": max(ratio), "order": model.order,
            "fit_error": model.fit_error}


def trim_case(rounds: int) -> dict[str, Any]:
    import twmr
    from twmr.linear_trim import trim

    solve, plain = [], []
    point = None
    for _ in range(rounds):
        t0 = time.perf_counter()
        point = trim(PENDULUM, ["th.x0", "w.x0"])
        solve.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        for _ in range(point.runs):
            twmr.simulate(twmr.load(PENDULUM, ["experiment.stop=0.001"]))
        plain.append(time.perf_counter() - t0)
    assert point is not None
    ratio = [a / b for a, b in zip(solve, plain, strict=True)]
    return {"trim_s": statistics.median(solve), "runs": point.runs,
            "runs_s": statistics.median(plain), "ratio": statistics.median(ratio),
            "ratio_min": min(ratio), "ratio_max": max(ratio), "iterations": point.iterations}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    out = {
        "loop": linearize_case(LOOP, ["plant.u"], ["z.y"], 2.0, 200, args.rounds),
        "paper": linearize_case(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml",
                                ["motor.torque_command[1]"], ["ctrl.torque[1]"], 5.0, 200,
                                args.rounds),
        "chain100": linearize_case(chain(100), ["f0.u"], ["f99.y"], 0.5, 800, args.rounds),
        "trim": trim_case(args.rounds),
    }
    for name, row in out.items():
        print(f"{name}: " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                      for k, v in row.items()), flush=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
