"""Regenerate every number and figure of docs/reproduction.md.

    .venv/bin/python docs/reproduction/regenerate.py          # sweeps, then tables and figures
    .venv/bin/python docs/reproduction/regenerate.py 10       # a quick check on 10 realisations

Runs the three sweep files of this folder (100 realisations each: start within +-1 mm, RK4
substep 1 ms or 0.1 ms, slip phase over its period; seed 1, so the ASMC and SMC sweeps draw the
same realisations, paired by `sample`) twice: as shipped (48 N.m per wheel, the bounded-torque
configuration) and "as printed" (Table II's eta = 7, sgn, 1 mm clamp, no torque limit). Sweep
folders go to $REPRO_OUT (default: twmr_reproduction in the system's temporary folder; an existing
folder is resumed); the tables go to docs/reproduction/numbers.md and the figures to
docs/figures/reproduction/. It prints its own wall time, and writes it into numbers.md.

Definitions fixed before looking at results (docs/reproduction.md explains them):
- Table III metrics: `--metrics tracking` (world-frame errors, settling band 0.15 m); the band's
  influence is shown with 0.10 and 0.20 m, recomputed from the kept signals;
- ASMC wins a realisation when each of its six metrics is strictly lower than the SMC's in the
  same realisation (inf against inf is not lower; a failed run loses);
- circle: a realisation passes when max |e_x| and max |e_y| (world frame) over t >= 10 s are both
  <= 0.07 m;
- torque: the applied torque (motor.torque), peak over both wheels and RMS over both wheels, from
  the recorded rows (every 10 ms); as printed, also the peak over every 1 ms step (the same
  realisations run again, recording motor.torque at every step, `--metrics signals`; bounded,
  the clip at 48 N.m is the 1 ms peak too);
- driving direction: the sign of the forward speed r (phi_R' + phi_L') / 2 of M over t >= 5 s.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIGS = ROOT / "docs" / "figures" / "reproduction"
OUT = Path(os.environ.get("REPRO_OUT", Path(tempfile.gettempdir()) / "twmr_reproduction"))
KEYS = ("settling_time_x", "settling_time_y", "peak_error_x", "peak_error_y", "mse_x", "mse_y")
BANDS = (0.10, 0.15, 0.20)
R_WHEEL = 0.15          # [m], Table I
T_LATE, E_CIRCLE = 10.0, 0.07
PAPER = {"asmc": (2.0, 0.8, 0.19, 0.19, 0.054, 0.145), "smc": (5.2, 4.0, 0.45, 0.54, 0.127, 0.258)}
AS_PRINTED = ["ctrl.torque_limit=0", "motor.torque_max=0", "ctrl.eps_singular=0.001", "ctrl.phi=0",
              "ctrl.lam=13", "ctrl.vartheta=20", "ctrl.k=20", "ctrl.lookahead=0.05",
              "ctrl.drive=backward"]  # Table II, and the 5 cm look-ahead behind M
AS_PRINTED_ASMC = ["ctrl.eta=7", "ctrl.hold_saturated=false", "ctrl.d_hat_limit=0"]
SWEEPS = ("trajectory1_asmc", "trajectory1_smc", "circle_asmc")
VARIANTS = ("bounded", "as_printed")


def run_sweep(name: str, variant: str, samples: int, fixed_phase: bool = False) -> Path:
    """Run (or resume) one sweep file in one variant (with the slip phase fixed at 0: only the
    start and the plant step vary); its folder."""
    out = OUT / variant / (name + ("_phase0" if fixed_phase else ""))
    cmd = [sys.executable, "-m", "twmr.cli", "sweep", str(HERE / f"{name}.yaml"), "--out", str(out),
           "--workers", "2", "--samples", str(samples), "-q"]
    if fixed_phase:
        cmd += ["--vary", "slip.phase=values:0.0"]
    if variant == "as_printed":
        for s in AS_PRINTED + (AS_PRINTED_ASMC if "asmc" in name else []):
            cmd += ["--set", s]
    print("$ twmr", " ".join(cmd[3:]).replace(str(ROOT) + "/", ""), flush=True)
    subprocess.run(cmd, check=False, cwd=ROOT)
    return out


def fine_torque(name: str, variant: str, samples: int) -> pd.DataFrame:
    """The peak applied torque of each realisation of one sweep file as printed, from every 1 ms
    step: the same draws of a copy of its scenario that records motor.torque at every step."""
    import yaml

    import twmr

    file = yaml.safe_load((HERE / f"{name}.yaml").read_text(encoding="utf-8"))
    scenario = (HERE / file["scenario"]).resolve()
    data = yaml.safe_load(scenario.read_text(encoding="utf-8"))
    data["record"] = {"signals": ["motor.torque"], "decimation": 1}
    out = OUT / variant / f"{name}_1ms"
    out.mkdir(parents=True, exist_ok=True)
    copy = OUT / variant / f"{name}_1ms.yaml"
    copy.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    sets = AS_PRINTED + (AS_PRINTED_ASMC if "asmc" in name else [])
    print(f"$ twmr sweep {copy.name} (the scenario recording motor.torque every step) --samples "
          f"{samples} --seed {file['seed']} --metrics signals" + "".join(f" --set {s}" for s in
                                                                         sets), flush=True)
    frame = twmr.sweep(copy, file["vary"], samples=samples, seed=file["seed"],
                       method=file["method"], overrides=sets, metrics=["signals"], workers=2,
                       out=out).frame()
    frame["torque_peak_1ms"] = np.maximum(frame.get("peak_motor_torque_1", np.nan),
                                          frame.get("peak_motor_torque_2", np.nan))
    return frame[["sample", "torque_peak_1ms"]]


def settling(t: np.ndarray, e: np.ndarray, band: float) -> float:
    outside = np.nonzero(np.abs(e) > band)[0]
    if len(outside) == 0:
        return float(t[0])
    return float(t[outside[-1] + 1]) if outside[-1] + 1 < len(t) else float("inf")


def per_run(folder: Path) -> tuple[pd.DataFrame, dict[str, np.ndarray]]:
    """runs.parquet plus the figures derived from each run's kept signals; the error, torque
    and time series of the successful runs (rows: runs in sample order)."""
    import twmr

    df = pd.read_parquet(folder / "runs.parquet").sort_values("sample").reset_index(drop=True)
    extra: list[dict[str, float]] = []
    series: dict[str, list[np.ndarray]] = {"ex": [], "ey": [], "tau": []}
    t = None
    for rid, status in zip(df["run_id"], df["status"], strict=False):
        if status != "ok":
            extra.append({})
            continue
        d = twmr.read_result(folder / "runs" / rid).data
        t = np.asarray(d["time"], dtype=float)
        ex = d["ref.position[1]"] - d["plant.pose[1]"]
        ey = d["ref.position[2]"] - d["plant.pose[2]"]
        tau = np.abs(np.c_[d["motor.torque[1]"], d["motor.torque[2]"]])
        v = R_WHEEL * (d["plant.wheel_speed[1]"] + d["plant.wheel_speed[2]"]) / 2.0
        late = t >= T_LATE
        row = {"torque_peak": float(tau.max()), "torque_rms": float(np.sqrt(np.mean(tau ** 2))),
               "late_ex": float(np.abs(ex[late]).max()), "late_ey": float(np.abs(ey[late]).max()),
               "backward": float(np.mean(v[t >= 5.0] < 0.0))}
        for band in BANDS:
            row[f"settle_x_{band:.2f}"] = settling(t, ex, band)
            row[f"settle_y_{band:.2f}"] = settling(t, ey, band)
        extra.append(row)
        series["ex"].append(ex)
        series["ey"].append(ey)
        series["tau"].append(tau.max(axis=1))
    df = pd.concat([df, pd.DataFrame(extra)], axis=1)
    arrays = {k: np.array(v) for k, v in series.items()}
    arrays["t"] = t if t is not None else np.zeros(0)
    return df, arrays


def cell(x: pd.Series, digits: int = 3) -> str:
    """median (5 %-95 %) over the finite values, with the count of finite ones if not all."""
    x = pd.to_numeric(x, errors="coerce")
    fin = x[np.isfinite(x)]
    if x.isna().all():
        return "—"
    if len(fin) == 0:
        return "never (inf)" if len(x) else "—"
    q = np.percentile(fin, [50, 5, 95])
    s = f"{q[0]:.{digits}g} ({q[1]:.{digits}g}–{q[2]:.{digits}g})"
    return s if len(fin) == len(x) else f"{s}, finite in {len(fin)}/{len(x)}"


def paired(a: pd.DataFrame, s: pd.DataFrame,
           keys: dict[str, str]) -> tuple[int, dict[str, int], int]:
    """Realisations where the ASMC's metric is lower, per metric and on all; and their count."""
    m = a.merge(s, on="sample", suffixes=("_a", "_s"))
    for col in ("plant.pose[1]", "slip.phase", "plant.internal_step"):
        assert np.allclose(m[col + "_a"].astype(float), m[col + "_s"].astype(float)), col
    ok = (m["status_a"] == "ok") & (m["status_s"] == "ok")
    win, per = ok.copy(), {}
    for label, col in keys.items():
        better = ok & (m[col + "_a"] < m[col + "_s"])
        per[label] = int(better.sum())
        win &= better
    return int(win.sum()), per, len(m)


