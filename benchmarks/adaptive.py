"""Steps taken by the adaptive master against fixed-step Gauss-Seidel at equal accuracy.

Three cases (`--case`, default all of them):

- `loop`: the loop of `tests/integration/test_adaptive_master.py` (a step at 1 s into
  5 / (s^2 + 3 s + 2) with unit feedback, 6 s; base step --step, default 1 ms) under
  `algorithm: adaptive` for each --rtol (atol = rtol / 10); its maximum error against
  python-control's continuous response is compared with fixed steps of 1, 2, 4, 8, 12, 24,
  48 ms: `fixed_steps` is the step count of the largest fixed step at least as accurate (NaN:
  none of them).
- `ball`: the FMI 3.0 bouncing ball `tests/fmus/bounce3` alone, 1.2 s (one bounce at
  sqrt(2 h / g) = 0.4515236 s, a second at 1.0837 s). Model exchange (FMU rtol 1e-8, base step
  1 ms): the error is the recorded event time's against the analytic one; co-simulation (base
  step 1 us): the width of the two rows that bracket the bounce. Fixed steps of 1 ms and 0.1 ms
  show the bounce at the grid point after it; `fixed_steps_as_accurate` is stop / error, the
  steps of a fixed grid as fine as the adaptive run's error (computed, not run).
- `fmpy`: the Reference FMUs BouncingBall (3 s) and VanDerPol (10 s), FMI 2.0 model exchange,
  a point every 10 ms, against fmpy's `simulate_fmu` (CVODE at rtol 1e-6) in the same process,
  both from the file, interleaved, medians of --rounds: the adaptive master with the FMU's
  largest rtol of 1e-6 ... 1e-9 that is at least as accurate (the first bounce's time against
  sqrt(2 h / g); x0 against fmpy's CVODE at rtol 1e-12) (`wall_ratio`).
- `vdp`: the Van der Pol oscillator `tests/fmus/vdp2` in co-simulation (one RK4 step per
  doStep, mu = 1, 10 s, base step 0.1 ms) for rtol = atol = 1e-4 and 1e-6, against fmpy's
  CVODE at rtol 1e-10 (model exchange of the same FMU); fixed steps of 5 to 100 ms.

`do_steps` counts the adaptive run's doStep calls per component (a checked macro step costs
three: one whole, two halves; a step retried to a state event or halved for a discrete change
one). Wall times are this machine's, for scale only: compare the ratios of one run.

Last line: one JSON object with the figures, one list per case.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from tests.fmu_build import build_c_fmu
from tests.integration.test_adaptive_master import LOOP, max_error, run
from twmr.master import Execution
from twmr.observers.store import ResultStore
from twmr.scenario import loads

T1 = math.sqrt(2 * 1.0 / 9.81)


def do_steps(history: list[Any]) -> int:
    return sum(1 if math.isnan(a.err) else 3 for a in history)


def timed(text: str) -> tuple[np.ndarray, Execution, float]:
    """(rows, execution, wall time [s]) of one run of scenario `text`."""
    ex = Execution(loads(text, source="bench.yaml"), [store := ResultStore()])
    t0 = time.perf_counter()
    ex.run()
    return store.data(), ex, time.perf_counter() - t0


def adaptive_figures(ex: Execution, wall: float) -> dict[str, Any]:
    return {**ex.algorithm.report(), "do_steps": do_steps(ex.algorithm.history),  # type: ignore[attr-defined]
            "adaptive_wall_s": round(wall, 3)}


def loop_figures(rtol: float, step: float) -> dict[str, Any]:
    t0 = time.perf_counter()
    data, ex = run(LOOP % {"h": step,
                           "alg": f"adaptive, rtol: {rtol:.3e}, atol: {rtol / 10:.3e}"})
    wall = time.perf_counter() - t0
    error = max_error(data)
    fixed = None
    for h in (0.001, 0.002, 0.004, 0.008, 0.012, 0.024, 0.048):
        if max_error(run(LOOP % {"h": h, "alg": "gauss_seidel"})[0]) <= error:
            fixed = h
    return {"rtol": rtol, "step_s": step, "max_error": error, **adaptive_figures(ex, wall),
            "fixed_step_s": fixed or float("nan"),
            "fixed_steps": round(6.0 / fixed) if fixed else float("nan")}


def ball_scenario(path: Path, interface: str, experiment: str) -> str:
    solver = ", rtol: 1.0e-8" if interface == "model_exchange" else ""
    return f"""
