"""The loop closed on the paper's robot (docs/data.md): a bench run, the plant identified from
it, the identified model checked against the bench. Writes docs/studies/identify_numbers.md and
docs/figures/studies/identify_*.png; prints its wall time.

    .venv/bin/python docs/studies/identify.py

1. The bench: bench_odrive_trajectory1.yaml (the ASMC, two emulated ODrives 0.6.10 on CAN, in
   real time) for 10 s with a plant the fit is not told: plant.scale 1.4 (the scenario's 1.25)
   and slip.slip_gain 1.3 (1); the drives' torques, the pose and the wheel speeds recorded
   every 2 ms.
2. The fit: the plant and slip alone, driven by the recorded drive torques through a `data`
   block, from plant.scale 1.25 and slip.slip_gain 1 (bounds 0.5 .. 2), matching the pose
   (x, y) and both wheel speeds over the first 2 s (`twmr.fit`; over all 10 s the open-loop
   replay drifts so far that the fit stops in another minimum: the numbers say which).
3. The check: the bench scenario with an ideal motor in place of the drives and the fitted
   values, run closed loop (no hardware, not paced), against the bench with `twmr verify`
   (tube: 0.05 absolute in each signal's unit, 1 % relative, 10 ms time shift), and the same
   with the scenario's own values (1.25, 1).
4. A poor start: the same fit from plant.scale 0.55 and slip.slip_gain 1.95, one local fit
   against a global start of six (`starts=6`, on a Dask cluster of two local workers).
5. The re-tune: the ASMC's k, lam and vartheta tuned (`twmr.tune`, 30 trials, from the shipped
   values) on the fitted model in closed loop to the least tracking error (mse_x + mse_y), then
   run on the bench (the emulated drives, the true plant); `twmr verify` compares the bench
   with the fitted model under the new gains, and the bench's tracking error is given before
   and after.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIGS = ROOT / "docs" / "figures" / "studies"
SCENARIOS = ROOT / "scenarios"
STOP = 10.0
UNTIL = 2.0  # [s] the stretch fitted: open loop, the plant drifts far from any start later
TRUE = {"plant.scale": 1.4, "slip.slip_gain": 1.3}
SIGNALS = ["plant.pose[1]", "plant.pose[2]", "plant.wheel_speed[1]", "plant.wheel_speed[2]"]
OPEN_LOOP = """components:
  tq:
    kind: data
    parameters: {file: bench, columns: ['motor.torque[1]', 'motor.torque[2]']}
  plant:
    kind: twmr_plant
    parameters: {scale: 1.25}
    initial: {pose: [0.5, 0.0, -0.7853981633974483]}
  slip: {kind: slip_disturbance, parameters: {profile: paper}}
connections:
  - tq.y -> plant.torque
  - slip.slip_rate -> plant.slip_rate
  - slip.slip_accel -> plant.slip_accel
  - slip.disturbance -> plant.disturbance
  - plant.pose -> slip.pose