def table3(runs: dict[tuple[str, str], pd.DataFrame]) -> list[str]:
    lines = []
    for variant in VARIANTS:
        a, s = runs[(variant, "trajectory1_asmc")], runs[(variant, "trajectory1_smc")]
        wins, per, n = paired(a, s, {k: k for k in KEYS})
        ok_a, ok_s = a[a["status"] == "ok"], s[s["status"] == "ok"]
        blank = pd.Series([np.nan])
        lines += [f"### Trajectory 1, {variant.replace('_', ' ')}", "",
                  f"{n} realisations; failed runs: ASMC {n - len(ok_a)}, SMC {n - len(ok_s)}. "
                  f"ASMC lower than SMC on all six metrics in **{wins}/{n}**.", "",
                  "| metric | paper ASMC | paper SMC | ASMC | SMC | ASMC lower in |",
                  "|---|---|---|---|---|---|"]
        for i, k in enumerate(KEYS):
            lines.append(f"| {k} | {PAPER['asmc'][i]} | {PAPER['smc'][i]} | {cell(ok_a[k])} | "
                         f"{cell(ok_s[k])} | {per[k]}/{n} |")
        for k, label in (("torque_peak_1ms", "peak applied torque, every 1 ms step [N·m]"),
                         ("torque_peak", "peak applied torque, 10 ms rows [N·m]"),
                         ("torque_rms", "RMS applied torque [N·m]")):
            lines.append(f"| {label} | — | — | {cell(ok_a.get(k, blank))} | "
                         f"{cell(ok_s.get(k, blank))} | |")
        lines += ["", "Settling band sensitivity (same runs; settling times recomputed):", "",
                  "| band [m] | ASMC settling x | SMC settling x | ASMC settling y | "
                  "SMC settling y "
                  "| ASMC lower on all six |", "|---|---|---|---|---|---|"]
        for band in BANDS:
            keys = {k: k for k in KEYS if not k.startswith("settling")}
            keys.update({"sx": f"settle_x_{band:.2f}", "sy": f"settle_y_{band:.2f}"})
            w, _, _ = paired(a, s, keys)
            sx, sy = f"settle_x_{band:.2f}", f"settle_y_{band:.2f}"
            lines.append(f"| {band:.2f} | {cell(ok_a[sx])} | {cell(ok_s[sx])} | {cell(ok_a[sy])}"
                         f" | {cell(ok_s[sy])} | {w}/{n} |")
        lines.append("")
    return lines