components:
  ball: {{kind: fmu, parameters: {{path: {path}, interface: {interface}{solver}}}}}
experiment: {{start: 0.0, stop: 1.2, {experiment}}}
record: {{signals: [ball.h, ball.bounces]}}
"""


def bounce_error(data: np.ndarray, interface: str) -> float:
    """ME: |recorded event time - analytic| [s]; CS: the width of the rows bracketing it."""
    i = int(np.argmax(data[:, 2] >= 1))
    if interface == "model_exchange":
        return abs(float(data[i, 0]) - T1)
    return float(data[i, 0] - data[i - 1, 0])


def ball_figures(path: Path, interface: str) -> dict[str, Any]:
    base = "1.0e-3" if interface == "model_exchange" else "1.0e-6"
    data, ex, wall = timed(ball_scenario(path, interface, f"step: {base}, algorithm: adaptive, "
                                         "rtol: 1.0e-6, atol: 1.0e-8, max_step: 0.1"))
    error = bounce_error(data, interface)
    row: dict[str, Any] = {"interface": interface, "step_s": float(base),
                           "first_bounce_error_s": error, **adaptive_figures(ex, wall)}
    for h in ("1.0e-3", "1.0e-4"):
        fixed, _, fixed_wall = timed(ball_scenario(path, interface, f"step: {h}"))
        row[f"fixed_{h}_error_s"] = bounce_error(fixed, interface)
        row[f"fixed_{h}_steps"] = round(1.2 / float(h))
        row[f"fixed_{h}_wall_s"] = round(fixed_wall, 3)
    row["fixed_steps_as_accurate"] = math.ceil(1.2 / error)
    return row


def vdp_figures(path: Path, rtol: float) -> dict[str, Any]:
    from fmpy import simulate_fmu

    ref = simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=10.0,
                       relative_tolerance=1e-10, output_interval=1e-4, output=["x0", "x1"])

    def error(data: np.ndarray) -> float:
        return max(float(np.max(np.abs(data[:, j + 1] - np.interp(data[:, 0], ref["time"],
                                                                  ref[x]))))
                   for j, x in enumerate(("x0", "x1")))

    def text(experiment: str) -> str:
        return f"""
components:
  osc: {{kind: fmu, parameters: {{path: {path}}}}}
