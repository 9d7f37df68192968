"""Study of the singularity remedy: look-ahead L (and boundary layer phi) against Table III and the
circle error, plus the sensitivity of each choice to a 1 um shift of the initial position.

Run: .venv/bin/python docs/remedy_study.py  (prints a Markdown table used in reproduction.md)
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from twmr.components.metrics import errors, tracking_metrics
from twmr.core import CosimError
from twmr.master import simulate
from twmr.scenario import load

S = Path(__file__).resolve().parent.parent / "scenarios"


def run(name: str, sets: list[str]) -> dict[str, float]:
    try:
        data = simulate(load(S / f"{name}.yaml", sets))
    except CosimError as err:
        return {"error": str(err).split(":")[0][:40] + " " + str(err).split("t = ")[-1][:8]}
    m = tracking_metrics(data)
    t, ex, ey = errors(data)
    late = t >= 10.0
    m["max_abs_after_10s"] = float(max(np.max(np.abs(ex[late])), np.max(np.abs(ey[late]))))
    return m


def main() -> None:
    rows = []
    for L in (0.0, -0.01, -0.02, -0.05, -0.1, 0.05):
        for phi in (0.0, 0.5):
            sets = [f"ctrl.lookahead={L}", f"ctrl.phi={phi}"]
            a = run("paper_trajectory1_asmc", sets)
            a2 = run("paper_trajectory1_asmc", sets + ["plant.pose=[0.500001, 0.0, -0.7853981633974483]"])
            s = run("paper_trajectory1_smc", sets)
            c = run("paper_circle_asmc", sets)
            rows.append({"L": L, "phi": phi, "asmc": a, "asmc_shifted": a2, "smc": s, "circle": c})
            print(json.dumps(rows[-1]), flush=True)
    print()
    print("| L [m] | phi | ASMC mse x / y | SMC mse x / y | ASMC wins 6/6 | mse x change for 1 um shift | circle max abs e after 10 s [m] |")
    print("|---|---|---|---|---|---|---|")
    keys = ("settling_time_x", "settling_time_y", "peak_error_x", "peak_error_y", "mse_x", "mse_y")
    for r in rows:
        a, s, c, a2 = r["asmc"], r["smc"], r["circle"], r["asmc_shifted"]
        failed = [f"{n}: {x['error']}" for n, x in (("ASMC", a), ("ASMC shifted", a2),
                                                     ("SMC", s), ("circle", c)) if "error" in x]
        if failed:
            print(f"| {r['L']} | {r['phi']} | failed ({'; '.join(failed)}) | | | | |")
            continue
        wins = sum(a[k] < s[k] for k in keys)
        shift = abs(a2["mse_x"] - a["mse_x"]) / a["mse_x"]
        print(f"| {r['L']} | {r['phi']} | {a['mse_x']:.4f} / {a['mse_y']:.4f} | "
              f"{s['mse_x']:.4f} / {s['mse_y']:.4f} | {wins}/6 | {shift:.1%} | "
              f"{c['max_abs_after_10s']:.3f} |")


if __name__ == "__main__":
    main()
