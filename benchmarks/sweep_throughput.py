"""Sweep throughput on Dask: runs per minute of the paper scenario with 1 and 2 local workers.

The scenario is the 30 s trajectory-1 run (ASMC, `scenarios/paper_trajectory1_asmc.yaml`, step
1 ms, ~0.16 s of stepping per run), swept over `plant.scale=uniform:0.9:1.1` (random draws, seed
0). Each sweep goes into a fresh temporary folder (so no run is skipped as already done) through
`twmr.sweeps.sweep` (what `twmr.sweep` and `twmr sweep` call), with `workers=1` and `workers=2`: a
LocalCluster of worker processes, one thread each, started and closed by the call. The
`on_row` callback stamps each row's arrival in this process. Figures (`_1` / `_2`: 1 / 2
workers):

- `sweep_s`: wall time of the whole sweep call (scenario check, cluster start-up, the runs,
  cluster close, `runs.parquet`); `runs_per_min` = runs / `sweep_s`, start-up included.
- `startup_s`: from the call to the start of the first run (its arrival minus its
  `wall_time_s`); `shutdown_s`: from the last row's arrival to the call's return.
- `import_distributed_s`: importing `dask.distributed` in this process, done before anything is
  timed (a `twmr sweep` pays it once on top of `startup_s`).
- `runs_per_min_steady`: start-up and each worker's first batch left out: per worker, the runs
  whose rows arrived after its first row's batch / (arrival of its last row - arrival of its
  first row), summed over workers. Runs go to the workers in batches, whose rows arrive
  together; the gap-based `scheduling_ms_*` figures below then measure batches, not runs (a
  batch's rows after its first arrive with no gap), and may come out negative.
- `scaling` = `runs_per_min_2` / `runs_per_min_1` (with start-up; the 2-worker sweep spreads its
  fixed costs over twice the runs, so this may exceed 2); `scaling_steady` the same with the
  steady figures. Target >= 1.8 on a 2-core machine.
- `overhead_ms`: median over the runs of both sweeps, each worker's first run left out, of
  `wall_time_s - step_time_s`: what a run costs inside the worker beyond the stepping the engine
  reports (scenario build, `simulate`'s set-up and the `Result`); `overhead_fraction` is it
  over the median `step_time_s`. Target <= 10 %. `step_ms_median_1/_2` show whether two workers
  slow each other down (2 cores shared with the scheduler and this process).
- `first_run_s`: median `wall_time_s` of the workers' first runs (3 in all), which pay the
  imports and loading the numba cache; `first_run_extra_s` is it minus the steady median
  `wall_time_s`.
- `scheduling_ms_per_run`: the cost outside the worker, steady state: per worker, the time
  between its first and last row's arrival minus the `wall_time_s` of the runs in between,
  summed over workers and divided by those runs (both sweeps pooled; also per sweep);
  `scheduling_ms_per_run_total_1/_2` = (`sweep_s` x workers - sum of `wall_time_s`) / runs, with
  start-up and shutdown.
- serial baseline, run first: the same draws as the 1-worker sweep, one by one in this process
  with `twmr.simulate(twmr.load(path, overrides))` (in memory, as a worker runs them):
  `serial_runs_per_min` over all of them (the first, cold run included),
  `serial_runs_per_min_steady` without it, `serial_first_run_s`; `dask_cost_ms_per_run_1` /
  `_steady_1` are the extra time per run of the 1-worker sweep over the serial loop;
  `serial_step_ms_median` (runs after the first) is the stepping time to set beside
  `step_ms_median_1`.
- `main_cpu_ms_per_run_1/_2`: CPU time of this process (the client, the scheduler and the
  nannies of the LocalCluster live here) per run: on 2 cores it competes with the 2 workers.
- `other_cpu_serial/_1/_2`: share of the machine's CPUs other processes used in each part
  (machine busy time minus this process and its reaped workers), `steal_cpu` the largest share
  the hypervisor stole; above 5 % a warning says the figures are not to be trusted.
- the floor: `hand_step_ms`, the median stepping time of one run of the hand-written numba loop
  of the same model (`compiled_schedule.hand_run`, 5 calls in this process before the sweeps
  and 5 after them; `hand_step_ms_range` their least and most), gives the most
  runs per minute W workers could do, `floor_runs_per_min_W` = W x 60 / `hand_step_ms`;
  `floor_fraction_W` = `runs_per_min_W` / it (start-up included) and `floor_fraction_steady_W`
  the same with the steady rate. Target on 2 workers: >= 0.7.
  `floor_fraction_steady_W_single_run`: the same against the floor as the issue that set the
  target words it, W cores / the compiled stepping time of one run of the scenario
  (`serial_step_ms_median`: `twmr.simulate`, which runs the driver); the hand-written loop is
  the stricter yardstick, and the one the target is checked against.
- `serial_built_runs_per_min_steady`: the same draws one by one in this process with a built
  system (`twmr.build(path).run(overrides)`, as a worker now runs them), the first run left out.
- `failed_1/_2`, `serial_failed`: runs that failed. A draw whose closed loop diverges is a failed
  run, as in a real sweep (seed 0 draws such values, e.g. plant.scale = 1.0442976...: the
  ASMC's torque is NaN at t = 17.7 s): counted in the runs per minute (it stops early), left out
  of the per-run medians. More than a tenth failed aborts the benchmark.

- `runs_per_min_pool_2`, `floor_fraction_pool_2`, `sweep_s_pool_2`: the 2-worker sweep run
  again inside a `twmr.Workers(2)` pool, after a first sweep in it (end to end: the pool's
  workers already started, the scenario built and its loop loaded in them), as a script that
  runs several sweeps in one process does.

- `--cache fresh`: the compiled loops' cache (`TWMR_CACHE_DIR`) an empty folder, as on a
  machine that has not run the scenario yet: each kind's adapters are compiled by the first run,
  and a worker compiles the scenario's own loop only when its share of the sweep repays that
  (`twmr.built.Built.expect`); `loop_cache` says which cache the figures had.

    python benchmarks/sweep_throughput.py [--runs 40] [--cache user|fresh]
    # 1 worker: RUNS, 2 workers: 2 x RUNS

Prints a table, then one JSON object on the last line.
"""
from __future__ import annotations

