"""Start-up cost of the command line, beside the interpreter's own.

Each command runs as a subprocess (the venv's `twmr`, found next to `sys.executable`), timed on
the wall clock from spawn to exit; the commands are interleaved within each repeat (their order
rotated from one repeat to the next) and the medians over the repeats are reported, in seconds
and as a ratio to `python -c pass` measured in the same run:

- `python -c pass`, `python -c "import twmr"`;
- `twmr run` of a 1-step scenario of two blocks (a `sine` into a `gain`, stop 0.001, step 0.001)
  into a temporary folder, with `--quiet` (no export: the default) and with `--format csv,mat`;
- `twmr check scenarios/paper_trajectory1_asmc.yaml`;
- `twmr run scenarios/paper_trajectory1_asmc.yaml --quiet --set experiment.stop=0.001`;
- `twmr run scenarios/paper_trajectory1_asmc.yaml --quiet` (all 30,000 steps, compiled: what
  importing numba and loading the compiled kinds from its cache add to a run; no target).

Targets (an idle machine): `twmr run` of the 1-step scenario < 0.4 s and at most 3x `python -c
pass`, `twmr run` of the paper scenario for one step < 1.0 s, `twmr check` of the paper scenario
< 1.0 s, the whole 30 s paper run (a warm cache) < 0.3 s.
Then one `python -X importtime -m twmr.cli run` of the 1-step scenario lists which heavy modules
(scipy.signal, scipy.interpolate, control, pandas, matplotlib, numba, jsonschema, dask,
importlib.metadata: the entry points are read from their cache after the first start) it
imports; the same is reported for `twmr check` and the 1-step `twmr run` of the paper scenario
(whose blocks may import some of them on purpose: numba for the plant's model).
The subprocesses run in a temporary working directory, so `results/` lands there.

    python benchmarks/startup.py [--repeats 7]

Last line: one JSON object.
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

ROOT = Path(__file__).resolve().parent.parent
PAPER = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
TINY = """\
components:
  src: {kind: sine, parameters: {frequency: 1.0}}
  g: {kind: gain, parameters: {k: 2.0}}
connections:
  - src.y -> g.u
