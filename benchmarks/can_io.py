"""The cost of CAN messages in the step loop: 20 messages of a public vehicle database
(cantools' vehicle.dbc) sent by one `can_io` node every step and received by another, on a
simulated 1 Mbit/s `can_bus` block stepped in run time, against the same run with the bus block
alone; and, in the same run, a bare cantools loop encoding and decoding the same frames.

    python benchmarks/can_io.py [--rounds 3] [--seconds 2.0]

Reported: frames per second encoded and decoded in the step loop (each frame once each way),
the same for the bare cantools loop, their ratio (in loop / bare: the share of cantools' speed
the loop keeps, the rest being ports, scheduling and the bus model), and the cost per step of
the 20 messages (wall time with the nodes less without, per step). Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DBC = ROOT / "tests" / "fixtures" / "dbc" / "vehicle.dbc"
N_MESSAGES = 20
STEP = 0.01  # [s]: 20 frames per step, 2000 per second, a third of a 1 Mbit/s bus


def messages() -> list[str]:
    import cantools

    db = cantools.database.load_file(str(DBC))
    return sorted(m.name for m in db.messages if m.signals)[:N_MESSAGES]


def scenario(names: list[str], seconds: float, with_nodes: bool) -> dict:
    chosen = ", ".join(names)
    components: dict = {"can0": {"kind": "can_bus", "parameters": {"bitrate": 1_000_000,
                                                                   "log_file": ""}}}
    if with_nodes:
        components["dev"] = {"kind": "can_io", "parameters": {
            "dbc": str(DBC), "send": chosen, "bus": "can0", "send_mode": "every_step",
            "log_file": ""}}
        components["ecu"] = {"kind": "can_io", "parameters": {
            "dbc": str(DBC), "receive": chosen, "bus": "can0", "log_file": ""}}
    return {"components": components,
            "experiment": {"start": 0.0, "stop": seconds, "step": STEP}}


def bare_loop(names: list[str], frames: int) -> float:
    """Wall time [s] of `frames` encodes and decodes with cantools, the messages in turn."""
    import cantools

    db = cantools.database.load_file(str(DBC))
    chosen = [db.get_message_by_name(n) for n in names]
    values = [m.decode(bytes(m.length), decode_choices=False) for m in chosen]  # raw zeros
    t0 = time.perf_counter()
    for k in range(frames):
        i = k % len(chosen)
        data = chosen[i].encode(values[i], strict=False)
        chosen[i].decode(data)
    return time.perf_counter() - t0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=2.0)
    args = parser.parse_args()

    import twmr

    names = messages()
    steps = round(args.seconds / STEP)
    walls: dict[str, list[float]] = {"nodes": [], "bus": [], "bare": []}
    seen = 0
    for _ in range(args.rounds):
        for key, nodes in (("nodes", True), ("bus", False)):
            loaded = twmr.load(scenario(names, args.seconds, nodes))
            t0 = time.perf_counter()
            result = twmr.simulate(loaded, out=None)
            walls[key].append(time.perf_counter() - t0)
            if nodes:
                seen = sum(v.get("seen", 0) for k, v in result.summary["pacing"].items()
                           if k.startswith("ecu.") and isinstance(v, dict))
        walls["bare"].append(bare_loop(names, steps * N_MESSAGES))
    med = {k: statistics.median(v) for k, v in walls.items()}
    frames = steps * N_MESSAGES
    loop_rate = frames / (med["nodes"] - med["bus"])
    bare_rate = frames / med["bare"]
    per_step = (med["nodes"] - med["bus"]) / steps
    print(f"{N_MESSAGES} messages of vehicle.dbc every {STEP * 1e3:.0f} ms for {args.seconds} s "
          f"({frames} frames, {seen} received): in the step loop {loop_rate:.0f} frames/s "
          f"encoded and decoded, bare cantools {bare_rate:.0f} frames/s (ratio "
          f"{loop_rate / bare_rate:.2f}); {per_step * 1e3:.3f} ms per step for the 20 messages "
          f"(runs {med['nodes']:.2f} s with the nodes, {med['bus']:.2f} s without)")
    print(json.dumps({"frames": frames, "received": seen, "loop_frames_per_s": loop_rate,
                      "bare_frames_per_s": bare_rate,
                      "ratio_loop_to_bare": loop_rate / bare_rate, "per_step_s": per_step,
                      "with_nodes_s": med["nodes"], "bus_only_s": med["bus"],
                      "spread_with_nodes_s": max(walls["nodes"]) - min(walls["nodes"])}))


if __name__ == "__main__":
    main()
