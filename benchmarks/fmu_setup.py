"""Setting up many FMUs: a chain of N instances of one FMU file (the Modelica Association's
Reference Feedthrough, FMI 2.0) loaded, built and stepped once by twmr, against a hand-written
fmpy set-up of the same instances (one model description read, one extraction, N instances
instantiated and initialised) measured in the same run, interleaved; medians of the rounds with
their spread (min, max).

    python benchmarks/fmu_setup.py [--rounds 5] [--sizes 10,100]

The FMU comes from the conformance folder (`TWMR_CONFORMANCE`, default ../shared/conformance).
Last line: one JSON object.
"""
from __future__ import annotations

import argparse
import itertools
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FMU = Path(os.environ.get("TWMR_CONFORMANCE") or ROOT.parent / "shared" / "conformance") / \
    "reference-fmus" / "Feedthrough_fmi2.fmu"


def scenario(n: int, folder: Path) -> Path:
    names = [f"f{i}" for i in range(n)]
    wires = ", ".join(f"{a}.Float64_continuous_output -> {b}.Float64_continuous_input"
                      for a, b in itertools.pairwise(names))
    comps = "\n".join(f"  {x}: {{kind: fmu, parameters: {{path: '{FMU}'}}}}" for x in names)
    path = folder / f"chain{n}.yaml"
    path.write_text(f"components:\n{comps}\nconnections: [{wires}]\nopen: ['f*']\n"
                    f"experiment: {{stop: 0.001, step: 0.001}}\n"
                    f"record: {{signals: [{names[-1]}.Float64_continuous_output]}}\n")
    return path


def hand(n: int) -> float:
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    t0 = time.perf_counter()
    md = read_model_description(str(FMU))
    folder = extract(str(FMU), tempfile.mkdtemp())
    slaves = [FMU2Slave(guid=md.guid, unzipDirectory=folder, instanceName=f"f{i}",
                        modelIdentifier=md.coSimulation.modelIdentifier) for i in range(n)]
    for s in slaves:
        s.instantiate()
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
    elapsed = time.perf_counter() - t0
    for s in slaves:
        s.terminate()
        s.freeInstance()
    return elapsed


def ours(path: Path) -> float:
    import twmr

    t0 = time.perf_counter()
    twmr.simulate(twmr.load(path), compiled="off")
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--sizes", default="10,100")
    args = ap.parse_args()
    if not FMU.exists():
        print(json.dumps({"skipped": f"{FMU} is absent"}))
        return
    out: dict[str, object] = {"fmu": FMU.name, "rounds": args.rounds}
    with tempfile.TemporaryDirectory() as tmp:
        for n in (int(s) for s in args.sizes.split(",")):
            path = scenario(n, Path(tmp))
            ours(path)  # the first load imports fmpy and the engine: not counted
            hands, mine = [], []
            for _ in range(args.rounds):
                hands.append(hand(n))
                mine.append(ours(path))
            ratios = [m / h for m, h in zip(mine, hands, strict=True)]
            row = {"hand_s": round(statistics.median(hands), 4),
                   "twmr_s": round(statistics.median(mine), 4),
                   "ratio": round(statistics.median(ratios), 2), "ratio_min": round(min(ratios), 2),
                   "ratio_max": round(max(ratios), 2), "target_ratio": 2.0}
            out[f"n{n}"] = row
            print(f"{n} FMUs: hand {row['hand_s']} s, twmr (load, build, 1 step) "
                  f"{row['twmr_s']} s", flush=True)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