def circle(runs: dict[tuple[str, str], pd.DataFrame]) -> list[str]:
    lines = ["### Circle", "", "| variant | failed | max abs e_x, t >= 10 s [m] | max abs e_y, "
             "t >= 10 s [m] | within 0.07 m | peak torque, 10 ms rows [N·m] | peak torque, "
             "every 1 ms step [N·m] | RMS torque [N·m] |", "|---|---|---|---|---|---|---|---|"]
    for variant in VARIANTS:
        c = runs[(variant, "circle_asmc")]
        ok = c[c["status"] == "ok"]
        passed = int(((ok["late_ex"] <= E_CIRCLE) & (ok["late_ey"] <= E_CIRCLE)).sum())
        lines.append(f"| {variant.replace('_', ' ')} | {len(c) - len(ok)}/{len(c)} | "
                     f"{cell(ok['late_ex'])} | {cell(ok['late_ey'])} | {passed}/{len(c)} | "
                     f"{cell(ok['torque_peak'])} | "
                     f"{cell(ok.get('torque_peak_1ms', pd.Series([np.nan])))} | "
                     f"{cell(ok['torque_rms'])} |")
    lines += ["", "### Driving direction (share of t >= 5 s with M moving backwards)", "",
              "| run | bounded | as printed |", "|---|---|---|"]
    for name in SWEEPS:
        cells = []
        for variant in VARIANTS:
            b = runs[(variant, name)]
            cells.append(cell(b.loc[b["status"] == "ok", "backward"], 2))
        lines.append(f"| {name} | {cells[0]} | {cells[1]} |")
    return [*lines, ""]


