"""Install footprint: the packages and megabytes of a fresh virtual environment with twmr-cosim
installed from this checkout, for the core install and for each extra alone, and for `[test]`
(every extra and the test tools, as the README installs it).

Each install is `python -m venv` + `pip install '<checkout>[EXTRA]'` (a regular, non-editable
install, so twmr-cosim itself is counted) in a temporary folder; figures: the distributions
`pip list` shows beside those of an empty venv (pip, setuptools), and the size of its
site-packages folder (`du`-style sum of file sizes, MB = 10^6 bytes).

    python benchmarks/install_footprint.py [--extras core,plot,cluster,tune,live,hw,test]

Last line: one JSON object.
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


def size_mb(folder: Path) -> float:
    total = 0
    for base, _dirs, files in os.walk(folder):
        for name in files:
            path = Path(base) / name
            if not path.is_symlink():
                total += path.stat().st_size
    return total / 1e6


def footprint(extra: str, tmp: Path) -> dict[str, object]:
    venv = tmp / f"venv-{extra}"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    py = venv / "bin" / "python"
    def installed() -> set[str]:
        listed = subprocess.run([py, "-m", "pip", "list", "--format", "json"], check=True,
                                capture_output=True, text=True).stdout
        return {p["name"].lower() for p in json.loads(listed)}

    before = installed()
    target = str(ROOT) if extra == "core" else f"{ROOT}[{extra}]"
    t0 = time.perf_counter()
    subprocess.run([py, "-m", "pip", "install", "-q", target], check=True,
                   stdout=subprocess.DEVNULL)
    seconds = time.perf_counter() - t0
    after = installed()
    site = next((venv / "lib").glob("python*/site-packages"))
    return {"packages": len(after - before), "site_packages_mb": round(size_mb(site), 1),
            "install_s": round(seconds, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--extras", default="core,plot,cluster,tune,live,hw,test")
    extras = [e.strip() for e in ap.parse_args().extras.split(",") if e.strip()]
    figures: dict[str, object] = {}
    with tempfile.TemporaryDirectory(prefix="twmr-footprint-") as folder:
        for extra in extras:
            figures[extra] = footprint(extra, Path(folder))
            print(f"{extra}: {figures[extra]}", flush=True)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
