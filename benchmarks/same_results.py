"""Every shipped scenario run at an earlier commit and at the working tree, the results compared bit
for bit: a refactoring must not change a number.

    python benchmarks/same_results.py BASE_REF [--compiled auto|on|off]

The commit BASE_REF is installed (`pip install --no-deps --target`) into a temporary folder put
first on the import path of its runs; the working tree's runs use the installed package. Each
scenario (`scenarios/**/*.yaml` but the bench ones, which pace real or emulated drives to the wall
clock) runs once per side in a fresh process with its own cache folder; their `result.arrows`
tables are compared column by column (names, units, values as bytes). Prints one line per
scenario, then one JSON object.
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

ROOT = Path(__file__).resolve().parents[1]
#: scenarios paced to the wall clock (real or emulated drives): not reproducible bit for bit
PACED = ("bench_",)


def scenarios() -> list[Path]:
    found = sorted(p for p in (ROOT / "scenarios").rglob("*.yaml")
                   if not p.name.startswith(PACED) and "include" not in p.parts)
    return [p for p in found if _runnable(p)]


def _runnable(path: Path) -> bool:
    """A complete scenario (not a fragment that others include)."""
    text = path.read_text(encoding="utf-8")
    return "components:" in text and "experiment:" in text


def install(ref: str, tree: Path, site: Path) -> None:
    """Commit `ref` checked out in `tree` and installed into `site`."""
    subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(tree), ref],
                   check=True, capture_output=True)
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target",
                    str(site), str(tree)], check=True, capture_output=True)


def run(scenario: Path, out: Path, site: Path | None, compiled: str, cache: Path) -> float:
    env = dict(os.environ, TWMR_CACHE_DIR=str(cache), TWMR_COMPILED=compiled)
    if site is not None:
        env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")])
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(scenario), "--out",
                           str(out), "-q"], env=env, capture_output=True, text=True,
                          cwd=scenario.parent, timeout=1800)
    if done.returncode != 0:
        raise RuntimeError(f"{scenario}: {done.stderr.strip()[-2000:]}")
    return time.perf_counter() - t0


def table(folder: Path) -> dict[str, tuple[str, bytes]]:
    """Column -> (unit, its values as bytes) of a run's result."""
    import twmr

    result = twmr.read_result(folder)
    return {name: (unit, result.values[:, k].tobytes())
            for k, (name, unit) in enumerate(zip(result.columns, result.units, strict=True))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("base", help="the earlier commit (a ref git knows)")
    ap.add_argument("--compiled", default="auto", choices=("auto", "on", "off"))
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="twmr-same-") as tmp:
        work = Path(tmp)
        tree = work / "tree"
        install(args.base, tree, work / "site")
        rows = []
        try:
            for path in scenarios():
                rows.append(compare(path, tree, work, args.compiled))
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(tree)],
                           check=True, capture_output=True)
    print(json.dumps({"base": args.base, "compiled": args.compiled, "scenarios": len(rows),
                      "identical": sum(r["identical"] for r in rows),
                      "differ": [r["scenario"] for r in rows if not r["identical"]]}))


def compare(path: Path, tree: Path, work: Path, compiled: str) -> dict[str, object]:
    """One scenario at both commits (each side its own copy of the scenario's folder)."""
    name = str(path.relative_to(ROOT))
    base, head = work / "base" / name, work / "head" / name
    refused = []
    for scenario, out, site, cache in ((tree / name, base, work / "site", "cache-base"),
                                       (path, head, None, "cache-head")):
        try:
            run(scenario, out, site, compiled, work / cache)
        except RuntimeError as err:
            refused.append(str(err).splitlines()[0][-200:])
    if refused:  # both sides must refuse it alike
        same = len(refused) == 2
        print(f"{name}: {'refused by both' if same else 'REFUSED by one'}: {refused[0]}",
              flush=True)
        return {"scenario": name, "columns": 0, "identical": same, "differ": []}
    a, b = table(base), table(head)
    differ = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
    print(f"{name}: {len(a)} columns, "
          f"{'identical' if not differ else 'DIFFER in ' + ', '.join(differ[:5])}", flush=True)
    return {"scenario": name, "columns": len(a), "identical": not differ, "differ": differ[:5]}


if __name__ == "__main__":
    main()
