"""Cost of recording Binary (bus) ports: two FMI-LS-BUS test nodes wired terminal to terminal
(`tests/integration/test_lsbus_recording.py`), a 0.1 ms grid, `--steps` steps, run through
`twmr.simulate(scenario, out=<temp folder>)`, twice per repeat (interleaved):

- numbers: b.rx_frames, b.rx_time and both Tx clocks recorded;
- with Binary ports: the same, plus a's and b's Tx_Data and Rx_Data (each taken at its clock's
  ticks: 4 ports, a tick every 0.3 s of each).

The time is the stepping wall time the engine reports (`summary["wall_time_s"]`); medians over
`--repeats`, and their ratio (one run, this machine). Disk: bytes of `ticks.arrows`.

    python benchmarks/binary_recording_cost.py [--repeats 5] [--steps 20000]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import twmr
from tests.fmu_build import build_lsbus_fmu

NUMBERS = ["b.rx_frames", "b.rx_time", "a.CanChannel.Tx_Clock", "b.CanChannel.Tx_Clock"]
BINARY = ["a.CanChannel.Tx_Data", "a.CanChannel.Rx_Data", "b.CanChannel.Tx_Data",
          "b.CanChannel.Rx_Data"]
H = 1e-4


def scenario(node: Path, steps: int, signals: list[str]) -> str:
    return f"""
components:
  a: {{kind: fmu, parameters: {{path: {node}}}}}
  b: {{kind: fmu, parameters: {{path: {node}, id: 0x22}}}}
connections: [a.CanChannel -> b.CanChannel]
open: [a.payload, b.payload]
record: {{signals: [{", ".join(signals)}]}}
experiment: {{start: 0.0, stop: {steps * H}, step: {H}}}
"""


def run(node: Path, steps: int, signals: list[str], out: Path) -> tuple[float, int]:
    """(stepping wall time [s], ticks recorded) of one run."""
    r = twmr.simulate(twmr.load(scenario(node, steps, signals)), out=out)
    assert r.summary["status"] == "completed" and len(r) == steps + 1
    return float(r.summary["wall_time_s"]), sum(len(r[p]) for p in r.binary)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=20_000)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        node = build_lsbus_fmu("cannode_triggered", tmp)
        run(node, 1000, NUMBERS + BINARY, tmp / "warmup")
        walls: dict[str, list[float]] = {"numbers": [], "binary": []}
        ticks = 0
        for rep in range(args.repeats):
            for mode in (("numbers", "binary") if rep % 2 == 0 else ("binary", "numbers")):
                signals = NUMBERS + (BINARY if mode == "binary" else [])
                wall, n = run(node, args.steps, signals, tmp / f"{mode}{rep}")
                walls[mode].append(wall)
                ticks = max(ticks, n)
            print(f"repeat {rep + 1}/{args.repeats}: numbers {walls['numbers'][-1]:.3f} s, "
                  f"with Binary ports {walls['binary'][-1]:.3f} s", flush=True)
        size = (tmp / f"binary{args.repeats - 1}" / "ticks.arrows").stat().st_size
    med = {k: statistics.median(v) for k, v in walls.items()}
    print(json.dumps({"steps": args.steps, "repeats": args.repeats, "binary_ports": len(BINARY),
                      "ticks_recorded": ticks, "wall_s_numbers": round(med["numbers"], 4),
                      "wall_s_with_binary": round(med["binary"], 4),
                      "ratio": round(med["binary"] / med["numbers"], 4),
                      "us_per_step_added": round((med["binary"] - med["numbers"]) /
                                                 args.steps * 1e6, 3),
                      "ticks_arrows_bytes": size}))


if __name__ == "__main__":
    main()
