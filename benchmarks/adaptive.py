"""Steps taken by the adaptive master against fixed-step Gauss-Seidel at equal accuracy.

The loop of `tests/integration/test_adaptive_master.py` (a step at 1 s into 5 / (s^2 + 3 s + 2)
with unit feedback, 6 s; base step --step, default 1 ms) runs under `algorithm: adaptive` for
each --rtol (atol = rtol / 10); its maximum error against python-control's continuous response
is compared with fixed steps of 1, 2, 4, 8, 12, 24, 48 ms: `fixed_steps` is the step count of
the largest fixed step at least as accurate (NaN: none of them). `do_steps` counts the adaptive
run's component steps per component (a checked macro step costs three: one whole, two halves; a
rejected one three more). Wall times are this machine's, for scale only.

Last line: one JSON object with the figures.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.integration.test_adaptive_master import LOOP, max_error, run


def figures(rtol: float, step: float) -> dict[str, float]:
    t0 = time.perf_counter()
    data, ex = run(LOOP % {"h": step,
                           "alg": f"adaptive, rtol: {rtol:.3e}, atol: {rtol / 10:.3e}"})
    wall = time.perf_counter() - t0
    report = ex.algorithm.report()
    history = ex.algorithm.history  # type: ignore[attr-defined]
    error = max_error(data)
    fixed = None
    for h in (0.001, 0.002, 0.004, 0.008, 0.012, 0.024, 0.048):
        if max_error(run(LOOP % {"h": h, "alg": "gauss_seidel"})[0]) <= error:
            fixed = h
    return {"rtol": rtol, "step_s": step, "max_error": error, **report,
            "do_steps": sum(1 if a.k == 1 else 3 for a in history),
            "fixed_step_s": fixed or float("nan"),
            "fixed_steps": round(6.0 / fixed) if fixed else float("nan"),
            "adaptive_wall_s": round(wall, 3)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rtol", type=float, nargs="+", default=[1e-2, 1e-3])
    parser.add_argument("--step", type=float, default=1e-3,
                        help="the adaptive run's base step [s] (default 1 ms)")
    args = parser.parse_args()
    rows = [figures(r, args.step) for r in args.rtol]
    for row in rows:
        print(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                        for k, v in row.items()))
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