import argparse
import atexit
import contextlib
import json
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import psutil  # a dependency of dask.distributed

import twmr
from twmr.core.errors import CosimError
from twmr.sweeps import spec_from, sweep

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "paper_trajectory1_asmc.yaml"
VARY = "plant.scale=uniform:0.9:1.1"
TARGETS = {"scaling_min": 1.8, "overhead_fraction_max": 0.10, "floor_fraction_2_min": 0.7}
HERE = Path(__file__).resolve().parent
#: rows that arrive less than this apart came with one batch (a run takes milliseconds)
BATCH_GAP_S = 1e-3


class CpuMeter:
    """The share of the machine's CPUs that other processes (not this one nor its children: the
    workers are reaped when the sweep closes its cluster) used while it was open, and the share
    the hypervisor stole: a busy machine makes every figure here meaningless."""

    def __enter__(self) -> CpuMeter:
        self.t0, self.m0, self.p0 = time.perf_counter(), psutil.cpu_times(), self._own()
        self.s0 = self._self()
        return self

    def __exit__(self, *exc: object) -> None:
        wall, m1 = time.perf_counter() - self.t0, psutil.cpu_times()
        cpus = wall * (psutil.cpu_count() or 1)
        busy = sum(getattr(m1, f) - getattr(self.m0, f)
                   for f in ("user", "nice", "system", "irq", "softirq"))
        self.other = max(0.0, busy - (self._own() - self.p0)) / cpus
        self.main_cpu_s = self._self() - self.s0
        self.steal = (m1.steal - self.m0.steal) / cpus if hasattr(m1, "steal") else 0.0

    @staticmethod
    def _self() -> float:
        t = psutil.Process().cpu_times()
        return t.user + t.system

    @staticmethod
    def _own() -> float:
        t = psutil.Process().cpu_times()
        return t.user + t.system + t.children_user + t.children_system


