"""FMU overhead: what the master costs over a hand-written loop of fmpy calls, for chains of the C
test FMUs (tests/fmus/, built here into a temporary folder). All figures come from one run; every
master time is `Outcome.wall_time` (the stepping alone: instantiating and initializing the FMUs are
not in it), the best of two runs, rows kept in memory by a `ResultStore`; every hand-loop time is
the loop alone, the best of two.

Last line: one JSON object with

* lag2 chain (three `lag2`, src -> a.u[1], a.u[2]; a.y -> b.u -> c.u; c.y recorded every 100
  steps), 100,000 steps of 1 ms: `steps`, `fmus` (3), `hand_loop_s` (setReal, doStep, getReal per
  FMU and step), `master_s`, `ratio` = master_s / hand_loop_s, `target_ratio` (1.2), and those per
  FMU and step: `hand_us_per_fmu_step`, `master_us_per_fmu_step`; `simulate_fmu_us_per_step`:
  fmpy's own `simulate_fmu` of one lag2, 20,000 steps (it includes its set-up).
* `mixed`, mixed-type chain (three `mixed2`: src -> a.r1, a.r1o -> b.r1, b.r1o -> c.r1, every other
  input open, c.r1o recorded every 100 steps; r1o = 2 r1 is direct feedthrough), 100,000 steps:
  `hand_loop_s` (per step, along the chain at t: setReal r1, getReal r1o of a, then b, then c;
  then doStep of all three: 3 FMI calls per FMU), `master_s`, `ratio` (master / hand),
  `target_ratio`, `hand_us_per_fmu_step`, `master_us_per_fmu_step`; `master_calls_per_fmu_step`:
  the FMI calls the master makes per FMU and step (fmpy's FMU2Slave set/get of every type and
  doStep counted: the calls of a 2,000-step run less those of a 1,000-step run, over 1,000 steps
  and 3 FMUs, so set-up and initialization drop out; a hand loop makes 3), `master_calls_by_kind`
  (the same per method), `hand_calls_per_fmu_step` (3).
* `chain`, per FMI version (`fmi2`, `fmi3`): a Van der Pol oscillator into two feedthrough FMUs
  (tests/fmus/: `vdp2` -> `ft2` -> `ft2`, `vdp3` -> `types3` -> `types3`; vdp.x0 ->
  ft1.Float64 input, ft1's Float64 output -> ft2's, every other input open; ft2's output recorded
  every 100 steps), 100,000 steps of 1 ms: `hand_loop_s` (fmpy's FMU2Slave/FMU3Slave, per step
  along the chain set and get of ft1 and of ft2, the three doSteps, get of vdp: 8 FMI calls),
  `python_s` (our master, `TWMR_COMPILED` off), `compiled_s` (on; `compile_s` its compilation or
  cache load, not in `compiled_s`), `ecos_s` (Ecos through ecospy, its API: three models, two
  real connections, `step(n)`), `libcosim_s` (libcosim through libcosimpy, `step(n)`), each the
  stepping alone, best of two (hand loop and Python path: best of three, run alternately);
  `first_run_s`: a first run in a fresh process with `--compiled on` (numba's cache warm from
  the runs before; the default `auto` keeps FMUs in the Python loop): its stepping wall time
  plus the compiling or loading of the compiled kinds (`algorithm.compile_s`)
  (`first_run_compiled`: whether it ran compiled), `first_run_ratio` = first_run_s /
  hand_loop_s (target 0.5);
  `python_ratio` = python_s / hand_loop_s (`target_ratio` 1.2),
  `compiled_ratio`, `ecos_ratio`, `libcosim_ratio` (over the hand loop) and `compiled_vs_ecos`
  = compiled_s / ecos_s. A peer that does not install or cannot run the chain has its error
  under `<peer>_error` instead.
* `isolation`, one `lag2` fed by a constant source, 20,000 steps, with and without
  `isolate: true` (the FMU in a worker process, `twmr.fmi.isolated`): `steps`,
  `in_process_us_per_step`, `isolated_us_per_step` (master wall time per step, the whole system),
  `overhead_us_per_step` = isolated - in process (the cost per step of one isolated FMU), `ratio`
  (isolated / in process); if the isolated run fails, `error` holds its message instead.
"""
from __future__ import annotations

import functools
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.fmu_build import build_c_fmu
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
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

