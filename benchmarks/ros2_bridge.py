"""The cost of a ROS 2 controller in lockstep: scenarios/ros2_control_robot.yaml with a loopback
peer (tests/ros2_peer.py, another process: a DDS participant that answers each joint state with
a velocity command at once) against the same robot with the commands from a constant block and
no ROS 2 topics, in the same run.

    python benchmarks/ros2_bridge.py [--steps 2000] [--rounds 3]

Reported: steps per second of each, and the latency the lockstep adds per step (the difference
of their wall times per step: a /clock, a joint state and an answer across processes).
Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import random
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "ros2_control_robot.yaml"
PEER = ROOT / "tests" / "ros2_peer.py"
STEP = 0.01


def bridged(domain: int) -> str:
    text = SCENARIO.read_text(encoding="utf-8")
    return text.replace("direction: publish}", f"direction: publish, domain_id: {domain}}}") \
        .replace("timeout: 10.0}", f"timeout: 10.0, domain_id: {domain}}}") \
        .replace("constants: 'name=right_wheel_joint|left_wheel_joint'}",
                 f"constants: 'name=right_wheel_joint|left_wheel_joint', domain_id: {domain}}}")


def plain() -> str:
    """The same robot and loops, the commands a constant (2, 1) rad/s, no ROS 2 topic."""
    import yaml

    data = yaml.safe_load(SCENARIO.read_text(encoding="utf-8"))
    comps = data["components"]
    for name in [n for n, c in comps.items() if c["kind"] == "ros2_topic"]:
        del comps[name]
    comps["commands"] = {"kind": "table", "parameters": {"times": [0.0, 1e9],
                                                         "values": [2.0, 2.0]}}
    comps["commands_left"] = {"kind": "table", "parameters": {"times": [0.0, 1e9],
                                                              "values": [1.0, 1.0]}}
    wires = [w for w in data["connections"] if not w.split("->")[1].strip().startswith(
        ("states.", "odom.")) and not w.startswith("commands.")]
    wires += ["commands.y -> error.u1[1]", "commands_left.y -> error.u1[2]"]
    data["connections"] = wires
    data["record"] = {"signals": ["plant.wheel_speed"]}
    return yaml.safe_dump(data, sort_keys=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=2000)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import twmr

    stop = args.steps * STEP
    walls: dict[str, list[float]] = {"bridge": [], "plain": []}
    for _ in range(args.rounds):
        domain = random.randint(1, 232)
        peer = subprocess.Popen([sys.executable, str(PEER), str(domain), str(args.steps),
                                 "/dev/null", "joints"], stdout=subprocess.PIPE, text=True)
        try:
            assert peer.stdout is not None and peer.stdout.readline().strip() == "ready"
            loaded = twmr.load(bridged(domain), [f"experiment.stop={stop}"])
            t0 = time.perf_counter()
            twmr.simulate(loaded, compiled="off")
            walls["bridge"].append(time.perf_counter() - t0)
        finally:
            peer.kill()
        loaded = twmr.load(plain(), [f"experiment.stop={stop}"])
        t0 = time.perf_counter()
        twmr.simulate(loaded, compiled="off")
        walls["plain"].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) for k, v in walls.items()}
    rate = {k: args.steps / v for k, v in med.items()}
    added = (med["bridge"] - med["plain"]) / args.steps
    print(f"{args.steps} steps: in lockstep with a ROS 2 peer {rate['bridge']:.0f} steps/s, "
          f"without the bridge {rate['plain']:.0f} steps/s (Python loop both); lockstep adds "
          f"{added * 1e6:.0f} us per step (median of {args.rounds})")
    print(json.dumps({"steps": args.steps, "bridge_steps_per_s": rate["bridge"],
                      "plain_steps_per_s": rate["plain"], "added_per_step_s": added,
                      "ratio_bridge_to_plain": rate["bridge"] / rate["plain"],
                      "spread_bridge_s": max(walls["bridge"]) - min(walls["bridge"])}))


if __name__ == "__main__":
    main()