def run_sweep(workers: int, runs: int) -> dict[str, Any]:
    """One sweep of `runs` samples on `workers` local workers; timings of the call and rows."""
    spec = spec_from(str(SCENARIO), [VARY], samples=runs, method="random", seed=0)
    arrivals: list[tuple[float, dict[str, Any]]] = []
    with tempfile.TemporaryDirectory(prefix=f"sweep{workers}-") as tmp:
        t0 = time.perf_counter()
        outcome = sweep(spec, Path(tmp) / "out", workers=workers,
                        on_row=lambda row: arrivals.append((time.perf_counter(), row)))
        t1 = time.perf_counter()
    bad = [r for r in outcome.rows if r["status"] != "ok"]
    if outcome.ran != runs or len(bad) > runs // 10:
        raise SystemExit(f"sweep on {workers} worker(s): {outcome.ran} of {runs} runs, "
                         f"{len(bad)} failed: {bad[:1]}")
    by_worker: dict[str, list[tuple[float, dict[str, Any]]]] = {}
    for t, row in arrivals:
        by_worker.setdefault(row["worker"], []).append((t - t0, row))
    first_t, first_row = min(arrivals, key=lambda a: a[0])
    return {"workers": workers, "runs": runs, "sweep_s": t1 - t0, "by_worker": by_worker,
            "startup_s": first_t - t0 - first_row["wall_time_s"],
            "shutdown_s": t1 - max(t for t, _ in arrivals), "failed": len(bad),
            "sum_wall_s": sum(r["wall_time_s"] for r in outcome.rows)}


def steady(s: dict[str, Any]) -> dict[str, Any]:
    """Per worker, the runs after its first: rate, gaps between runs, their rows."""
    rate, gap_s, n, rows, first = 0.0, 0.0, 0, [], []
    for arrived in s["by_worker"].values():
        first.append(arrived[0][1])
        if len(arrived) < 2:
            continue
        span = arrived[-1][0] - arrived[0][0]
        # the rows of a batch arrive together: those that came with the first row ran before
        # the span began
        later = [row for t, row in arrived if t > arrived[0][0] + BATCH_GAP_S]
        rate += len(later) / span * 60.0
        gap_s += span - sum(r["wall_time_s"] for r in later)
        n += len(later)
        rows += [r for r in later if r["status"] == "ok"]
    return {"runs_per_min": rate, "scheduling_ms": gap_s / n * 1e3 if n else float("nan"),
            "rows": rows, "first": first}


def serial(runs: int) -> dict[str, Any]:
    """The 1-worker sweep's draws, one by one in this process."""
    spec = spec_from(str(SCENARIO), [VARY], samples=runs, method="random", seed=0)
    name = VARY.partition("=")[0]
    times, steps, failed = [], [], 0
    for values in spec.samples_table():
        t0 = time.perf_counter()
        try:
            result = twmr.simulate(twmr.load(SCENARIO, [f"{name}={json.dumps(values[name])}"]))
            steps.append(result.summary["wall_time_s"])
        except CosimError:  # as a worker does: the run failed, the loop goes on
            failed += 1
        times.append(time.perf_counter() - t0)
    return {"failed": failed, "runs_per_min": runs / sum(times) * 60.0,
            "runs_per_min_steady": (runs - 1) / sum(times[1:]) * 60.0,
            "first_run_s": times[0], "total_s": sum(times),
            "step_ms_median": med_ms(steps[1:]) if len(steps) > 1 else float("nan")}