MIXED_SCENARIO = """
components:
  src: {kind: constant, parameters: {value: 1.0}}
  a: {kind: fmu, parameters: {path: %(fmu)s}}
  b: {kind: fmu, parameters: {path: %(fmu)s}}
  c: {kind: fmu, parameters: {path: %(fmu)s}}
connections:
  - src.y -> a.r1
  - a.r1o -> b.r1
  - b.r1o -> c.r1
open: [a.r2, a.i1, a.i2, a.b1, a.s1, b.r2, b.i1, b.i2, b.b1, b.s1, c.r2, c.i1, c.i2, c.b1, c.s1]
experiment: {start: 0.0, stop: %(stop)r, step: 0.001}
record: {signals: [c.r1o], decimation: 100}
"""

SINGLE_SCENARIO = """
components:
  src: {kind: constant, parameters: {value: 1.0}}
  a: {kind: fmu, parameters: {path: %(fmu)s%(extra)s}}
connections:
  - src.y -> a.u[1]
  - src.y -> a.u[2]
experiment: {start: 0.0, stop: %(stop)r, step: 0.001}
record: {signals: [a.y], decimation: 100}
"""

CHAIN_SCENARIO = """
components:
  vdp: {kind: fmu, parameters: {path: %(vdp)s}}
  ft1: {kind: fmu, parameters: {path: %(ft)s}}
  ft2: {kind: fmu, parameters: {path: %(ft)s}}
connections:
  - vdp.x0 -> ft1.%(port)s_input
  - ft1.%(port)s_output -> ft2.%(port)s_input
open: [%(open)s]
experiment: {start: 0.0, stop: %(stop)r, step: 0.001}
record: {signals: [ft2.%(port)s_output], decimation: 100}
"""
#: per FMI version: the source FMU, the feedthrough FMU, the Float64 port stem, the FMI 3.0 flag
CHAINS = {"fmi2": ("vdp2", "ft2", "Float64_continuous", False),
          "fmi3": ("vdp3", "types3", "Float64", True)}

#: the fmpy FMU2Slave methods counted as FMI calls of a co-simulation step
COUNTED = ("setReal", "getReal", "setInteger", "getInteger", "setBoolean", "getBoolean",
           "setString", "getString", "doStep")


def slaves(fmu: Path, names: str = "abc") -> list[FMU2Slave]:
    """Instantiated and initialized fmpy slaves of `fmu`, one per name."""
    md = read_model_description(str(fmu))
    unzipped = extract(str(fmu))
    out = []
    for name in names:
        s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        out.append(s)
    return out


def free(instances: list[FMU2Slave]) -> None:
    for s in instances:
        s.terminate()
        s.freeInstance()


def hand_loop(fmu: Path, n: int, h: float) -> float:
    """The lag2 chain: inputs from the previous step's outputs, then doStep, then getReal."""
    instances = slaves(fmu)
    u, y = [2, 3], [4, 5]
    a, b, c = instances
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
    free(instances)
    return wall


def hand_loop_mixed(fmu: Path, n: int, h: float) -> float:
    """The mixed2 chain, direct feedthrough: along the chain at t set r1 and get r1o, then step
    all three."""
    instances = slaves(fmu)
    r1, r1o = [0], [6]
    a, b, c = instances
    one = [1.0]
    t0 = time.perf_counter()
    for k in range(n):
        t = k * h
        a.setReal(r1, one)
        ya = a.getReal(r1o)
        b.setReal(r1, ya)
        yb = b.getReal(r1o)
        c.setReal(r1, yb)
        c.getReal(r1o)
        a.doStep(t, h)
        b.doStep(t, h)
        c.doStep(t, h)
    wall = time.perf_counter() - t0
    expected = [8.0]
    got = c.getReal(r1o)
    free(instances)
    assert got == expected, got
    return wall


def master_run(text: str, n: int, compiled: str = "auto") -> float:
    """Wall time [s] of the master stepping the scenario `text` (n steps, rows every 100)."""
    return master_outcome(text, n, compiled).wall_time


def master_outcome(text: str, n: int, compiled: str = "auto") -> Any:
    """The master's `Outcome` of the scenario `text` (n steps, rows every 100), the loop
    compiled as `compiled` says (auto | on | off)."""
    store = ResultStore()
    outcome = Execution(loads(text, source="bench.yaml"), [store],
                        algorithm=make_algorithm("gauss_seidel", compiled)).run()
    assert outcome.status == "completed" and len(store.data()) == n // 100 + 1, outcome
    return outcome


