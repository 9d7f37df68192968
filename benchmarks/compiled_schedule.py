"""The compiled fixed-step algorithm against a hand-written numba loop and the Python schedule.

The paper's 30 s trajectory-1 scenario (ASMC, 1 ms step, 30,000 steps, 16 columns recorded every
10 steps), measured in this one run:

(a) the master with the compiled algorithm (`compiled='on'`): `Execution` with a `ResultStore`,
    the stepping wall time it reports (`Outcome.wall_time`: chunks of compiled steps, the NaN/Inf
    check at every step, the rows handed to the store); compilation happens before it;
(b) a hand-written numba loop over the same kernels (`hand_loop` below: the six blocks' kernel
    functions called in the Gauss-Seidel order, the rows written to a preallocated array every
    10 steps, no NaN/Inf check), one call for the whole run; its rows must equal (a)'s exactly;
(c) the master with the Python schedule (`compiled='off'`), as `twmr run` ran before.
Each is run `--repeats` times interleaved; medians are compared (target: a <= 2 b).

FMUs (`compiled='on'` only): (d) the chain of three `lag2` test FMUs of
benchmarks/fmu_overhead.py (100,000 steps, c.y recorded every 100) and (e) the paper scenario with
every block its standalone C FMU (`twmr export`, 30,000 steps), each through the compiled loop
(the FMUs called through their C function pointers) and through the Python loop (fmpy), per FMU
and step (targets: <= 1.0 us, moonshot <= 0.19 us); both loops' rows must be equal.

Mixed (f): the paper scenario with the slip block's `random` profile (no kernel: Python only),
`compiled='auto'` (the default: kernels collected, then the Python loop) against `'off'`,
median of three each; target: no slower.

Compile time: `twmr run`'s figure `algorithm.compile_s` (kernels collected, loop generated,
compiled or loaded from numba's cache), in a fresh process with empty numba and schedule caches
(cold), then in a second fresh process with those caches (cached).

Last line: one JSON object with the figures.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from numba import njit

from twmr.components.asmc import asmc_evaluate, asmc_step
from twmr.components.motor import motor_evaluate, motor_step
from twmr.components.plant import plant_step
from twmr.components.slip import slip_evaluate
from twmr.components.trajectory import trajectory_step
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load, loads

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.fmu_build import build_c_fmu
from tests.integration.c_fmu_scenario import export_blocks, paper, swapped

CHAIN = """
components:
  src: {kind: constant, parameters: {value: 1.0}}
  a: {kind: fmu, parameters: {path: %(fmu)s}}
  b: {kind: fmu, parameters: {path: %(fmu)s}}
  c: {kind: fmu, parameters: {path: %(fmu)s}}
connections:
  - src.y -> a.u[1]
  - src.y -> a.u[2]
  - a.y -> b.u
  - b.y -> c.u