experiment: {{start: 0.0, stop: 10.0, {experiment}}}
record: {{signals: [osc.x0, osc.x1]}}
"""
    data, ex, wall = timed(text(f"step: 1.0e-4, algorithm: adaptive, rtol: {rtol:.3e}, "
                                f"atol: {rtol:.3e}"))
    err = error(data)
    row: dict[str, Any] = {"rtol": rtol, "max_error": err, **adaptive_figures(ex, wall),
                           "fixed_step_s": float("nan"), "fixed_error": float("nan"),
                           "fixed_steps": float("nan"), "fixed_wall_s": float("nan")}
    for h in (0.005, 0.01, 0.02, 0.025, 0.04, 0.05, 0.1):
        fixed, _, fixed_wall = timed(text(f"step: {h}"))
        if error(fixed) <= err:
            row.update(fixed_step_s=h, fixed_error=error(fixed), fixed_steps=round(10.0 / h),
                       fixed_wall_s=round(fixed_wall, 3))
    return row


def fmpy_figures(rounds: int) -> list[dict[str, Any]]:
    """BouncingBall (error: the first bounce's time) and VanDerPol (error: the largest
    deviation of x0 at the recorded points from fmpy's CVODE at rtol 1e-12), each against fmpy's
    `simulate_fmu` at rtol 1e-6 (3 s and 10 s, a point every 10 ms)."""
    from fmpy import simulate_fmu

    import twmr
    from tests.conformance.corpus import corpus

    rows = []
    for name, stop, signal in (("BouncingBall_fmi2.fmu", 3.0, "h"),
                               ("VanDerPol_fmi2.fmu", 10.0, "x0")):
        path = corpus("reference-fmus", name)

        def fmpy_run(rtol: float, path: Path = path, stop: float = stop) -> Any:
            return simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=stop,
                                output_interval=0.01, relative_tolerance=rtol)

        exact = fmpy_run(1e-12)

        def error(t: np.ndarray, y: np.ndarray, signal: str = signal, exact: Any = exact
                  ) -> float:
            if signal == "h":  # the first bounce: fmpy's two rows at the event, ours one
                return float(np.min(np.abs(t - T1)))
            return float(np.max(np.abs(np.interp(t, exact["time"], exact[signal]) - y)))

        def theirs(fmpy_run: Any = fmpy_run, signal: str = signal
                   ) -> tuple[float, float, int]:
            t0 = time.perf_counter()
            out = fmpy_run(1e-6)
            wall = time.perf_counter() - t0
            t = out["time"]
            if signal == "h":
                t = np.array([t[i] for i in range(1, len(t)) if t[i] == t[i - 1]][:1])
            return wall, error(t, out[signal][:len(t)]), len(out)

        def ours(rtol: float, path: Path = path, stop: float = stop, signal: str = signal,
                 algorithm: str = ", algorithm: adaptive") -> tuple[float, float, int]:
            text = f"""
components:
  m: {{kind: fmu, parameters: {{path: {path}, interface: model_exchange, rtol: {rtol}}}}}
experiment: {{start: 0.0, stop: {stop}, step: 0.01{algorithm}}}
record: {{signals: [m.{signal}]}}
"""
            t0 = time.perf_counter()
            result = twmr.simulate(twmr.load(text), None)
            wall = time.perf_counter() - t0
            return (wall, error(np.asarray(result["time"]), np.asarray(result[f"m.{signal}"])),
                    len(result))

        theirs()
        target = theirs()[1]
        rtol = next((r for r in (1e-6, 3e-7, 1e-7, 3e-8, 1e-8, 3e-9, 1e-9)
                     if ours(r)[1] <= target), 1e-9)
        walls: tuple[list[float], list[float], list[float]] = ([], [], [])
        for _ in range(rounds):
            walls[0].append(ours(rtol)[0])
            walls[1].append(theirs()[0])
            if signal != "h":  # fixed steps show a bounce only at the grid point after it
                walls[2].append(ours(1e-6, algorithm="")[0])
        mine, fmpy = (statistics.median(w) for w in walls[:2])
        ratios = [a / b for a, b in zip(walls[0], walls[1], strict=True)]
        mine_last, theirs_last = ours(rtol), theirs()
        rows.append({"fmu": name, "error": "first bounce time [s]" if signal == "h" else
                     "max |x0 - reference| at the rows", "fmpy_rtol": 1e-6,
                     "fmpy_error": target, "fmpy_rows": theirs_last[2], "fmpy_wall_s": fmpy,
                     "adaptive_rtol": rtol, "adaptive_error": mine_last[1],
                     "adaptive_rows": mine_last[2], "adaptive_wall_s": mine,
                     "wall_ratio": mine / fmpy, "wall_ratio_min": min(ratios),
                     "wall_ratio_max": max(ratios)})
        if walls[2]:  # the fixed-step master at the same rtol, a row every 10 ms as fmpy
            fixed = ours(1e-6, algorithm="")
            rows[-1].update(fixed_error=fixed[1], fixed_rows=fixed[2],
                            fixed_wall_s=statistics.median(walls[2]),
                            fixed_wall_ratio=statistics.median(walls[2]) / fmpy)
    return rows


def show(case: str, rows: list[dict[str, Any]]) -> None:
    for row in rows:
        print(case + ": " + ", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}"
                                      for k, v in row.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", nargs="+", choices=("loop", "ball", "vdp", "fmpy"),
                        default=["loop", "ball", "vdp", "fmpy"])
    parser.add_argument("--rounds", type=int, default=9, help="fmpy: interleaved rounds")
    parser.add_argument("--rtol", type=float, nargs="+", default=[1e-2, 1e-3],
                        help="the loop's tolerances")
    parser.add_argument("--step", type=float, default=1e-3,
                        help="the loop's adaptive base step [s] (default 1 ms)")
    args = parser.parse_args()
    out: dict[str, list[dict[str, Any]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        if "loop" in args.case:
            out["loop"] = [loop_figures(r, args.step) for r in args.rtol]
        if "ball" in args.case:
            ball = build_c_fmu("bounce3", Path(tmp), fmi3=True)
            out["ball"] = [ball_figures(ball, i) for i in ("model_exchange", "co_simulation")]
        if "vdp" in args.case:
            vdp = build_c_fmu("vdp2", Path(tmp))
            out["vdp"] = [vdp_figures(vdp, r) for r in (1e-4, 1e-6)]
        if "fmpy" in args.case:
            out["fmpy"] = fmpy_figures(args.rounds)
    for case, rows in out.items():
        show(case, rows)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
