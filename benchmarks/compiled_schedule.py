"""The compiled fixed-step algorithm against a hand-written numba loop and the Python schedule,
and the driver (`twmr.master.driver`: each kind of block compiled once, one loop for every
scenario; "driver") against the loop generated and compiled for each scenario ("loop", the
compiled path before the driver; `CompiledStep(..., use_driver=False)`), measured in this one
run.

The paper's trajectory-1 scenario (ASMC, 1 ms step, 21 columns recorded every 10 steps) cut to
3 s, 30 s (as written) and 300 s:

(a) the master with the compiled algorithm (`compiled='on'`), driver and loop: `Execution` with a
    `ResultStore`, the stepping wall time it reports (`Outcome.wall_time`: chunks of compiled
    steps, the NaN/Inf check at every step, the rows handed to the store); compilation happens
    before it;
(b) a hand-written numba loop over the same kernels (`hand_loop` below: the six blocks' kernel
    functions called in the Gauss-Seidel order, the controller stepped by its `advance`, the rows
    written to a preallocated array every 10 steps, no NaN/Inf check), one call for the whole
    run; its rows must equal (a)'s exactly;
(c) the master with the Python schedule (`compiled='off'`, 3 s and 30 s), against (d) the same
    hand-written loop in plain Python (`hand_loop.py_func`, every kernel function its `py_func`;
    `python_over_python_hand`). In this process numba is loaded, so the Python schedule's forms
    of the kernels call the kernel functions inside them compiled (`KernelFunction.python`),
    which the plain hand loop does not: (c) is then below (d). In a process without numba, a
    short run's schedule runs the same `py_func`s as (d).
Each is run `--repeats` times interleaved (300 s: 3 times); medians are compared.

Compile time (`algorithm.compile_s`: kernels collected, the loop or driver found, generated,
compiled or loaded from numba's cache):
- cold: a fresh process with empty numba and schedule caches, then a second fresh process with
  those caches (cached), for the driver and for the loop;
- own_loop_load_s: a built system that ran once by the driver takes its own loop, in a fresh
  process with those caches: what `twmr.master.compiled.OWN_LOOP_LOAD_S` stands for;
  own_loop_compile_s: the same after the driver's runs alone, whose caches hold the kernels but
  not the loop, which is compiled: what `OWN_LOOP_COMPILE_S` stands for;
- rewired, warm kinds: the paper scenario with a unit gain and offset on the reference and the
  wheel speeds wired element by element (tests/integration/test_compiled.py `rewired`), after the
  plain scenario has run: in the same process, and in a fresh process whose caches the plain
  scenario filled (target <= 0.3 s). The loop compiles the rewired scenario anew (a new source);
- a chain of N gain blocks fed by a sine (N = 10, 100, 1000, 10,000 steps): the driver's
  compile_s (at N = 10 it compiles the kinds sine and gain), and the stepping per block and step
  against the Python schedule (the loop is not run here: 35 s to compile at N = 100, a failure
  at N = 1000).
- new kinds: the sensors scenario (the paper's kinds and `encoder`, `imu`) after the paper
  scenario, in the same process (this process keeps its adapters in an empty cache folder; the
  kernel functions' own numba cache stays as it is).

FMUs (`compiled='on'` only; these keep the generated loop): (d) the chain of three `lag2` test
FMUs of benchmarks/fmu_overhead.py (100,000 steps, c.y recorded every 100) and (e) the paper
scenario with every block its standalone C FMU (`twmr export`, 30,000 steps), each through the
compiled loop (the FMUs called through their C function pointers) and through the Python loop
(fmpy), per FMU and step; both loops' rows must be equal.

Mixed (f): the paper scenario with the slip block's `random` profile (no kernel: Python only),
`compiled='auto'` (the default: kernels collected, then the Python loop) against `'off'`,
median of three each; target: no slower.

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

from twmr.components.asmc import asmc_advance, asmc_evaluate
from twmr.components.motor import motor_evaluate, motor_step
from twmr.components.plant import plant_step
from twmr.components.slip import slip_evaluate
from twmr.components.trajectory import trajectory_step
from twmr.master import Execution
from twmr.master.algorithm import Algorithm, make_algorithm
from twmr.master.compiled import CompiledStep
from twmr.observers.store import ResultStore
from twmr.scenario import load, loads
from twmr.scenario.system import System

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.fmu_build import build_c_fmu
from tests.integration.c_fmu_scenario import export_blocks, paper, swapped
from tests.integration.test_compiled import rewired
from tests.integration.test_compiled_driver import chain

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
    motor, slip evaluated, then every block stepped, the controller by its `advance`: its
    torque is evaluated again at the next point); rows into `buf`; returns rows written."""
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
            buf[k, 16], buf[k, 17], buf[k, 18] = slip[0]  # plant.slip_rate
            buf[k, 19], buf[k, 20] = slip[2]  # plant.disturbance
            k += 1
        if n == n_steps:  # the final point: no step
            break
        _, (pos, vel, acc) = trajectory_step(t, h, (), (pos, vel, acc), (), pt)
        xc, ctrl = asmc_advance(t, h, xc, ctrl, (pose, ws, pos, vel, acc), pc)
        xm, motor = motor_step(t, h, xm, motor, (ctrl[0], ws), pm)
        _, (pose, ws, com) = plant_step(t, h, (), (pose, ws, com),
                                        (motor[0], slip[0], slip[1], slip[2], slip[3]), pp)
    return k


