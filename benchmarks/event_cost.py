"""The cost of events: the paper scenario (30 s at 1 ms, compiled loop) without events, with 100
`set` events (ctrl.k changed at 100 times) and with 100 port faults (a bias of 0 on
ctrl.torque from 100 times) and with one condition event (a set of ctrl.k each time the robot's
x crosses -10 m: the master then takes one base step at a time), interleaved over rounds: wall
times, the cost per event (with - without) / 100, and per base step of the condition event's
stepping (with - without) / 30,000.

    python benchmarks/event_cost.py [--rounds 3]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
N = 100


def scenario(events: str) -> str:
    text = (ROOT / "scenarios" / "paper_trajectory1_asmc.yaml").read_text(encoding="utf-8")
    return text + (f"events:\n{events}" if events else "")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import twmr

    times = [0.25 + 0.29 * k for k in range(N)]
    texts = {"none": scenario(""),
             "set": scenario("".join(f"  - {{at: {t:.3f}, set: ctrl.k, value: "
                                     f"{59.0 + (k % 2)}}}\n" for k, t in enumerate(times))),
             "fault": scenario("".join(f"  - {{at: {t:.3f}, port: ctrl.torque, fault: bias, "
                                       f"value: 0.0}}\n" for t in times)),
             "condition": scenario('  - {when: "plant.pose[1] < -10.0", set: ctrl.k, '
                                   'value: 59.5}\n')}
    for text in texts.values():  # compile what each needs once, outside the timing
        twmr.simulate(twmr.load(text), compiled="on")
    walls: dict[str, list[float]] = {k: [] for k in texts}
    for _ in range(args.rounds):
        for name, text in texts.items():
            scenario_ = twmr.load(text)
            t0 = time.perf_counter()
            twmr.simulate(scenario_, compiled="on")
            walls[name].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in walls.items()}
    per = {k: (med[k] - med["none"]) / N for k in ("set", "fault")}
    steps = round(30.0 / 1e-3)
    per_step = (med["condition"] - med["none"]) / steps
    print(f"30 s paper run, compiled: no events {med['none'] * 1e3:.0f} ms; {N} set events "
          f"{med['set'] * 1e3:.0f} ms ({per['set'] * 1e3:.2f} ms each); {N} port faults "
          f"{med['fault'] * 1e3:.0f} ms ({per['fault'] * 1e3:.3f} ms each); a condition event "
          f"{med['condition'] * 1e3:.0f} ms ({per_step * 1e6:.1f} us per base step)")
    print(json.dumps({"none_s": med["none"], "set_s": med["set"], "fault_s": med["fault"],
                      "condition_s": med["condition"], "per_step_watched_s": per_step,
                      "per_set_event_s": per["set"], "per_fault_s": per["fault"],
                      "spread_none_s": max(walls["none"]) - min(walls["none"])}))


if __name__ == "__main__":
    main()
