"""What the clamp |e_p1| >= eps_singular in kappa does (docs/model.md, section 3.4): how often it is
active, and what it does to the controller's estimate of x1' against eq. (15) with the real e_p1.
Writes docs/studies/clamp_numbers.md and docs/figures/studies/clamp_*.png; prints its wall time.

    .venv/bin/python docs/studies/clamp.py

One run each of trajectory 1 and the circle (the paper scenarios, slip phase 0), recorded every
1 ms, for each configuration of CONFIGS. From the recorded pose, wheel speeds and reference:
- active: the share of t >= 2 s with |e_p1| < eps_singular (e_p1 = ctrl.error[1], of M);
- the lateral x1' (= e_p2', the look-ahead point moves rigidly with the body) three ways: the
  law's, -omega clamp(e_p1) + [R(theta) p_T']_2 (kappa with the clamped e_p1, slip dropped);
  eq. (15) with the real e_p1 and the slip dropped, -omega e_p1 + [R(theta) p_T']_2; and the
  true one, the central difference of the recorded e_p2 (it sees the slip);
- for each estimate: its correlation with the true one and its RMS error over t >= 2 s.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIGS = ROOT / "docs" / "figures" / "studies"
R_WHEEL, B_HALF = 0.15, 0.75  # [m], Table I
T0 = 2.0  # [s] after the start transient
SIGNALS = ["ref.position", "ref.velocity", "plant.pose", "plant.wheel_speed", "ctrl.error",
           "ctrl.torque", "ctrl.d_hat"]
CONFIGS = {
    "as shipped": [],
    "before the tune (eta 0.1, eps 0.5, L 0.05, phi 0.2, Table II gains)":
        ["ctrl.eta=0.1", "ctrl.eps_singular=0.5", "ctrl.lookahead=0.05", "ctrl.phi=0.2",
         "ctrl.lam=13", "ctrl.vartheta=20", "ctrl.k=20", "ctrl.d_hat_limit=0",
         "ctrl.hold_saturated=true", "ctrl.drive=backward"],
}
SCENARIOS = {"trajectory 1": "paper_trajectory1_asmc.yaml", "circle": "paper_circle_asmc.yaml"}


def fine_copy(name: str, folder: Path) -> Path:
    """The paper scenario recorded every step with the signals this study reads."""
    data = yaml.safe_load((ROOT / "scenarios" / name).read_text(encoding="utf-8"))
    data["record"] = {"signals": SIGNALS, "decimation": 1}
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return path


def analyse(data: dict, eps: float) -> tuple[dict[str, float], tuple]:
    t = np.asarray(data["time"], dtype=float)
    th = np.asarray(data["plant.pose[3]"])
    e1, e2 = np.asarray(data["ctrl.error[1]"]), np.asarray(data["ctrl.error[2]"])
    omega = R_WHEEL * (np.asarray(data["plant.wheel_speed[1]"]) -
                       np.asarray(data["plant.wheel_speed[2]"])) / (2 * B_HALF)
    vT2 = -np.sin(th) * data["ref.velocity[1]"] + np.cos(th) * data["ref.velocity[2]"]
    clamped = np.where(np.abs(e1) >= eps, e1, np.where(e1 >= 0, eps, -eps))
    law = -omega * clamped + vT2
    eq15 = -omega * e1 + vT2
    true = np.gradient(e2, t)
    late = t >= T0
    out = {"active": float(np.mean(np.abs(e1[late]) < eps)),
           "e1_median": float(np.median(e1[late])),
           "abs_e1_p95": float(np.percentile(np.abs(e1[late]), 95))}
    for name, est in (("law", law), ("eq15", eq15)):
        out[f"corr_{name}"] = float(np.corrcoef(est[late], true[late])[0, 1])
        out[f"rms_{name}"] = float(np.sqrt(np.mean((est[late] - true[late]) ** 2)))
    out["rms_true"] = float(np.sqrt(np.mean(true[late] ** 2)))
    out["rms_clamp"] = float(np.sqrt(np.mean((law[late] - eq15[late]) ** 2)))
    out["d_hat1_mean"] = float(np.mean(np.asarray(data["ctrl.d_hat[1]"])[t >= 10.0]))
    out["torque_peak"] = float(np.max(np.abs([data["ctrl.torque[1]"], data["ctrl.torque[2]"]])))
    return out, (t, e1, law, eq15, true)


def figure(series: tuple, eps: float, title: str, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, e1, law, eq15, true = series
    window = (t >= 10.0) & (t <= 16.0)
    fig, axes = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    axes[0].plot(t[window], e1[window], lw=1, label="e_p1 of M")
    for sign in (1, -1):
        axes[0].axhline(sign * eps, color="grey", ls=":", lw=1)
    axes[0].set_ylabel("e_p1 [m]")
    axes[0].legend(fontsize=8, loc="upper right")
    axes[1].plot(t[window], true[window], color="black", lw=1, label="true e_p2' (difference)")
    axes[1].plot(t[window], law[window], lw=1, label="the law's estimate (clamped kappa)")
    axes[1].plot(t[window], eq15[window], lw=1, ls="--", label="eq. (15), real e_p1, no slip")
    axes[1].set_ylabel("lateral x1' [m/s]")
    axes[1].set_xlabel("t [s]")
    axes[1].legend(fontsize=8, loc="upper right")
    axes[0].set_title(title, fontsize=10)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> None:
    import twmr

    t0 = time.perf_counter()
    lines = ["# Numbers of the clamp of kappa (docs/model.md, section 3.4)", "",
             "Generated by `.venv/bin/python docs/studies/clamp.py`; do not edit. One run each "
             f"(slip phase 0), recorded every 1 ms; figures over t >= {T0:g} s.", "",
             "| configuration | run | eps_singular [m] | clamp active | median e_p1 [m] | "
             "95 % of abs e_p1 [m] | corr. law / true | corr. eq. 15 / true | RMS err. law "
             "[m/s] | RMS err. eq. 15 [m/s] | RMS true [m/s] | RMS law - eq. 15 [m/s] | "
             "mean d_hat_1, t >= 10 s [m/s²] | peak command torque, 1 ms [N·m] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    FIGS.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for c, (config, sets) in enumerate(CONFIGS.items()):
            for label, name in SCENARIOS.items():
                scenario = twmr.load(fine_copy(name, Path(tmp)), sets)
                eps = float(scenario.system.components["ctrl"].get("eps_singular"))
                data = twmr.simulate(scenario).data
                f, series = analyse(data, eps)
                lines.append(
                    f"| {config} | {label} | {eps:.3g} | {f['active']:.1%} | "
                    f"{f['e1_median']:.3g} | {f['abs_e1_p95']:.3g} | {f['corr_law']:.2f} | "
                    f"{f['corr_eq15']:.2f} | {f['rms_law']:.3g} | {f['rms_eq15']:.3g} | "
                    f"{f['rms_true']:.3g} | {f['rms_clamp']:.3g} | {f['d_hat1_mean']:.3g} | "
                    f"{f['torque_peak']:.3g} |")
                figure(series, eps, f"{label}, {config}",
                       FIGS / f"clamp_{c}_{label.replace(' ', '')}.png")
    wall = time.perf_counter() - t0
    lines += ["", f"Wall time of this script, measured by it: {wall:.0f} s.", ""]
    (HERE / "clamp_numbers.md").write_text("\n".join(lines), encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