experiment: {start: 0.0, stop: %g, step: 2.0e-3, algorithm: gauss_seidel}
record: {signals: [plant.pose, plant.wheel_speed]}
"""
RECORD = "  signals: [ref.position, plant.pose, plant.wheel_speed, motor.torque, ctrl.error]"


def bench(folder: Path) -> Path:
    import twmr

    text = (SCENARIOS / "bench_odrive_trajectory1.yaml").read_text(encoding="utf-8")
    text = text.replace("stop: 10.0", f"stop: {STOP}").replace("decimation: 5", "decimation: 1")
    lines = [RECORD if line.startswith("  signals:") else line for line in text.splitlines()]
    (folder / "bench.yaml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    overrides = [f"{k}={v}" for k, v in TRUE.items()]
    twmr.simulate(twmr.load(folder / "bench.yaml", overrides), folder / "bench")
    return folder / "bench"


def closed_loop(folder: Path, values: dict[str, float], tag: str) -> Path:
    """The bench scenario with an ideal motor (its 40 N.m limit) in place of the drives, with
    `values`, recorded as the bench is."""
    import twmr

    lines = (folder / "bench.yaml").read_text(encoding="utf-8").splitlines()
    first, last = lines.index("  motor:"), lines.index("  plant:")
    lines[first:last] = ["  motor:", "    kind: motor_driver",
                         "    parameters: {mode: ideal, torque_max: 40.0}"]
    (folder / f"{tag}.yaml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    overrides = [f"{k}={v!r}" for k, v in values.items()]
    twmr.simulate(twmr.load(folder / f"{tag}.yaml", overrides), folder / tag)
    return folder / tag


SHIPPED = {"ctrl.k": 59.86576491472427, "ctrl.lam": 2.695663974624746,
           "ctrl.vartheta": 36.62110443258697}
RETUNE = {"ctrl.k": "log:10:120", "ctrl.lam": "log:1:20", "ctrl.vartheta": "log:5:80"}


def retune(folder: Path, fitted: dict[str, float], measured: Path, tol: Any
           ) -> tuple[dict[str, float], dict[str, float], dict[str, float], Any]:
    """The gains tuned on the fitted model (its scenario written by `closed_loop`); the bench's
    tracking figures with the shipped and the re-tuned gains; the fitted model under the
    re-tuned gains verified against the bench run with them."""
    import twmr
    from twmr.components.metrics import tracking_metrics
    from twmr.verify import verify

    values = [f"{k}={v!r}" for k, v in fitted.items()]
    outcome = twmr.tune(folder / "fitted.yaml", RETUNE, "mse_x + mse_y", trials=30, seed=3,
                        metrics=["tracking"], start=[SHIPPED], overrides=values,
                        lockstep=True, out=folder / "retune", report=False)
    best = {k: float(outcome.best[k]) for k in RETUNE}
    gains = [f"{k}={v!r}" for k, v in best.items()]
    after = twmr.simulate(twmr.load(folder / "bench.yaml", [
        *(f"{k}={v}" for k, v in TRUE.items()), *gains]), folder / "bench_retuned")
    twmr.simulate(twmr.load(folder / "fitted.yaml", [*values, *gains]),
                  folder / "model_retuned")
    check = verify(folder / "model_retuned", folder / "bench_retuned", tol, SIGNALS)
    before = twmr.read_result(measured)
    return best, tracking_metrics(before.data), tracking_metrics(after.data), check


def main() -> None:
    from twmr.fitting import Experiment, fit
    from twmr.plots import pyplot, save
    from twmr.result import read_result
    from twmr.verify import Tolerance, verify

    started = time.perf_counter()
    lines = ["# Numbers of docs/studies/identify.py", "",
             "Written by `.venv/bin/python docs/studies/identify.py`; do not edit.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        measured = bench(folder)
        (folder / "open.yaml").write_text(OPEN_LOOP % STOP, encoding="utf-8")
        fitted = fit(folder / "open.yaml", [Experiment(measured, until=UNTIL)],
                     ["plant.scale=0.5:2", "slip.slip_gain=0.5:2"], SIGNALS,
                     out=folder / "fit")
        lines += ["## The fit", "", "| parameter | true (bench) | start | fitted | 95 % interval "
                  "|", "|---|---|---|---|---|"]
        for name, value in fitted.estimates.items():
            lo, hi = fitted.interval[name]
            start = 1.25 if name == "plant.scale" else 1.0
            lines.append(f"| {name} | {TRUE[name]} | {start} | {value:.6f} | [{lo:.6f}, "
                         f"{hi:.6f}] |")
        lines += ["", f"{fitted.runs} runs; {fitted.status}", ""]
        whole = fit(folder / "open.yaml", [Experiment(measured)],
                    ["plant.scale=0.5:2", "slip.slip_gain=0.5:2"], SIGNALS)
        lines += ["The same fit over all 10 s: " + ", ".join(
            f"{k} {v:.6f}" for k, v in whole.estimates.items()) + f" (cost {whole.cost:.4g}, "
            f"against {fitted.cost:.3g} over the first {UNTIL:g} s): another minimum.", ""]
        tol = Tolerance(abs=0.05, rel=0.01, shift=0.01)
        lines += ["## The model against the bench (`twmr verify`)", "",
                  f"Tube: abs {tol.abs}, rel {tol.rel}, shift {tol.shift} s.", ""]
        runs = {"fitted values": closed_loop(folder, fitted.estimates, "fitted"),
                "the scenario's values": closed_loop(folder, {}, "nominal")}
        for label, run in runs.items():
            verdict = verify(run, measured, tol, SIGNALS)
            lines += [f"### {label}", "", "```", verdict.text().replace(str(folder) + "/", ""),
                      "```", ""]
        poor = ["plant.scale=0.5:2@0.55", "slip.slip_gain=0.5:2@1.95"]
        one = fit(folder / "open.yaml", [Experiment(measured, until=UNTIL)], poor, SIGNALS)
        many = fit(folder / "open.yaml", [Experiment(measured, until=UNTIL)], poor, SIGNALS,
                   starts=6, workers=2)
        lines += ["## A poor start and the global start", "",
                  "From plant.scale 0.55 and slip.slip_gain 1.95 (bounds 0.5 .. 2):", "",
                  "| fit | plant.scale | slip.slip_gain | cost | runs |", "|---|---|---|---|---|"]
        for label, r in (("one local fit", one), ("global start, 6 starts (Dask, 2 workers)",
                                                  many)):
            lines.append(f"| {label} | {r.estimates['plant.scale']:.6f} | "
                         f"{r.estimates['slip.slip_gain']:.6f} | {r.cost:.4g} | {r.runs} |")
        costs = sorted(s["cost"] for s in many.starts)
        shown = ", ".join(f"{c:.3g}" for c in costs)
        lines += ["", f"The six local fits stopped at costs {shown}.", ""]
        retuned, before, after, check = retune(folder, fitted.estimates, measured, tol)
        lines += ["## Re-tuned on the fitted model, run on the bench", "",
                  "| gain | shipped | re-tuned |", "|---|---|---|"]
        for name, value in retuned.items():
            lines.append(f"| {name} | {SHIPPED[name]:.6g} | {value:.6g} |")
        lines += ["", "| bench run | mse_x [m²] | mse_y [m²] |", "|---|---|---|",
                  f"| shipped gains | {before['mse_x']:.4g} | {before['mse_y']:.4g} |",
                  f"| re-tuned gains | {after['mse_x']:.4g} | {after['mse_y']:.4g} |", "",
                  "The fitted model under the re-tuned gains against that bench run:", "",
                  "```", check.text().replace(str(folder) + "/", ""), "```", ""]
        plt = pyplot()
        fig, axes = plt.subplots(1, 2, figsize=(10, 4))
        b = read_result(measured)
        axes[0].plot(b["plant.pose[1]"], b["plant.pose[2]"], lw=1.6, color="#999999",
                     label="bench (emulated ODrives)")
        for label, run in runs.items():
            r = read_result(run)
            axes[0].plot(r["plant.pose[1]"], r["plant.pose[2]"], lw=0.9, label=label)
            axes[1].plot(r["time"], r["plant.wheel_speed[1]"] - b["plant.wheel_speed[1]"],
                         lw=0.8, label=label)
        axes[0].set_xlabel("x [m]")
        axes[0].set_ylabel("y [m]")
        axes[0].set_aspect("equal", adjustable="datalim")
        axes[0].legend(fontsize=7, frameon=False)
        axes[1].set_xlabel("time [s]")
        axes[1].set_ylabel("right wheel speed, model - bench [rad/s]")
        axes[1].legend(fontsize=7, frameon=False)
        save(fig, FIGS / "identify_model_vs_bench")
    lines.append(f"Wall time of the study: {time.perf_counter() - started:.0f} s.")
    (HERE / "identify_numbers.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
