"""Recording cost per signal: what each recorded scalar adds to a step, and to the disk.

Scenarios of K `constant` blocks (each with its own value) plus one `sine`, K = 0, 10, 100, 1000,
run through `twmr.simulate(scenario, out=<temp folder>, formats=())` (the store streaming to
`result.arrows`, `summary.json`, as `twmr run --format none` does); the time is the stepping wall
time the engine reports (`summary["wall_time_s"]`). Each K runs twice:

- recorded: the K constants' outputs and the sine (`c0.y` ... `c{K-1}.y`, `s.y`);
- not recorded: the same K + 1 components, only the sine recorded.

The K constants are also K components in the system, so the honest cost of recording is the
difference (recorded minus not recorded) at the same K and N; its least-squares slope against K
is the cost per recorded signal per step (the generated loop's tuple, its NaN/Inf check of every
recorded output, the rows -> array conversion, the store and the summary statistics). The slope
of the recorded runs alone is also given. N (steps per run) is chosen per K from a pilot run so
that a recorded run takes about `--target` seconds; runs are interleaved over K and mode and
repeated, medians reported. Disk: bytes of `result.arrows` per row per column, and the marginal
bytes per row per added signal (slope against K).

    python benchmarks/recording_cost.py [--repeats 5] [--target 0.7]

Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import twmr

KS = (0, 10, 100, 1000)
H = 1e-3


def scenario(k: int, n_steps: int, recorded: bool) -> dict[str, Any]:
    components: dict[str, Any] = {"s": {"kind": "sine", "parameters": {"frequency": 1.0}}}
    for i in range(k):
        components[f"c{i}"] = {"kind": "constant", "parameters": {"value": 1.0 + 0.5 * i}}
    signals = ["s.y"] + ([f"c{i}.y" for i in range(k)] if recorded else [])
    return {"components": components,
            "experiment": {"start": 0.0, "stop": n_steps * H, "step": H},
            "record": {"signals": signals, "decimation": 1}}


def run(k: int, n_steps: int, recorded: bool, tmp: Path, tag: str) -> tuple[float, int, int]:
    """(stepping wall time [s], rows, bytes of result.arrows) of one run."""
    sc = twmr.load(scenario(k, n_steps, recorded))
    out = tmp / tag
    result = twmr.simulate(sc, out=out, formats=())
    s = result.summary
    assert s["status"] == "completed" and s["steps_done"] == n_steps, s
    width = 2 + (k if recorded else 0)
    assert result.values.shape == (n_steps + 1, width), result.values.shape
    if recorded and k:
        assert result[f"c{k - 1}.y"][-1] == 1.0 + 0.5 * (k - 1)
    size = (out / "result.arrows").stat().st_size
    del result
    return float(s["wall_time_s"]), n_steps + 1, size


def slope(xs: list[float], ys: list[float]) -> float:
    return float(np.polyfit(np.asarray(xs, float), np.asarray(ys, float), 1)[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--target", type=float, default=0.7, help="seconds per recorded run")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        run(0, 1000, True, tmp, "warmup")  # imports (pyarrow) land inside the first timed run
        steps: dict[int, int] = {}
        for k in KS:  # pilot: N so that a recorded run takes about --target seconds
            wall, _, _ = run(k, 5000, True, tmp, f"pilot{k}")
            steps[k] = int(min(2_000_000, max(2000, round(args.target / (wall / 5000), -3))))
        print("steps per run: " + ", ".join(f"K={k}: {n}" for k, n in steps.items()), flush=True)
        us: dict[tuple[int, bool], list[float]] = {(k, r): [] for k in KS for r in (True, False)}
        disk: dict[int, tuple[int, int]] = {}
        for rep in range(args.repeats):
            order = list(KS) if rep % 2 == 0 else list(reversed(KS))
            for k in order:
                for recorded in ((True, False) if rep % 2 == 0 else (False, True)):
                    wall, rows, size = run(k, steps[k], recorded, tmp, f"k{k}{recorded}")
                    us[(k, recorded)].append(wall / steps[k] * 1e6)
                    if recorded:
                        disk[k] = (rows, size)
            print(f"repeat {rep + 1}/{args.repeats}: " + ", ".join(
                f"K={k} {us[(k, True)][-1]:.2f}/{us[(k, False)][-1]:.2f} us" for k in KS),
                flush=True)
    rec = {k: statistics.median(us[(k, True)]) for k in KS}
    norec = {k: statistics.median(us[(k, False)]) for k in KS}
    diff = {k: rec[k] - norec[k] for k in KS}
    bytes_per_row_col = {k: disk[k][1] / disk[k][0] / (k + 2) for k in KS}
    bytes_per_row = [disk[k][1] / disk[k][0] for k in KS]
    figures = {
        "ks": list(KS), "repeats": args.repeats, "steps": {str(k): steps[k] for k in KS},
        "us_per_step_recorded": {str(k): round(rec[k], 3) for k in KS},
        "us_per_step_not_recorded": {str(k): round(norec[k], 3) for k in KS},
        "us_per_step_recording": {str(k): round(diff[k], 3) for k in KS},
        "ns_per_signal_step_recorded_fit": round(slope(list(KS), [rec[k] for k in KS]) * 1e3, 1),
        "ns_per_signal_step_components_fit": round(
            slope(list(KS), [norec[k] for k in KS]) * 1e3, 1),
        "ns_per_signal_step": round(slope(list(KS), [diff[k] for k in KS]) * 1e3, 1),
        "ns_per_signal_step_at_1000": round(diff[1000] / 1000 * 1e3, 1),
        "disk_bytes_per_row_per_column": {str(k): round(bytes_per_row_col[k], 2) for k in KS},
        "disk_bytes_per_row_per_signal_fit": round(slope(list(KS), bytes_per_row), 3),
        "disk_columns_note": "columns = time + sine + K constants",
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
