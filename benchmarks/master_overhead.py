"""Master overhead: the same components stepped by a hand-written loop and by the master.

(a) a hand-written Python loop that wires and steps the components directly;
(b) the master running the same components from a scenario (Gauss-Seidel, recording as (a) does,
    plus its NaN/Inf check of every output at every step, which (a) does not do), its rows going
    to the result store (`ResultStore`, appending to `result.arrows` in a temporary folder); the
    time of the run (`Outcome.wall_time`) is compared, the one-off scenario build (YAML, schema,
    wiring) is reported apart.
Both run 100,000 steps in this process, interleaved and repeated, and the ratio of the medians is
reported. Then a 1-hour simulated run at 1 kHz with 10 recorded signals measures steps/second and
resident memory sampled along the run from an observer's `rows()` callback (called about every
0.1 s of wall time; it must stay flat: results stream to disk). The same hour through
`twmr.simulate` into a folder without exports and with CSV, MAT and Parquet, interleaved for
`--export-rounds` rounds (`long_run_exports_ratio`: the ratio of the medians, what the three
exports add, everything included; `long_run_exports_ratio_spread`: the rounds' own ratios), and
the time of writing as many bytes as the three files hold, 1 MB at a time, into a new file
(`long_run_exports_write_s`, and over the run without exports: the least the exports can add
on this machine, before any formatting).

Last line: one JSON object with the figures.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

import twmr
from twmr.blocks import Gain, Integrator, Sine, Sum
from twmr.master import Execution
from twmr.observers.base import Observer, Outcome
from twmr.observers.store import ResultStore
from twmr.scenario import loads

SCENARIO = """
components:
  ref: {kind: sine, parameters: {frequency: 0.5}}
  err: {kind: sum, parameters: {k2: -1.0}}
  ctrl: {kind: gain, parameters: {k: 4.0}}
  plant: {kind: integrator}
  fb: {kind: gain, parameters: {k: 1.0}}
connections:
  - ref.y -> err.u1
  - plant.y -> fb.u
  - fb.y -> err.u2
  - err.y -> ctrl.u
  - ctrl.y -> plant.u
