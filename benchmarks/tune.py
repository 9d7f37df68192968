"""Tune throughput: runs (evaluations) per minute of `twmr.tune` on the paper scenario, with 1
worker (in this process) and 2 (a local Dask cluster), against `twmr.sweep` of as many runs of
the same scenario.

The scenario is `scenarios/paper_trajectory1_asmc.yaml` (30 s, step 1 ms). The tune searches
`ctrl.eta=log:0.01:10` and `ctrl.phi=0.05:1` for `mse_x + mse_y` (tracking) over `--realisations`
draws of `slip.phase=uniform:0:5`, `--trials` trials. The sweep runs the same runs: a run's cost
depends on the controller's parameters, so it sweeps the tune's own trial points,
`ctrl.eta` and `ctrl.phi` as `values:` of the trials' (each value `--realisations` times, paired at
random), with `slip.phase=uniform:0:5`. The tune is seeded, so every call proposes the same trials;
an untimed first tune per worker count gives them (and warms the numba cache). Each call goes into a
fresh temporary folder; its wall time includes the scenario check and, with 2 workers, the cluster's
start-up and close.
Figures, medians over `--rounds` rounds (tune and sweep alternate in each, their order swapped
from one round to the next): `tune_runs_per_min_W`, `sweep_runs_per_min_W`, `ratio_W` = tune /
sweep (target >= 0.9), and `ratio_W_spread`, the lowest and highest ratio of the rounds. The
tune asks its trials in batches of W (its default: the workers), so the runs of W trials are on
the cluster at once.

    python benchmarks/tune.py [--trials 10] [--realisations 4] [--rounds 3] [--lockstep]

Prints one JSON object.
"""
from __future__ import annotations

import argparse
import json
import statistics
import tempfile
import time
from pathlib import Path

import twmr

SCENARIO = "scenarios/paper_trajectory1_asmc.yaml"
PHASE = "slip.phase=uniform:0:5"


def timed(call) -> float:  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    call()
    return time.perf_counter() - t0


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=10)
    p.add_argument("--realisations", type=int, default=4)
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--lockstep", action="store_true",
                   help="tune in lockstep (a batch asked once the one before is told)")
    args = p.parse_args()
    runs = args.trials * args.realisations
    figures: dict[str, object] = {"runs": runs, "rounds": args.rounds,
                                  "lockstep": args.lockstep}
    times: dict[tuple[str, int], list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        def tune(workers: int, out: str):  # type: ignore[no-untyped-def]
            return twmr.tune(
                SCENARIO, ["ctrl.eta=log:0.01:10", "ctrl.phi=0.05:1"], "mse_x + mse_y",
                vary=[PHASE], realisations=args.realisations, trials=args.trials,
                metrics=["tracking"], workers=workers, lockstep=args.lockstep, report=False,
                out=Path(tmp) / out)

        points = {}
        for workers in (1, 2):
            trials = tune(workers, f"warm{workers}").trials
            points[workers] = [PHASE, *(
                f"{name}=values:" + ",".join(repr(float(t[name])) for t in trials)
                for name in ("ctrl.eta", "ctrl.phi"))]
        for r in range(args.rounds):
            for workers in (1, 2):
                calls = {
                    "tune": lambda w=workers, r=r: tune(w, f"tune{w}_{r}"),
                    "sweep": lambda w=workers, r=r: twmr.sweep(
                        SCENARIO, points[w], samples=runs, seed=1, workers=w,
                        metrics=["tracking"], out=Path(tmp) / f"sweep{w}_{r}")}
                for name in (("tune", "sweep") if r % 2 == 0 else ("sweep", "tune")):
                    times.setdefault((name, workers), []).append(timed(calls[name]))
    for workers in (1, 2):
        tune, sweep = times["tune", workers], times["sweep", workers]
        ratios = [s_ / t_ for s_, t_ in zip(sweep, tune, strict=True)]
        figures[f"tune_runs_per_min_{workers}"] = round(60 * runs / statistics.median(tune), 1)
        figures[f"sweep_runs_per_min_{workers}"] = round(60 * runs / statistics.median(sweep), 1)
        figures[f"ratio_{workers}"] = round(statistics.median(ratios), 3)
        figures[f"ratio_{workers}_spread"] = [round(min(ratios), 3), round(max(ratios), 3)]
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