experiment: {start: 0.0, stop: 0.001, step: 0.001}
record: {signals: [src.y, g.y]}
"""
HEAVY = ("scipy.signal", "scipy.interpolate", "control", "pandas", "matplotlib", "numba",
         "jsonschema", "dask", "importlib.metadata")
TARGETS = {"twmr_run_1step": 0.4, "twmr_run_paper_1step": 1.0, "twmr_check_paper": 1.0,
           "twmr_run_paper": 0.3}
#: the most `twmr run` of the 1-step scenario may take, in runs of `python -c pass`
TARGET_RATIO_1STEP = 3.0


def twmr_script() -> str:
    exe = Path(sys.executable)
    for folder in (exe.parent, exe.resolve().parent):
        if (folder / "twmr").is_file():
            return str(folder / "twmr")
    raise SystemExit(f"no 'twmr' script beside {sys.executable}: install the package in the venv")


def commands(tmp: Path) -> dict[str, list[str]]:
    py, twmr = sys.executable, twmr_script()
    tiny = tmp / "tiny.yaml"
    return {
        "python_pass": [py, "-c", "pass"],
        "import_twmr": [py, "-c", "import twmr"],
        "twmr_run_1step": [twmr, "run", str(tiny), "--out", str(tmp / "out_none"), "--quiet",
                           "--format", "none"],
        "twmr_run_1step_csv_mat": [twmr, "run", str(tiny), "--out", str(tmp / "out_default"),
                                   "--quiet", "--format", "csv,mat"],
        "twmr_check_paper": [twmr, "check", str(PAPER)],
        "twmr_run_paper_1step": [twmr, "run", str(PAPER), "--quiet", "--set",
                                 "experiment.stop=0.001"],
        "twmr_run_paper": [twmr, "run", str(PAPER), "--quiet"],
    }


def timed(cmd: list[str], cwd: Path, env: dict[str, str]) -> float:
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, check=False, cwd=cwd, env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    return wall


def heavy_imports(args: list[str], tmp: Path, env: dict[str, str]) -> dict[str, object]:
    """Modules imported by `python -X importtime -m twmr.cli *args`: the heavy ones found, how
    many in all, and the slowest top-level imports (cumulative ms)."""
    cmd = [sys.executable, "-X", "importtime", "-m", "twmr.cli", *args]
    proc = subprocess.run(cmd, check=False, cwd=tmp, env=env, stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr}")
    cumulative: dict[str, int] = {}
    for line in proc.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        # "import time:   self_us |  cumulative_us |   <indent>name"
        _, cum_us, name = line.split(":", 1)[1].split("|", 2)
        cumulative[name.strip()] = int(cum_us)
    modules = set(cumulative)
    found = [h for h in HEAVY if any(m == h or m.startswith(h + ".") for m in modules)]
    top = sorted(((n, us) for n, us in cumulative.items() if "." not in n),
                 key=lambda item: -item[1])[:8]
    return {"heavy_modules_imported": found, "modules_imported": len(modules),
            "top_level_imports_ms": {n: round(us / 1e3, 1) for n, us in top}}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # bytecode caches as a user has them
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        (tmp / "tiny.yaml").write_text(TINY)
        cmds = commands(tmp)
        names = list(cmds)
        for name in names:  # warm-up: bytecode caches and the page cache, as after an install
            timed(cmds[name], tmp, env)
        walls: dict[str, list[float]] = {name: [] for name in names}
        for r in range(args.repeats):
            order = names[r % len(names):] + names[:r % len(names)]
            for name in order:
                walls[name].append(timed(cmds[name], tmp, env))
            print(f"repeat {r + 1}/{args.repeats}: " +
                  ", ".join(f"{n} {walls[n][-1]:.3f}" for n in names), flush=True)
        written = sorted(p.name for p in (tmp / "out_default").iterdir())
        imports = heavy_imports(["run", str(tmp / "tiny.yaml"), "--out", str(tmp / "out_imports"),
                                 "--quiet", "--format", "none"], tmp, env)
        check_imports = heavy_imports(["check", str(PAPER)], tmp, env)
        paper_imports = heavy_imports(["run", str(PAPER), "--quiet", "--set",
                                       "experiment.stop=0.001"], tmp, env)
        full_imports = heavy_imports(["run", str(PAPER), "--quiet"], tmp, env)
    median = {name: statistics.median(v) for name, v in walls.items()}
    base = median["python_pass"]
    figures: dict[str, object] = {"repeats": args.repeats}
    for name in names:
        figures[f"{name}_s"] = round(median[name], 4)
        figures[f"{name}_min_s"] = round(min(walls[name]), 4)
        figures[f"{name}_ratio_to_python"] = round(median[name] / base, 2)
    for name, target in TARGETS.items():
        figures[f"target_{name}_s"] = target
        figures[f"target_{name}_met"] = median[name] < target
    figures["target_twmr_run_1step_ratio_to_python"] = TARGET_RATIO_1STEP
    figures["target_twmr_run_1step_ratio_met"] = \
        figures["twmr_run_1step_ratio_to_python"] <= TARGET_RATIO_1STEP
    figures["twmr_run_1step_csv_mat_target_met"] = \
        median["twmr_run_1step_csv_mat"] < TARGETS["twmr_run_1step"]
    figures["csv_mat_files"] = written
    figures.update(imports)
    figures["heavy_modules_checked"] = list(HEAVY)
    figures["twmr_check_paper_heavy_modules"] = check_imports["heavy_modules_imported"]
    figures["twmr_run_paper_1step_heavy_modules"] = paper_imports["heavy_modules_imported"]
    figures["twmr_run_paper_1step_top_level_imports_ms"] = paper_imports["top_level_imports_ms"]
    figures["twmr_run_paper_heavy_modules"] = full_imports["heavy_modules_imported"]
    figures["twmr_run_paper_top_level_imports_ms"] = full_imports["top_level_imports_ms"]
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
