"""Standalone C FMUs (`twmr export KIND`): the paper scenario all native against all C FMUs
through the master, and one exported plant FMU stepped by a hand-written fmpy loop. All figures
come from one run; master times are `Outcome.wall_time` (the stepping alone, rows kept in memory
by a `ResultStore`), the best of two runs; the hand loop is the loop alone, the best of two.

Last line: one JSON object with

* `export_s_per_fmu`: mean wall time of `export_c_fmu` (generate, compile, zip) over the five
  blocks of the paper scenario (FMI 2.0);
* `paper`: the 30 s trajectory-1 scenario at 1 ms (30,000 steps, 5 blocks), `native_s`,
  `c_fmu_s` (FMI 2.0) and `c_fmu3_s` (FMI 3.0), `ratio` (c_fmu_s / native_s), each also in µs
  per step (`*_us_per_step`), and `max_abs_diff`: the largest difference between the native and
  the all-C-FMU (FMI 2.0) recorded signals;
* `plant_hand_loop`: the exported plant (FMI 2.0, RK4 with one substep per 1 ms step), 100,000
  steps of setReal(torque, slip, disturbance: 10 values), doStep, getReal(pose, wheel speed: 5
  values) through fmpy's FMU2Slave: `steps`, `loop_s`, `us_per_step`; and `native_us_per_step`:
  the native plant component stepped the same way in Python (`do_step` after writing its inputs).
"""
from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.integration.c_fmu_scenario import export_blocks, paper, swapped
from twmr.components.plant import TwmrPlant
from twmr.fmi.cexport import export_c_fmu
from twmr.master import Execution
from twmr.observers.store import ResultStore
from twmr.scenario import loads


def master_run(data: dict[str, Any]) -> tuple[float, np.ndarray]:
    """Wall time [s] of the master stepping scenario `data`, and its recorded rows (rows x
    columns)."""
    store = ResultStore()
    outcome = Execution(loads(yaml.safe_dump(data), source="bench.yaml"), [store]).run()
    assert outcome.status == "completed", outcome
    return outcome.wall_time, np.array(store.data())


def plant_loop(fmu: Path, n: int, h: float) -> float:
    """The exported plant stepped by hand through fmpy: inputs, doStep, outputs per step."""
    md = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    inputs = [vr[f"torque[{i}]"] for i in (1, 2)] + [vr[f"slip_rate[{i}]"] for i in (1, 2, 3)] \
        + [vr[f"slip_accel[{i}]"] for i in (1, 2, 3)] + [vr[f"disturbance[{i}]"] for i in (1, 2)]
    outputs = [vr[f"pose[{i}]"] for i in (1, 2, 3)] + [vr[f"wheel_speed[{i}]"] for i in (1, 2)]
    s = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="plant")
    s.instantiate()
    s.setupExperiment(startTime=0.0)
    s.enterInitializationMode()
    s.exitInitializationMode()
    u = [1.0, 0.9, 0.1, 0.1, 0.05, 0.0, 0.0, 0.0, 0.2, -0.2]
    t0 = time.perf_counter()
    for k in range(n):
        s.setReal(inputs, u)
        s.doStep(k * h, h)
        s.getReal(outputs)
    wall = time.perf_counter() - t0
    s.terminate()
    s.freeInstance()
    return wall


def native_plant_loop(n: int, h: float) -> float:
    """The native plant component stepped the same way (inputs written, do_step, outputs read)."""
    p = TwmrPlant("plant")
    p.setup(0.0, None)
    p.initialize()
    t0 = time.perf_counter()
    for k in range(n):
        p.torque, p.slip_rate, p.slip_accel = (1.0, 0.9), (0.1, 0.1, 0.05), (0.0, 0.0, 0.0)
        p.disturbance = (0.2, -0.2)
        p.do_step(k * h, h)
        _ = p.pose, p.wheel_speed
    return time.perf_counter() - t0


def main() -> None:
    data = paper()
    steps = round(data["experiment"]["stop"] / data["experiment"]["step"])
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        fmus = export_blocks(data, Path(tmp) / "fmi2", 2)
        export_s = (time.perf_counter() - t0) / len(fmus)
        fmus3 = export_blocks(data, Path(tmp) / "fmi3", 3)
        native = [master_run(data) for _ in range(2)]
        assert native[0][1].shape[0] > 100
        c_fmu = [master_run(swapped(data, fmus)) for _ in range(2)]
        c_fmu3 = min(master_run(swapped(data, fmus3))[0] for _ in range(2))
        diff = float(np.max(np.abs(native[0][1] - c_fmu[0][1])))
        native_s, c_fmu_s = min(w for w, _ in native), min(w for w, _ in c_fmu)
        n, h = 100_000, 1e-3
        plant = export_c_fmu("twmr_plant", Path(tmp) / "plant.fmu")
        loop = min(plant_loop(plant, n, h) for _ in range(2))
        own = min(native_plant_loop(n, h) for _ in range(2))
    us = 1e6 / steps
    figures = {
        "export_s_per_fmu": round(export_s, 3),
        "paper": {"steps": steps, "blocks": len(fmus), "native_s": round(native_s, 3),
                  "c_fmu_s": round(c_fmu_s, 3), "c_fmu3_s": round(c_fmu3, 3),
                  "ratio": round(c_fmu_s / native_s, 2),
                  "native_us_per_step": round(native_s * us, 2),
                  "c_fmu_us_per_step": round(c_fmu_s * us, 2),
                  "c_fmu3_us_per_step": round(c_fmu3 * us, 2), "max_abs_diff": diff},
        "plant_hand_loop": {"steps": n, "loop_s": round(loop, 3),
                            "us_per_step": round(loop / n * 1e6, 2),
                            "native_us_per_step": round(own / n * 1e6, 2)}}
    print(f"paper scenario, {steps} steps: native {native_s:.3f} s, all C FMUs {c_fmu_s:.3f} s "
          f"(FMI 3.0 {c_fmu3:.3f} s), max |difference| {diff:.3g}")
    print(f"exported plant by hand through fmpy: {loop / n * 1e6:.2f} us per step")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