experiment: {start: 0.0, stop: 100.0, step: 0.001}
record: {signals: [c.y], decimation: 100}
"""

SCENARIO = Path(__file__).resolve().parent.parent / "scenarios" / "paper_trajectory1_asmc.yaml"


@njit(cache=True, error_model="numpy")
def hand_loop(n_steps: int, h: float, dec: int, pt: tuple, pc: tuple, pm: tuple, pp: tuple,
              ps: tuple, ref: tuple, ctrl: tuple, xc: tuple, motor: tuple, xm: tuple,
              plant: tuple, slip: tuple, buf: np.ndarray) -> int:
    """The paper loop written by hand over the blocks' kernels (Gauss-Seidel order: controller,
    motor, slip evaluated, then every block stepped); rows into `buf`; returns rows written."""
    pos, vel, acc = ref
    pose, ws, com = plant
    k = 0
    for n in range(n_steps + 1):
        t = n * h
        xc, ctrl = asmc_evaluate(t, xc, ctrl, (pose, ws, pos, vel, acc), pc)
        xm, motor = motor_evaluate(t, xm, motor, (ctrl[0], ws), pm)
        _, slip = slip_evaluate(t, (), slip, (pose,), ps)
        if n % dec == 0:
            buf[k, 0] = t
            buf[k, 1], buf[k, 2] = pos
            buf[k, 3], buf[k, 4], buf[k, 5] = pose
            buf[k, 6], buf[k, 7] = ws
            buf[k, 8], buf[k, 9] = ctrl[0]
            buf[k, 10], buf[k, 11] = motor[0]
            buf[k, 12], buf[k, 13] = ctrl[1]
            buf[k, 14], buf[k, 15] = ctrl[3]
            k += 1
        if n == n_steps:  # the final point: no step
            break
        _, (pos, vel, acc) = trajectory_step(t, h, (), (pos, vel, acc), (), pt)
        xc, ctrl = asmc_step(t, h, xc, ctrl, (pose, ws, pos, vel, acc), pc)
        xm, motor = motor_step(t, h, xm, motor, (ctrl[0], ws), pm)
        _, (pose, ws, com) = plant_step(t, h, (), (pose, ws, com),
                                        (motor[0], slip[0], slip[1], slip[2], slip[3]), pp)
    return k


def hand_run() -> tuple[np.ndarray, float]:
    """(rows, wall time [s]) of `hand_loop` over the scenario's initialized components."""
    system = load(SCENARIO)
    exp = system.experiment
    comps = system.components
    for name in system.order:
        comps[name].setup(exp.start, exp.stop)
        comps[name].initialize()
    kern = {n: comps[n].kernel(exp.step) for n in system.order}
    ref, ctrl, motor, plant, slip = (comps[n] for n in ("ref", "ctrl", "motor", "plant", "slip"))

    def outputs(c):
        return tuple(tuple(float(v) for v in c.__dict__[p]) for p in c.outputs)

    buf = np.empty((exp.n_steps // 10 + 1, 16))
    args = (exp.n_steps, exp.step, 10, kern["ref"].params, kern["ctrl"].params,
            kern["motor"].params, kern["plant"].params, kern["slip"].params, outputs(ref),
            outputs(ctrl), kern["ctrl"].state, outputs(motor), kern["motor"].state,
            outputs(plant), outputs(slip), buf)
    t0 = time.perf_counter()
    k = hand_loop(*args)
    wall = time.perf_counter() - t0
    return buf[:k], wall


def master_run(mode: str, overrides: tuple[str, ...] = ()) -> tuple[np.ndarray, float, dict]:
    """(rows, stepping wall time [s], outcome extra) of the scenario through `Execution`."""
    system = load(SCENARIO, list(overrides))
    store = ResultStore()
    outcome = Execution(system, [store], algorithm=make_algorithm("gauss_seidel", mode)).run()
    return store.data(), outcome.wall_time, outcome.extra


COMPILE = """
import json, sys
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load
out = Execution(load(sys.argv[1]), [ResultStore()],
                algorithm=make_algorithm("gauss_seidel", "on")).run()
print(json.dumps(out.extra["algorithm.compile_s"]))
"""


def compile_times() -> tuple[float, float]:
    """compile_s in a fresh process with empty caches, then again with those caches [s]."""
    with tempfile.TemporaryDirectory(prefix="twmr-compile-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"),
                   TWMR_CACHE_DIR=str(Path(tmp) / "schedules"))
        times = []
        for _ in range(2):
            out = subprocess.run([sys.executable, "-c", COMPILE, str(SCENARIO)], env=env,
                                 capture_output=True, text=True, check=True)
            times.append(float(out.stdout.strip().splitlines()[-1]))
    return times[0], times[1]


def fmu_case(text: str, fmus: int) -> dict[str, float]:
    """Compiled and Python loop over scenario `text` with `fmus` FMUs: best of two each."""
    def one(mode: str) -> tuple[np.ndarray, float]:
        store = ResultStore()
        out = Execution(loads(text, source="bench.yaml"), [store],
                        algorithm=make_algorithm("gauss_seidel", mode)).run()
        return store.data(), out.wall_time

    compiled = [one("on") for _ in range(2)]
    python = [one("off") for _ in range(2)]
    assert np.array_equal(compiled[0][0], python[0][0]), "FMUs: compiled != Python loop"
    steps = loads(text, source="bench.yaml").experiment.n_steps
    c, p = min(w for _, w in compiled), min(w for _, w in python)
    return {"steps": steps, "fmus": fmus,
            "compiled_us_per_fmu_step": round(c / steps / fmus * 1e6, 3),
            "python_us_per_fmu_step": round(p / steps / fmus * 1e6, 3),
            "python_over_compiled": round(p / c, 1), "target_us_per_fmu_step": 1.0,
            "moonshot_us_per_fmu_step": 0.19}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    cold, cached = compile_times()
    print(f"compile: cold {cold:.2f} s, cached {cached:.3f} s", flush=True)
    hand_rows, _ = hand_run()  # compiles hand_loop
    compiled_rows, _, extra = master_run("on")
    identical = bool(np.array_equal(hand_rows, compiled_rows))
    python_rows, _, _ = master_run("off")
    assert np.array_equal(python_rows, compiled_rows), "compiled != Python schedule"
    walls: dict[str, list[float]] = {"compiled": [], "hand": [], "python": []}
    for i in range(args.repeats):
        walls["hand"].append(hand_run()[1])
        walls["compiled"].append(master_run("on")[1])
        if i < 3:
            walls["python"].append(master_run("off")[1])
        print(f"repeat {i + 1}/{args.repeats}: compiled {walls['compiled'][-1]:.4f} s, "
              f"hand {walls['hand'][-1]:.4f} s, python {walls['python'][-1]:.3f} s", flush=True)
    with tempfile.TemporaryDirectory(prefix="twmr-bench-fmus-") as tmp:
        chain = fmu_case(CHAIN % {"fmu": build_c_fmu("lag2", Path(tmp))}, 3)
        print(f"lag2 chain: {chain}", flush=True)
        data = paper()
        every = fmu_case(yaml.safe_dump(swapped(data, export_blocks(data, Path(tmp) / "c")),
                                        sort_keys=False), 5)
        print(f"paper, every block a C FMU: {every}", flush=True)
    mixed: dict[str, list[float]] = {"auto": [], "off": []}
    for _ in range(3):
        for mode in ("auto", "off"):
            mixed[mode].append(master_run(mode, ("slip.profile=random",))[1])
    mixed_auto, mixed_off = (statistics.median(mixed[m]) for m in ("auto", "off"))
    print(f"mixed: auto {mixed_auto:.3f} s, off {mixed_off:.3f} s", flush=True)
    steps = load(SCENARIO).experiment.n_steps
    us = {k: statistics.median(v) / steps * 1e6 for k, v in walls.items()}
    figures = {
        "scenario": SCENARIO.name, "steps": steps,
        "compiled_us_per_step": round(us["compiled"], 4),
        "hand_numba_loop_us_per_step": round(us["hand"], 4),
        "python_schedule_us_per_step": round(us["python"], 3),
        "compiled_over_hand": round(us["compiled"] / us["hand"], 2), "target_over_hand": 2.0,
        "python_over_compiled": round(us["python"] / us["compiled"], 1),
        "compiled_realtime_factor": round(1e-3 / (us["compiled"] * 1e-6)),
        "hand_rows_identical_to_compiled": identical,
        "compile_s_cold": round(cold, 3), "compile_s_cached": round(cached, 4),
        "compile_s_this_process": round(extra["algorithm.compile_s"], 4),
        "mixed_random_slip_auto_s": round(mixed_auto, 4),
        "mixed_random_slip_off_s": round(mixed_off, 4),
        "mixed_auto_over_off": round(mixed_auto / mixed_off, 3),
        "fmu_chain_lag2": chain, "paper_every_block_c_fmu": every,
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