experiment: {start: 0.0, stop: STOP, step: 0.001}
record: {signals: [RECORD], decimation: 1}
"""


def hand_loop(n_steps: int, h: float) -> list[tuple[float, ...]]:
    """The same loop written by hand, recording plant.y and ctrl.y every step."""
    ref, err, ctrl, plant, fb = (Sine("ref", frequency=0.5), Sum("err", k2=-1.0),
                                 Gain("ctrl", k=4.0), Integrator("plant"), Gain("fb", k=1.0))
    for c in (ref, err, ctrl, plant, fb):
        c.setup(0.0, n_steps * h)
        c.initialize()
    rows: list[tuple[float, ...]] = []
    for n in range(n_steps):
        t = n * h
        fb.u = plant.y
        fb.evaluate(t)
        err.u1 = ref.y
        err.u2 = fb.y
        err.evaluate(t)
        ctrl.u = err.y
        ctrl.evaluate(t)
        plant.u = ctrl.y
        rows.append((t, plant.y, ctrl.y))
        ref.do_step(t, h)
        plant.do_step(t, h)
    return rows


class Sampler(Observer):
    """Calls `fn(steps_done)` whenever the run hands its rows over (about every 0.1 s)."""

    def __init__(self, fn):
        self.fn = fn

    def rows(self, block: np.ndarray, steps_done: int) -> None:
        self.fn(steps_done)


def master_run(n_steps: int, h: float, record: str, sample=None) -> Outcome:
    """Build from the scenario text, then run; `outcome.wall_time` is the run alone."""
    text = SCENARIO.replace("STOP", repr(n_steps * h)).replace("RECORD", record)
    system = loads(text, source="master_overhead.yaml")
    observers: list[Observer] = [ResultStore()]
    if sample is not None:
        observers.append(Sampler(sample))
    with tempfile.TemporaryDirectory() as tmp:
        outcome = Execution(system, observers, folder=Path(tmp)).run()
        rows = n_steps + 1
        size = (Path(tmp) / "result.arrows").stat().st_size
    assert outcome.status == "completed" and outcome.steps_done == n_steps, outcome
    assert size > rows * 8 * (record.count(",") + 2), (size, rows)  # every row reached the disk
    return outcome


def exported_run(n_steps: int, h: float, record: str, formats: tuple[str, ...]
                 ) -> tuple[float, int]:
    """(wall time [s] of `twmr.simulate` into a temporary folder with the exports `formats`
    (written from result.arrows after the run, as `twmr run --format` does), everything
    included; bytes of the exports written)."""
    text = SCENARIO.replace("STOP", repr(n_steps * h)).replace("RECORD", record)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        result = twmr.simulate(twmr.load(text), Path(tmp) / "out", formats=formats)
        wall = time.perf_counter() - t0
        return wall, sum((result.folder / f"result.{f}").stat().st_size for f in formats)


def write_time(size: int) -> float:
    """Wall time [s] of writing `size` bytes (1 MB at a time) to a new file in the temporary
    folder: what storing the exports costs on this machine before any formatting."""
    block = np.random.default_rng(0).bytes(1 << 20)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        with open(Path(tmp) / "floor.bin", "wb") as f:
            for _ in range(size >> 20):
                f.write(block)
        return time.perf_counter() - t0


def rss_mb() -> float:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=100_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--long-seconds", type=float, default=3600.0, help="simulated seconds")
    parser.add_argument("--export-rounds", type=int, default=3,
                        help="rounds of the long run without and with exports, interleaved")
    args = parser.parse_args()
    h = 1e-3
    hand, master, build = [], [], []
    # warm-up: the first run imports pyarrow (the store's writer) inside the timed run
    hand_loop(100, h)
    master_run(100, h, "plant.y, ctrl.y")
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        hand_loop(args.steps, h)
        hand.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        outcome = master_run(args.steps, h, "plant.y, ctrl.y")
        master.append(outcome.wall_time)
        build.append(time.perf_counter() - t0 - outcome.wall_time)
    ratio = statistics.median(master) / statistics.median(hand)
    print(f"hand loop {statistics.median(hand):.3f} s, master {statistics.median(master):.3f} s "
          f"for {args.steps} steps: ratio {ratio:.3f}")

    samples: list[float] = []
    long_steps = int(args.long_seconds / h)
    ten = "ref.y, err.y, ctrl.y, plant.y, fb.y, err.u1, err.u2, ctrl.u, plant.u, fb.u"

    def sample(n: int) -> None:
        samples.append(rss_mb())
        if len(samples) % 20 == 0:
            print(f"  long run: {n / long_steps:5.1%}, rss {samples[-1]:.1f} MB", flush=True)

    t0 = time.perf_counter()
    outcome = master_run(long_steps, h, ten, sample=sample)
    wall = time.perf_counter() - t0
    quarter = max(1, len(samples) // 4)
    exported_run(long_steps, h, ten, ())  # the first pays loading the kinds, paging memory in
    plains, exported = [], []
    size = 0
    for _ in range(args.export_rounds):  # interleaved: the machine's pace moves both alike
        plains.append(exported_run(long_steps, h, ten, ())[0])
        took, size = exported_run(long_steps, h, ten, ("csv", "mat", "parquet"))
        exported.append(took)
    floor = write_time(size)
    plain, exports = statistics.median(plains), statistics.median(exported)
    ratios = [e / p for e, p in zip(exported, plains, strict=True)]
    figures = {
        "steps": args.steps,
        "hand_loop_s": round(statistics.median(hand), 4),
        "master_s": round(statistics.median(master), 4),
        "overhead_ratio": round(ratio, 4),
        "scenario_build_s": round(statistics.median(build), 4),
        "target_ratio": 1.15,
        "long_run_simulated_s": args.long_seconds,
        "long_run_steps": long_steps,
        "long_run_wall_s": round(wall, 2),
        "long_run_steps_per_s": round(long_steps / wall),
        "long_run_recorded_signals": 10,
        "rss_mb_first_quarter": round(max(samples[:quarter]), 1),
        "rss_mb_peak": round(max(samples), 1),
        "rss_growth_mb": round(max(samples) - max(samples[:quarter]), 1),
        # a leak keeps growing to the end; an allocator high-water mark levels off
        "rss_mb_third_quarter": round(max(samples[2 * quarter:3 * quarter] or samples), 1),
        "rss_mb_last_quarter": round(max(samples[3 * quarter:] or samples), 1),
        "realtime_factor": round(outcome.realtime_factor, 1),
        "long_run_engine_wall_s": round(outcome.wall_time, 2),
        "long_run_rss_samples": len(samples),
        "long_run_simulate_s": round(plain, 2),
        "long_run_simulate_csv_mat_parquet_s": round(exports, 2),
        "long_run_exports_ratio": round(exports / plain, 2),
        "long_run_exports_ratio_spread": [round(min(ratios), 2), round(max(ratios), 2)],
        "long_run_export_rounds": args.export_rounds,
        "long_run_exports_mb": round(size / 1e6),
        "long_run_exports_write_s": round(floor, 2),
        "long_run_exports_write_over_plain": round(floor / plain, 2),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