def serial_built(runs: int) -> float:
    """Runs per minute of the 1-worker sweep's draws on one built system, the first left out."""
    spec = spec_from(str(SCENARIO), [VARY], samples=runs, method="random", seed=0)
    name = VARY.partition("=")[0]
    if "build" not in dir(twmr):  # an older twmr-cosim, measured for comparison
        return float("nan")
    built = twmr.build(SCENARIO)
    times = []
    for values in spec.samples_table():
        t0 = time.perf_counter()
        with contextlib.suppress(CosimError):  # a failed run, as a worker records it
            built.run([f"{name}={json.dumps(values[name])}"])
        times.append(time.perf_counter() - t0)
    return (runs - 1) / sum(times[1:]) * 60.0


def hand_steps_ms(calls: int = 5) -> list[float]:
    """Stepping times of `calls` runs of the hand-written numba loop of the paper model [ms]."""
    sys.path.insert(0, str(HERE))
    from compiled_schedule import hand_run

    hand_run()  # compiled or loaded from numba's cache
    return [hand_run()[1] * 1e3 for _ in range(calls)]


def med_ms(values: list[float]) -> float:
    return statistics.median(values) * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40,
                        help="runs of the 1-worker sweep and of the serial loop (2 workers: 2x)")
    parser.add_argument("--cache", choices=("user", "fresh"), default="user",
                        help="the compiled loops' cache: the user's (TWMR_CACHE_DIR, default "
                             "~/.cache/twmr/schedules), or an empty folder, as on a machine "
                             "that has not run the scenario yet")
    args = parser.parse_args()
    runs = args.runs
    if runs < 4:
        parser.error("--runs: give at least 4")
    if args.cache == "fresh":  # the workers inherit it
        fresh = tempfile.mkdtemp(prefix="twmr-sweep-cache-")
        atexit.register(shutil.rmtree, fresh, ignore_errors=True)
        os.environ["TWMR_CACHE_DIR"] = fresh

    t0 = time.perf_counter()
    import dask.distributed  # noqa: F401 - paid here, not by whichever sweep comes first
    import_s = time.perf_counter() - t0
    meters = {"serial": CpuMeter(), 1: CpuMeter(), 2: CpuMeter()}
    print(f"serial: {runs} runs in this process ...", flush=True)
    with meters["serial"]:
        base = serial(runs)
    built_rpm = serial_built(runs)
    hand = hand_steps_ms()
    sweeps = {}
    for workers in (1, 2):
        print(f"sweep: {runs * workers} runs on {workers} worker(s) ...", flush=True)
        with meters[workers]:
            sweeps[workers] = run_sweep(workers, runs * workers)
    print(f"sweep: {runs * 2} runs on 2 workers of a twmr.Workers pool, after a first sweep in "
          f"it ...", flush=True)
    with twmr.Workers(2):
        run_sweep(2, runs * 2)
        pool = run_sweep(2, runs * 2)
    hand += hand_steps_ms()  # before and after the sweeps: the machine's pace across them
    hand_ms = statistics.median(hand)
    st = {w: steady(s) for w, s in sweeps.items()}

    def overhead(rows: list[dict[str, Any]]) -> float:
        return med_ms([r["wall_time_s"] - r["step_time_s"] for r in rows])

    pooled = st[1]["rows"] + st[2]["rows"]
    step_ms = med_ms([r["step_time_s"] for r in pooled])
    wall_ms = med_ms([r["wall_time_s"] for r in pooled])
    firsts = [r["wall_time_s"] for w in (1, 2) for r in st[w]["first"]]
    rpm = {w: s["runs"] / s["sweep_s"] * 60.0 for w, s in sweeps.items()}
    sched_gaps = sum(st[w]["scheduling_ms"] * len(st[w]["rows"]) for w in (1, 2))
    fig: dict[str, Any] = {
        "scenario": SCENARIO.name, "vary": VARY, "runs_1": runs, "runs_2": 2 * runs,
        "runs_per_min_1": round(rpm[1], 1), "runs_per_min_2": round(rpm[2], 1),
        "runs_per_min_steady_1": round(st[1]["runs_per_min"], 1),
        "runs_per_min_steady_2": round(st[2]["runs_per_min"], 1),
        "scaling": round(rpm[2] / rpm[1], 3),
        "scaling_steady": round(st[2]["runs_per_min"] / st[1]["runs_per_min"], 3),
        "sweep_s_1": round(sweeps[1]["sweep_s"], 3), "sweep_s_2": round(sweeps[2]["sweep_s"], 3),
        "startup_s_1": round(sweeps[1]["startup_s"], 3),
        "startup_s_2": round(sweeps[2]["startup_s"], 3),
        "shutdown_s_1": round(sweeps[1]["shutdown_s"], 3),
        "shutdown_s_2": round(sweeps[2]["shutdown_s"], 3),
        "import_distributed_s": round(import_s, 3),
        "step_ms_median": round(step_ms, 2), "wall_ms_median": round(wall_ms, 2),
        "step_ms_median_1": round(med_ms([r["step_time_s"] for r in st[1]["rows"]]), 2),
        "step_ms_median_2": round(med_ms([r["step_time_s"] for r in st[2]["rows"]]), 2),
        "overhead_ms": round(overhead(pooled), 2),
        "overhead_fraction": round(overhead(pooled) / step_ms, 4),
        "overhead_ms_1": round(overhead(st[1]["rows"]), 2),
        "overhead_ms_2": round(overhead(st[2]["rows"]), 2),
        "first_run_s": round(statistics.median(firsts), 3),
        "first_run_extra_s": round(statistics.median(firsts) - wall_ms / 1e3, 3),
        "scheduling_ms_per_run": round(sched_gaps / len(pooled), 2),
        "scheduling_ms_per_run_1": round(st[1]["scheduling_ms"], 2),
        "scheduling_ms_per_run_2": round(st[2]["scheduling_ms"], 2),
        "scheduling_ms_per_run_total_1": round(
            (sweeps[1]["sweep_s"] - sweeps[1]["sum_wall_s"]) / runs * 1e3, 2),
        "scheduling_ms_per_run_total_2": round(
            (sweeps[2]["sweep_s"] * 2 - sweeps[2]["sum_wall_s"]) / (2 * runs) * 1e3, 2),
        "failed_1": sweeps[1]["failed"], "failed_2": sweeps[2]["failed"],
        "serial_failed": base["failed"],
        "serial_runs_per_min": round(base["runs_per_min"], 1),
        "serial_runs_per_min_steady": round(base["runs_per_min_steady"], 1),
        "serial_first_run_s": round(base["first_run_s"], 3),
        "serial_step_ms_median": round(base["step_ms_median"], 2),
        "dask_cost_ms_per_run_1": round((60.0 / rpm[1] - 60.0 / base["runs_per_min"]) * 1e3, 2),
        "dask_cost_ms_per_run_steady_1": round(
            (60.0 / st[1]["runs_per_min"] - 60.0 / base["runs_per_min_steady"]) * 1e3, 2),
        "main_cpu_ms_per_run_1": round(meters[1].main_cpu_s / runs * 1e3, 2),
        "main_cpu_ms_per_run_2": round(meters[2].main_cpu_s / (2 * runs) * 1e3, 2),
        "other_cpu_serial": round(meters["serial"].other, 3),
        "other_cpu_1": round(meters[1].other, 3), "other_cpu_2": round(meters[2].other, 3),
        "steal_cpu": round(max(m.steal for m in meters.values()), 3),
        "cpus": psutil.cpu_count(), "python": sys.version.split()[0],
    }
    fig["serial_built_runs_per_min_steady"] = round(built_rpm, 1)
    fig["hand_step_ms"] = round(hand_ms, 2)
    fig["hand_step_ms_range"] = [round(min(hand), 2), round(max(hand), 2)]
    fig["loop_cache"] = args.cache
    for w in (1, 2):
        floor = w * 60e3 / hand_ms
        fig[f"floor_runs_per_min_{w}"] = round(floor, 1)
        fig[f"floor_fraction_{w}"] = round(rpm[w] / floor, 3)
        fig[f"floor_fraction_steady_{w}"] = round(st[w]["runs_per_min"] / floor, 3)
        fig[f"floor_fraction_steady_{w}_single_run"] = round(
            st[w]["runs_per_min"] * base["step_ms_median"] / (w * 60e3), 3)
    fig["sweep_s_pool_2"] = round(pool["sweep_s"], 3)
    fig["runs_per_min_pool_2"] = round(pool["runs"] / pool["sweep_s"] * 60.0, 1)
    fig["floor_fraction_pool_2"] = round(fig["runs_per_min_pool_2"] / fig["floor_runs_per_min_2"],
                                         3)
    fig["targets"] = TARGETS
    fig["targets_met"] = {
        "scaling": fig["scaling"] >= TARGETS["scaling_min"],
        "scaling_steady": fig["scaling_steady"] >= TARGETS["scaling_min"],
        "overhead_fraction": fig["overhead_fraction"] <= TARGETS["overhead_fraction_max"],
        "floor_fraction_2": fig["floor_fraction_2"] >= TARGETS["floor_fraction_2_min"],
        "floor_fraction_steady_2":
            fig["floor_fraction_steady_2"] >= TARGETS["floor_fraction_2_min"]}

    print()
    print(f"{'':10} {'runs':>5} {'wall s':>7} {'runs/min':>9} {'steady':>8} {'start s':>8} "
          f"{'step ms':>8} {'ovh ms':>7} {'sched ms':>9}")
    print(f"{'serial':10} {runs:5d} {base['total_s']:7.2f} {fig['serial_runs_per_min']:9.1f} "
          f"{fig['serial_runs_per_min_steady']:8.1f} {'-':>8} {'-':>8} {'-':>7} {'-':>9}")
    for w in (1, 2):
        s = sweeps[w]
        print(f"{f'{w} worker':10} {s['runs']:5d} {s['sweep_s']:7.2f} {rpm[w]:9.1f} "
              f"{st[w]['runs_per_min']:8.1f} {s['startup_s']:8.2f} "
              f"{fig[f'step_ms_median_{w}']:8.1f} {fig[f'overhead_ms_{w}']:7.2f} "
              f"{st[w]['scheduling_ms']:9.2f}")
    print(f"scaling 2/1: {fig['scaling']:.2f} with start-up, {fig['scaling_steady']:.2f} steady "
          f"(target >= {TARGETS['scaling_min']}); overhead per run {fig['overhead_ms']:.2f} ms = "
          f"{fig['overhead_fraction']:.1%} of {step_ms:.1f} ms stepping (target <= "
          f"{TARGETS['overhead_fraction_max']:.0%}); first run on a worker "
          f"{fig['first_run_s']:.2f} s (+{fig['first_run_extra_s']:.2f} s)")
    print(f"floor (hand loop {hand_ms:.1f} ms a run): 1 worker {fig['floor_fraction_1']:.0%} "
          f"({fig['floor_fraction_steady_1']:.0%} steady), 2 workers "
          f"{fig['floor_fraction_2']:.0%} ({fig['floor_fraction_steady_2']:.0%} steady; target "
          f">= {TARGETS['floor_fraction_2_min']:.0%})")
    busy = {k: max(m.other, m.steal) for k, m in meters.items()}
    busy = {k: v for k, v in busy.items() if v > 0.05}
    if busy:
        print(f"WARNING: other processes (or the hypervisor) used {max(busy.values()):.0%} of "
              f"the CPUs during {', '.join(f'{k} worker' if k != 'serial' else k for k in busy)}"
              f": the figures above are not this code's; run again on a quiet machine")
    print(json.dumps(fig))


if __name__ == "__main__":  # the workers are spawned processes that import this module
    main()
