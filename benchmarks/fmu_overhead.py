"""FMU overhead: a chain of three FMUs (the C test FMU `lag2`, built here), 100,000 steps,
stepped (a) by a hand-written loop of fmpy calls (setReal, doStep, getReal) and (b) by the master
from a scenario (rows kept in memory by a `ResultStore`; the time is `Outcome.wall_time`, which
includes instantiating the FMUs); also fmpy's own `simulate_fmu` of one FMU per step.
Last line: one JSON object."""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.fmu_build import build_c_fmu
from twmr.master import Execution
from twmr.observers.store import ResultStore
from twmr.scenario import loads

SCENARIO = """
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
experiment: {start: 0.0, stop: %(stop)r, step: 0.001}
record: {signals: [c.y], decimation: 100}
"""


def hand_loop(fmu: Path, n: int, h: float) -> float:
    md = read_model_description(str(fmu))
    slaves = []
    for name in "abc":
        s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        slaves.append(s)
    u, y = [2, 3], [4, 5]
    a, b, c = slaves
    t0 = time.perf_counter()
    ya = yb = [0.0, 0.0]
    for k in range(n):
        t = k * h
        a.setReal(u, [1.0, 1.0])
        b.setReal(u, ya)
        c.setReal(u, yb)
        a.doStep(t, h)
        b.doStep(t, h)
        c.doStep(t, h)
        ya, yb = a.getReal(y), b.getReal(y)
        c.getReal(y)
    wall = time.perf_counter() - t0
    for s in slaves:
        s.terminate()
        s.freeInstance()
    return wall


def main() -> None:
    n, h = 100_000, 1e-3
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_c_fmu("lag2", Path(tmp))
        hand = min(hand_loop(fmu, n, h) for _ in range(2))
        walls = []
        for _ in range(2):
            store = ResultStore()
            ex = Execution(loads(SCENARIO % {"fmu": fmu, "stop": n * h}, source="chain.yaml"),
                           [store])
            outcome = ex.run()
            assert outcome.status == "completed" and len(store.data()) == n // 100 + 1, outcome
            walls.append(outcome.wall_time)
        master = min(walls)
        t0 = time.perf_counter()
        simulate_fmu(str(fmu), stop_time=20.0, step_size=h, output_interval=h)
        sim_per_step = (time.perf_counter() - t0) / 20000
    figures = {"steps": n, "fmus": 3, "hand_loop_s": round(hand, 3), "master_s": round(master, 3),
               "ratio": round(master / hand, 3), "target_ratio": 1.2,
               "hand_us_per_fmu_step": round(hand / n / 3 * 1e6, 2),
               "master_us_per_fmu_step": round(master / n / 3 * 1e6, 2),
               "simulate_fmu_us_per_step": round(sim_per_step * 1e6, 2)}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