def sensitivity(fixed: dict[str, pd.DataFrame], runs: dict[tuple[str, str], pd.DataFrame]
                ) -> list[str]:
    """Trajectory 1 ASMC: the spread over start and plant step alone (slip phase fixed at 0),
    against the spread when the phase varies too."""
    lines = ["### Sensitivity: start and plant step alone (slip phase 0)", "",
             "| configuration | failed | mse_x, phase 0 | max/min, phase 0 | mse_x, phase varied "
             "| max/min, phase varied |", "|---|---|---|---|---|---|"]
    for variant in VARIANTS:
        cells = []
        for df in (fixed[variant], runs[(variant, "trajectory1_asmc")]):
            x = df.loc[df["status"] == "ok", "mse_x"]
            cells += [cell(x), f"{x.max() / x.min():.4f}" if len(x) else "—"]
        f = fixed[variant]
        lines.append(f"| {variant.replace('_', ' ')} | {int((f['status'] != 'ok').sum())}/{len(f)} "
                     f"| {' | '.join(cells)} |")
    return [*lines, ""]


def band_figure(series: dict[str, dict[str, np.ndarray]], names: list[tuple[str, str]],
                title: str, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for (key, label), color in zip(names, ("tab:blue", "tab:red"), strict=False):
        s = series[key]
        if len(s["ex"]) == 0:
            continue
        for ax, what, ylabel in zip(axes, ("ex", "ey", "tau"),
                                    ("e_x [m]", "e_y [m]", "max |tau| [N·m]"), strict=False):
            lo, med, hi = np.percentile(s[what], [5, 50, 95], axis=0)
            ax.fill_between(s["t"], lo, hi, color=color, alpha=0.25, lw=0)
            ax.plot(s["t"], med, color=color, lw=1, label=f"{label}: median, 5–95 % band")
            ax.set_ylabel(ylabel)
            ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title(title, fontsize=10)
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(samples: int = 100) -> None:
    t0 = time.perf_counter()
    runs, series = {}, {}
    for variant in VARIANTS:
        for name in SWEEPS:
            folder = run_sweep(name, variant, samples)
            runs[(variant, name)], series[(variant, name)] = per_run(folder)
            if variant == "as_printed":
                runs[(variant, name)] = runs[(variant, name)].merge(
                    fine_torque(name, variant, samples), on="sample", how="left")
    text = ["# Numbers of docs/reproduction.md", "",
            "Generated by `.venv/bin/python docs/reproduction/regenerate.py`; do not edit. "
            "Cells: median (5 %–95 %) over the realisations that ran.", ""]
    fixed = {v: per_run(run_sweep("trajectory1_asmc", v, samples, fixed_phase=True))[0]
             for v in VARIANTS}
    text += table3(runs) + sensitivity(fixed, runs) + circle(runs)
    wall = time.perf_counter() - t0
    text += [f"Wall time of this call of regenerate.py, measured by it: {wall / 60:.1f} min on "
             f"{os.cpu_count()} cores (sweep folders already complete in $REPRO_OUT are read, "
             f"not run again).", ""]
    (HERE / "numbers.md").write_text("\n".join(text))
    print("\n".join(text))
    FIGS.mkdir(parents=True, exist_ok=True)
    for variant in VARIANTS:
        band_figure({"a": series[(variant, "trajectory1_asmc")],
                     "s": series[(variant, "trajectory1_smc")]},
                    [("a", "ASMC"), ("s", "SMC")],
                    f"Trajectory 1, {variant.replace('_', ' ')}: 100 realisations",
                    FIGS / f"trajectory1_{variant}.png")
        band_figure({"c": series[(variant, "circle_asmc")]}, [("c", "ASMC")],
                    f"Circle, {variant.replace('_', ' ')}: 100 realisations",
                    FIGS / f"circle_{variant}.png")
    print(f"wall time: {time.perf_counter() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:2]))
