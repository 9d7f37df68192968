"""Compiling a system of N FMUs: how long the compiled loop takes to be ready, cold (a fresh
cache folder, a fresh process), against N.

The system: N instances of the C test FMU `lag2` (tests/fmus/, built here) in a chain, a
constant into the first one's two inputs, each one's two outputs into the next one's inputs,
the last one's outputs recorded; 1,000 steps of 1 ms with `--compiled on`. Each N runs in a fresh
process with a fresh `TWMR_CACHE_DIR`, so numba compiles everything it needs (the driver, the
FMU kind's adapters; or, with `--generated`, the loop generated for the whole scenario, as every
FMU system ran before FMUs were kinds of the driver); with `--cold` numba's cache of twmr's own
code (the driver loop) is fresh too, as on the first run after installing. The time is the run's own
`algorithm.compile_s` (`summary.json`); the process's wall time beside it.

    python benchmarks/fmu_compile.py [--sizes 3,6,12,24,48,100] [--generated 3,6,12] [--cold]

Last line: one JSON object: `driver` and `generated`, each a list of {`fmus`, `compile_s`,
`process_s`, `rows_equal`} (`rows_equal`: the recorded rows equal those of the Python loop's
run of the same system), and `driver_growth`: the ratio of compile times at the largest and
smallest N over the ratio of the N (1: linear; 0: constant).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from tests.fmu_build import build_c_fmu  # noqa: E402

RUNNER = """
import json, sys
import numpy as np
from twmr.master import Execution
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load

path, generated = sys.argv[1], sys.argv[2] == "1"
rows = []
for mode in ("off", "on"):
    store = ResultStore()
    algorithm = make_algorithm("gauss_seidel", mode)
    if mode == "on" and generated:
        algorithm.use_driver = False
    outcome = Execution(load(path), [store], algorithm=algorithm).run()
    rows.append(store.data())
report = algorithm.report()
print(json.dumps({"compile_s": report["compile_s"], "driver": report.get("driver"),
                  "rows_equal": bool(np.array_equal(rows[0], rows[1]))}))
"""


#: --cold: numba's cache of the package's own code (the driver loop) fresh too
COLD = False


def scenario(fmu: Path, n: int) -> str:
    lines = ["components:", "  src: {kind: constant, parameters: {value: 1.0}}"]
    lines += [f"  f{i}: {{kind: fmu, parameters: {{path: {fmu}}}}}" for i in range(n)]
    lines += ["connections:", "  - src.y -> f0.u[1]", "  - src.y -> f0.u[2]"]
    for i in range(1, n):
        lines += [f"  - f{i - 1}.y -> f{i}.u"]
    lines += ["experiment: {start: 0.0, stop: 1.0, step: 0.001}",
              f"record: {{signals: [f{n - 1}.y], decimation: 10}}"]
    return "\n".join(lines) + "\n"


def measure(fmu: Path, n: int, generated: bool, tmp: Path) -> dict[str, object]:
    path = tmp / f"chain_{n}.yaml"
    path.write_text(scenario(fmu, n), encoding="utf-8")
    cache = tmp / f"cache_{n}_{int(generated)}"
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", RUNNER, str(path), str(int(generated))],
                          capture_output=True, text=True, timeout=3600,
                          env={**os.environ, "TWMR_CACHE_DIR": str(cache),
                               **({"NUMBA_CACHE_DIR": str(cache / "numba")} if COLD else {})})
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        return {"fmus": n, "error": done.stderr.strip().splitlines()[-1]}
    got = json.loads(done.stdout.strip().splitlines()[-1])
    return {"fmus": n, "compile_s": round(got["compile_s"], 3), "process_s": round(wall, 2),
            "driver": got["driver"], "rows_equal": got["rows_equal"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="3,6,12,24,48,100")
    ap.add_argument("--generated", default="3,6,12",
                    help="sizes also compiled as one loop generated for the scenario")
    ap.add_argument("--cold", action="store_true",
                    help="numba's cache of twmr's own code fresh too (a first run after install)")
    args = ap.parse_args()
    global COLD
    COLD = args.cold
    sizes = [int(s) for s in args.sizes.split(",") if s]
    old = [int(s) for s in args.generated.split(",") if s]
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        fmu = build_c_fmu("lag2", tmp)
        out: dict[str, object] = {"driver": [], "generated": []}
        for n in sizes:
            row = measure(fmu, n, False, tmp)
            print(f"driver, {n} FMUs: {row}", file=sys.stderr, flush=True)
            out["driver"].append(row)  # type: ignore[attr-defined]
        for n in old:
            row = measure(fmu, n, True, tmp)
            print(f"generated loop, {n} FMUs: {row}", file=sys.stderr, flush=True)
            out["generated"].append(row)  # type: ignore[attr-defined]
    rows = [r for r in out["driver"] if "compile_s" in r]  # type: ignore[attr-defined]
    if len(rows) >= 2:
        first, last = rows[0], rows[-1]
        out["driver_growth"] = round((last["compile_s"] / first["compile_s"]) /
                                     (last["fmus"] / first["fmus"]), 3)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