def hand_run(stop: float = 30.0, python: bool = False) -> tuple[np.ndarray, float]:
    """(rows, wall time [s]) of `hand_loop` over the scenario's initialized components, cut to
    `stop` [s]; `python`: its plain-Python form (the kernels' Python forms, as the Python
    schedule calls them)."""
    system = load(SCENARIO, [f"experiment.stop={stop}"])
    exp = system.experiment
    comps = system.components
    for name in system.order:
        comps[name].setup(exp.start, exp.stop)
        comps[name].initialize()
    kern = {n: comps[n].kernel(exp.step) for n in system.order}
    ref, ctrl, motor, plant, slip = (comps[n] for n in ("ref", "ctrl", "motor", "plant", "slip"))

    def outputs(c):
        return tuple(tuple(float(v) for v in c.__dict__[p]) for p in c.outputs)

    buf = np.empty((exp.n_steps // 10 + 1, 21))
    args = (exp.n_steps, exp.step, 10, kern["ref"].params, kern["ctrl"].params,
            kern["motor"].params, kern["plant"].params, kern["slip"].params, outputs(ref),
            outputs(ctrl), kern["ctrl"].state, outputs(motor), kern["motor"].state,
            outputs(plant), outputs(slip), buf)
    loop = hand_loop.py_func if python else hand_loop
    t0 = time.perf_counter()
    k = loop(*args)
    wall = time.perf_counter() - t0
    return buf[:k], wall


def algorithm(mode: str, how: str) -> Algorithm:
    """Gauss-Seidel: 'off' the Python schedule; else compiled by the driver (`how` 'driver') or
    the loop generated for the scenario ('loop')."""
    return make_algorithm("gauss_seidel", mode) if mode == "off" else \
        CompiledStep("gauss_seidel", mode, use_driver=how == "driver")


def master_run(mode: str, overrides: tuple[str, ...] = (), how: str = "driver",
               system: System | None = None) -> tuple[np.ndarray, float, dict]:
    """(rows, stepping wall time [s], outcome extra) of the scenario through `Execution`."""
    system = system if system is not None else load(SCENARIO, list(overrides))
    store = ResultStore()
    outcome = Execution(system, [store], algorithm=algorithm(mode, how)).run()
    return store.data(), outcome.wall_time, outcome.extra


COMPILE = """
import json, sys
sys.path.insert(0, sys.argv[3])
from tests.integration.test_compiled import rewired
from twmr.master import Execution
from twmr.master.compiled import CompiledStep
from twmr.observers.store import ResultStore
from twmr.scenario import load
system = rewired("gauss_seidel") if sys.argv[2] == "rewired" else load(sys.argv[1])
out = Execution(system, [ResultStore()],
                algorithm=CompiledStep("gauss_seidel", "on", use_driver=sys.argv[4] == "driver")
                ).run()
print(json.dumps(out.extra["algorithm.compile_s"]))
"""


OWN_LOOP = """
import json, sys
import twmr
built = twmr.build(sys.argv[1])
built.run()  # the driver: numba, the kinds' adapters and kernels loaded
built.system.own_loop_budget_s = 1e9
print(json.dumps(built.run({"ctrl.k": 20.0}).summary["pacing"]["algorithm.compile_s"]))
"""


def compile_times(how: str) -> dict[str, float]:
    """compile_s [s] in fresh processes: with empty caches (cold), then with those caches
    (cached), then of the rewired scenario with them (rewired_fresh_process)."""
    root = str(Path(__file__).resolve().parent.parent)
    with tempfile.TemporaryDirectory(prefix="twmr-compile-") as tmp:
        env = dict(os.environ, NUMBA_CACHE_DIR=str(Path(tmp) / "numba"),
                   TWMR_CACHE_DIR=str(Path(tmp) / "schedules"))
        times = []
        for which in ("plain", "plain", "rewired"):
            out = subprocess.run([sys.executable, "-c", COMPILE, str(SCENARIO), which, root, how],
                                 env=env, capture_output=True, text=True, check=True)
            times.append(float(out.stdout.strip().splitlines()[-1]))
        # a built system taking its loop after a run by the driver: the loop is in the cache
        # (how 'loop': loaded), or only the kernels are (how 'driver': compiled)
        out = subprocess.run([sys.executable, "-c", OWN_LOOP, str(SCENARIO)], env=env,
                             capture_output=True, text=True, check=True)
        times.append(float(out.stdout.strip().splitlines()[-1]))
    own = "own_loop_load" if how == "loop" else "own_loop_compile"
    return {"cold": times[0], "cached": times[1], "rewired_fresh_process": times[2],
            own: times[3]}


def rewired_in_process(how: str) -> float:
    """compile_s [s] of the rewired scenario after the plain one ran in this process."""
    master_run("on", ("experiment.stop=0.1",), how)
    system = rewired("gauss_seidel")
    return master_run("on", how=how, system=system)[2]["algorithm.compile_s"]


def chain_case(n: int) -> dict[str, float]:
    """The driver on a chain of `n` gains (benchmarks' `chain` text of the driver tests)."""
    text = chain(n, stop=10.0)
    python = master_run("off", system=loads(text, source="chain.yaml"))
    compiled = master_run("on", system=loads(text, source="chain.yaml"))
    assert np.array_equal(python[0], compiled[0]), "chain: driver != Python schedule"
    steps = 10_000
    return {"blocks": n, "compile_s": round(compiled[2]["algorithm.compile_s"], 4),
            "driver_us_per_block_step": round(compiled[1] / steps / n * 1e6, 4),
            "python_us_per_block_step": round(python[1] / steps / n * 1e6, 4)}


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


def per_step(stop: float, repeats: int, python: bool) -> dict[str, float]:
    """Median stepping time per step [us] of the driver, the loop, the hand loop (and the Python
    schedule) on the scenario cut to `stop` [s]; every compiled form's rows equal."""
    over = (f"experiment.stop={stop}",)
    hand_rows, _ = hand_run(stop)
    rows = {how: master_run("on", over, how)[0] for how in ("driver", "loop")}
    assert np.array_equal(rows["driver"], rows["loop"]), "driver != loop"
    identical = bool(np.array_equal(hand_rows, rows["driver"]))
    walls: dict[str, list[float]] = {"driver": [], "loop": [], "hand": [], "python": [],
                                     "python_hand": []}
    for i in range(repeats):
        walls["hand"].append(hand_run(stop)[1])
        for how in ("driver", "loop"):
            walls[how].append(master_run("on", over, how)[1])
        if python and i < 3:
            walls["python"].append(master_run("off", over)[1])
            walls["python_hand"].append(hand_run(stop, python=True)[1])
    steps = load(SCENARIO, list(over)).experiment.n_steps
    us = {k: statistics.median(v) / steps * 1e6 for k, v in walls.items() if v}
    out = {"steps": steps, **{f"{k}_us_per_step": round(v, 4) for k, v in us.items()},
           "driver_over_hand": round(us["driver"] / us["hand"], 2),
           "loop_over_hand": round(us["loop"] / us["hand"], 2),
           "driver_over_loop": round(us["driver"] / us["loop"], 2),
           "hand_rows_identical": identical}
    if python:
        out["python_over_driver"] = round(us["python"] / us["driver"], 1)
        out["python_over_python_hand"] = round(us["python"] / us["python_hand"], 2)
    print(f"{stop} s: {out}", flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    # this process's adapters and loops in an empty folder: the new kinds below compile
    os.environ["TWMR_CACHE_DIR"] = tempfile.mkdtemp(prefix="twmr-bench-cache-")
    compile_s = {how: compile_times(how) for how in ("driver", "loop")}
    print(f"compile in fresh processes: {compile_s}", flush=True)
    python_rows, _, _ = master_run("off")
    assert np.array_equal(python_rows, master_run("on")[0]), "compiled != Python schedule"
    rewired_s = {how: rewired_in_process(how) for how in ("driver", "loop")}
    print(f"rewired, same process: {rewired_s}", flush=True)
    sensors = load(SCENARIO.with_name("paper_trajectory1_asmc_sensors.yaml"),
                   ["experiment.stop=0.1"])
    new_kinds_s = master_run("on", system=sensors)[2]["algorithm.compile_s"]
    print(f"two new kinds: {new_kinds_s:.3f} s", flush=True)
    steps = {"3s": per_step(3.0, args.repeats, True), "30s": per_step(30.0, args.repeats, True),
             "300s": per_step(300.0, 3, False)}
    chains = [chain_case(n) for n in (10, 100, 1000)]
    print(f"gain chains: {chains}", flush=True)
    with tempfile.TemporaryDirectory(prefix="twmr-bench-fmus-") as tmp:
        fmu_chain = fmu_case(CHAIN % {"fmu": build_c_fmu("lag2", Path(tmp))}, 3)
        print(f"lag2 chain: {fmu_chain}", flush=True)
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
    figures = {
        "scenario": SCENARIO.name,
        "per_step": steps,
        "compile_s_cold": {h: round(c["cold"], 3) for h, c in compile_s.items()},
        "compile_s_cached": {h: round(c["cached"], 4) for h, c in compile_s.items()},
        "own_loop_load_s": round(compile_s["loop"]["own_loop_load"], 4),
        "own_loop_compile_s": round(compile_s["driver"]["own_loop_compile"], 3),
        "compile_s_rewired_warm_kinds_fresh_process":
            {h: round(c["rewired_fresh_process"], 4) for h, c in compile_s.items()},
        "compile_s_rewired_warm_kinds_same_process":
            {h: round(v, 4) for h, v in rewired_s.items()},
        "target_compile_s_rewired": 0.3,
        "compile_s_two_new_kinds_driver": round(new_kinds_s, 4),
        "gain_chains": chains,
        "mixed_random_slip_auto_s": round(mixed_auto, 4),
        "mixed_random_slip_off_s": round(mixed_off, 4),
        "mixed_auto_over_off": round(mixed_auto / mixed_off, 3),
        "fmu_chain_lag2": fmu_chain, "paper_every_block_c_fmu": every,
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