def chain_slaves(fmus: dict[str, Path], fmi3: bool) -> list[Any]:
    """Instantiated and initialized fmpy slaves vdp, ft1, ft2 of the chain."""
    from fmpy.fmi3 import FMU3Slave

    out = []
    for name, fmu in fmus.items():
        md = read_model_description(str(fmu))
        args = dict(guid=md.guid, unzipDirectory=extract(str(fmu)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name)
        s = FMU3Slave(**args) if fmi3 else FMU2Slave(**args)
        s.instantiate()
        if not fmi3:
            s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        out.append(s)
    return out


def hand_loop_chain(fmus: dict[str, Path], fmi3: bool, n: int, h: float) -> tuple[float, float]:
    """(wall time [s], ft2's output at the end) of the chain stepped with fmpy's calls: along
    the chain at t set ft1's input from vdp's output and get its output, then ft2's; the three
    doSteps; get vdp's output."""
    vdp, ft1, ft2 = chain_slaves(fmus, fmi3)
    md = {p.name: p.valueReference for p in
          read_model_description(str(fmus["ft1"])).modelVariables}
    port = CHAINS["fmi3" if fmi3 else "fmi2"][2]
    u, y = [md[f"{port}_input"]], [md[f"{port}_output"]]
    x0 = [1 if fmi3 else 0]
    get = "getFloat64" if fmi3 else "getReal"
    put = "setFloat64" if fmi3 else "setReal"
    vget, aget, aset, bget, bset = (getattr(vdp, get), getattr(ft1, get), getattr(ft1, put),
                                    getattr(ft2, get), getattr(ft2, put))
    x = vget(x0)
    out = [0.0]
    t0 = time.perf_counter()
    for k in range(n):
        t = k * h
        aset(u, x)
        ya = aget(y)
        bset(u, ya)
        out = bget(y)
        vdp.doStep(t, h)
        ft1.doStep(t, h)
        ft2.doStep(t, h)
        x = vget(x0)
    wall = time.perf_counter() - t0
    free([vdp, ft1, ft2])
    return wall, out[0]


def ecos_chain(fmus: dict[str, Path], port: str, n: int, h: float) -> float:
    """Wall time [s] of Ecos (ecospy) stepping the chain n steps."""
    from ecospy import EcosSimulation, EcosSimulationStructure

    structure = EcosSimulationStructure()
    for name, fmu in fmus.items():
        structure.add_model(name, str(fmu))
    structure.make_real_connection("vdp::x0", f"ft1::{port}_input")
    structure.make_real_connection(f"ft1::{port}_output", f"ft2::{port}_input")
    sim = EcosSimulation(step_size=h, structure=structure)
    try:
        sim.init()
        t0 = time.perf_counter()
        sim.step(n)
        wall = time.perf_counter() - t0
        sim.terminate()
    finally:
        sim.free()
    return wall


def libcosim_chain(fmus: dict[str, Path], port: str, n: int, h: float) -> float:
    """Wall time [s] of libcosim (libcosimpy) stepping the chain n steps."""
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimSlave import CosimLocalSlave

    log_output_level(CosimLogLevel.ERROR)
    ex = CosimExecution.from_step_size(step_size=round(h * 1e9))
    index, slaves = {}, []
    for name, fmu in fmus.items():
        slaves.append(CosimLocalSlave(fmu_path=str(fmu), instance_name=name))
        if not slaves[-1].ptr():
            raise RuntimeError(f"libcosim cannot load {fmu.name}")
        index[name] = ex.add_local_slave(slaves[-1])
        if index[name] < 0:
            raise RuntimeError(f"libcosim cannot load {fmu.name}")
    refs = {(name, v.name.decode()): v.reference
            for name, i in index.items() for v in ex.slave_variables(i)}
    for (a, pa), (b, pb) in ((("vdp", "x0"), ("ft1", f"{port}_input")),
                             (("ft1", f"{port}_output"), ("ft2", f"{port}_input"))):
        if ex.connect_real_variables(index[a], refs[a, pa], index[b], refs[b, pb]) < 0:
            raise RuntimeError(f"libcosim cannot connect {a}.{pa} to {b}.{pb}")
    t0 = time.perf_counter()
    if not ex.step(n):
        raise RuntimeError("libcosim's step failed")
    wall = time.perf_counter() - t0
    del ex
    return wall


def chain(tmp: Path, version: str, n: int, h: float) -> dict[str, Any]:
    """The chain of one FMI version: every column of the module docstring's `chain`."""
    vdp, ft, port, fmi3 = CHAINS[version]
    fmus = {"vdp": build_c_fmu(vdp, tmp, fmi3=fmi3)}
    fmus["ft1"] = fmus["ft2"] = build_c_fmu(ft, tmp, fmi3=fmi3)
    md = read_model_description(str(fmus["ft1"]))
    opened = [f"{c}.{v.name}" for c in ("ft1", "ft2") for v in md.modelVariables
              if v.causality == "input" and v.name != f"{port}_input"]
    text = CHAIN_SCENARIO % {"vdp": fmus["vdp"], "ft": fmus["ft1"], "port": port,
                             "open": ", ".join(opened), "stop": n * h}
    hands, pythons = [], []
    for _ in range(3):  # interleaved: a change of the machine's load hits both alike
        hands.append(hand_loop_chain(fmus, fmi3, n, h)[0])
        pythons.append(master_run(text, n, "off"))
    hand, python = min(hands), min(pythons)
    runs = [master_outcome(text, n, "on") for _ in range(2)]
    compiled = min(r.wall_time for r in runs)
    out: dict[str, Any] = {"steps": n, "fmus": 3, "hand_loop_s": round(hand, 4),
                           "python_s": round(python, 4), "compiled_s": round(compiled, 4),
                           "compile_s": round(runs[0].extra["algorithm.compile_s"], 3),
                           "python_ratio": round(python / hand, 3), "target_ratio": 1.2,
                           "compiled_ratio": round(compiled / hand, 4)}
    for peer, run in (("ecos", ecos_chain), ("libcosim", libcosim_chain)):
        try:
            wall = min(run(fmus, port, n, h) for _ in range(2))
        except Exception as exc:  # noqa: BLE001 - reported: a peer may not install or run it
            out[f"{peer}_error"] = f"{type(exc).__name__}: {exc}"
            continue
        out[f"{peer}_s"] = round(wall, 4)
        out[f"{peer}_ratio"] = round(wall / hand, 4)
    if "ecos_s" in out:
        out["compiled_vs_ecos"] = round(compiled / out["ecos_s"], 3)
    first = first_run(tmp, text, version)
    out.update(first_run_s=round(first[0], 4), first_run_compiled=first[1],
               first_run_ratio=round(first[0] / hand, 4))
    return out


FIRST_RUN = """
import json, sys
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load
outcome = Execution(load(sys.argv[1]), [ResultStore()],
                    algorithm=make_algorithm("gauss_seidel", "on")).run()
extra = outcome.extra
load = extra.get("algorithm.compile_s", 0.0) if not extra.get("algorithm.compiled_at_step") else 0.0
print(json.dumps([outcome.wall_time + load, bool(extra.get("algorithm.compiled"))]))
"""


def first_run(tmp: Path, text: str, version: str) -> tuple[float, bool]:
    """(stepping and compile wall time, compiled) of a run of `text` in a fresh process,
    compiled on."""
    import subprocess

    path = tmp / f"chain_{version}.yaml"
    path.write_text(text, encoding="utf-8")
    done = subprocess.run([sys.executable, "-c", FIRST_RUN, str(path)], capture_output=True,
                          text=True, timeout=600, check=True)
    wall, compiled = json.loads(done.stdout.strip().splitlines()[-1])
    return float(wall), bool(compiled)


def count_calls(text_of: Any, n1: int = 1000, n2: int = 2000) -> dict[str, float]:
    """FMI calls per FMU and step the master makes (the direct accessors and doStep of
    `twmr.fmi.direct` that `twmr.fmi.fmu` makes, wrapped with counters by their fmpy names):
    those of an n2-step run less those of an n1-step run, over (n2 - n1) steps and 3 FMUs."""
    from twmr.fmi import fmu as fmu_module

    counts = dict.fromkeys(COUNTED, 0)
    made = {"accessor": fmu_module.accessor, "stepper": fmu_module.stepper}

    def counting(name: str, fn: Any) -> Any:
        @functools.wraps(fn)  # keeps __name__: the master looks at setter.__name__
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            counts[name] += 1
            return fn(*args, **kwargs)
        return wrapper

    def accessor(*args: Any) -> Any:
        fn = made["accessor"](*args)
        return counting(fn.__name__, fn)

    def stepper(*args: Any) -> Any:
        return counting("doStep", made["stepper"](*args))

    runs = []
    try:
        fmu_module.accessor, fmu_module.stepper = accessor, stepper  # type: ignore[assignment]
        for n in (n1, n2):
            for m in COUNTED:
                counts[m] = 0
            master_run(text_of(n), n, "off")
            runs.append(dict(counts))
    finally:
        fmu_module.accessor, fmu_module.stepper = made["accessor"], made["stepper"]  # type: ignore[assignment]
    per = {m: (runs[1][m] - runs[0][m]) / (n2 - n1) / 3 for m in COUNTED}
    return {m: round(v, 3) for m, v in per.items() if v}


def isolation(fmu: Path, n: int, h: float) -> dict[str, Any]:
    """One lag2 stepped by the master, in process and isolated (worker process)."""
    def text(extra: str) -> str:
        return SINGLE_SCENARIO % {"fmu": fmu, "stop": n * h, "extra": extra}

    plain = min(master_run(text(""), n) for _ in range(2))
    out: dict[str, Any] = {"steps": n, "in_process_us_per_step": round(plain / n * 1e6, 2)}
    try:
        iso = min(master_run(text(", isolate: true"), n) for _ in range(2))
    except Exception as exc:  # noqa: BLE001 - reported, not raised: isolation may be unfinished
        out["error"] = f"{type(exc).__name__}: {exc}"
        return out
    out.update(isolated_us_per_step=round(iso / n * 1e6, 2),
               overhead_us_per_step=round((iso - plain) / n * 1e6, 2),
               ratio=round(iso / plain, 3))
    return out


def main() -> None:
    n, h = 100_000, 1e-3
    if "--chain" in sys.argv:  # the chain alone
        with tempfile.TemporaryDirectory() as tmp:
            print(json.dumps({"chain": {v: chain(Path(tmp), v, n, h) for v in CHAINS}}))
        return
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build_c_fmu("lag2", Path(tmp))
        mixed = build_c_fmu("mixed2", Path(tmp))
        hand = min(hand_loop(fmu, n, h) for _ in range(2))
        master = min(master_run(SCENARIO % {"fmu": fmu, "stop": n * h}, n) for _ in range(2))
        t0 = time.perf_counter()
        simulate_fmu(str(fmu), stop_time=20.0, step_size=h, output_interval=h)
        sim_per_step = (time.perf_counter() - t0) / 20000

        def mixed_text(steps: int) -> str:
            return MIXED_SCENARIO % {"fmu": mixed, "stop": steps * h}

        hand_m = min(hand_loop_mixed(mixed, n, h) for _ in range(2))
        master_m = min(master_run(mixed_text(n), n) for _ in range(2))
        calls = count_calls(mixed_text)
        iso = isolation(fmu, 20_000, h)
        chains = {v: chain(Path(tmp), v, n, h) for v in CHAINS}
    figures = {"steps": n, "fmus": 3, "hand_loop_s": round(hand, 3), "master_s": round(master, 3),
               "ratio": round(master / hand, 3), "target_ratio": 1.2,
               "hand_us_per_fmu_step": round(hand / n / 3 * 1e6, 2),
               "master_us_per_fmu_step": round(master / n / 3 * 1e6, 2),
               "simulate_fmu_us_per_step": round(sim_per_step * 1e6, 2),
               "mixed": {"steps": n, "fmus": 3, "hand_loop_s": round(hand_m, 3),
                         "master_s": round(master_m, 3), "ratio": round(master_m / hand_m, 3),
                         "target_ratio": 1.2,
                         "hand_us_per_fmu_step": round(hand_m / n / 3 * 1e6, 2),
                         "master_us_per_fmu_step": round(master_m / n / 3 * 1e6, 2),
                         "master_calls_per_fmu_step": round(sum(calls.values()), 3),
                         "master_calls_by_kind": calls, "hand_calls_per_fmu_step": 3},
               "isolation": iso, "chain": chains}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
