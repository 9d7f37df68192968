"""PNG plots of recorded signals: one figure per recorded port (vector elements together), and an
XY plot for every recorded planar position (a port with 2 or 3 elements in m, m[, rad])."""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np


def pyplot() -> Any:  # matplotlib without a screen
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def group_ports(names: list[str]) -> dict[str, list[str]]:
    """Columns grouped by port: 'a.p[1]', 'a.p[2]' -> {'a.p': [...]}; time left out."""
    groups: dict[str, list[str]] = {}
    for n in names:
        if n == "time":
            continue
        groups.setdefault(re.sub(r"\[\d+\]$", "", n), []).append(n)
    return groups


def plot_timing(lateness_us: np.ndarray, period_s: float, path: str | Path,
                title: str = "") -> Path:
    """A paced run's step lateness [us] over time and its histogram, the period marked."""
    plt = pyplot()
    late = np.asarray(lateness_us, dtype=float)
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.5), gridspec_kw={"width_ratios": [2, 1]})
    a.plot(np.arange(late.size) * period_s, late, lw=0.6)
    a.axhline(period_s * 1e6, color="r", lw=0.8, label=f"one period ({period_s * 1e6:g} us)")
    a.set_xlabel("time [s]")
    a.set_ylabel("release past deadline [us]")
    a.set_yscale("symlog", linthresh=10.0)
    a.legend(fontsize=8)
    a.grid(True, alpha=0.3)
    b.hist(late, bins=np.logspace(-2, max(1.0, np.log10(max(late.max(), 1.0)) + 0.1), 60))
    b.set_xscale("log")
    b.set_yscale("log")
    b.set_xlabel("lateness [us]")
    b.grid(True, alpha=0.3)
    fig.suptitle(f"{title} pacing: p99 {np.percentile(late, 99):.1f} us, max {late.max():.0f} us"
                 .strip())
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def plot_result(data: np.ndarray, units: dict[str, str], out_dir: str | Path,
                title: str = "") -> list[Path]:
    """Write one PNG per port (and XY plots) into `out_dir`; the paths written."""
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t = np.asarray(data["time"])
    written = []
    for port, cols in group_ports(list(data.dtype.names or ())).items():
        fig, ax = plt.subplots(figsize=(7, 3.5))
        for c in cols:
            ax.plot(t, data[c], label=f"{c} [{units.get(c, '')}]")
        ax.set_xlabel("time [s]")
        ax.set_title(f"{title} {port}".strip())
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        path = out / f"{port.replace('.', '_')}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
        if len(cols) in (2, 3) and all(units.get(c) == "m" for c in cols[:2]):
            fig, ax = plt.subplots(figsize=(5, 5))
            ax.plot(data[cols[0]], data[cols[1]])
            ax.set_xlabel(f"{cols[0]} [m]")
            ax.set_ylabel(f"{cols[1]} [m]")
            ax.set_aspect("equal", adjustable="datalim")
            ax.grid(True, alpha=0.3)
            ax.set_title(f"{title} {port} (XY)".strip())
            fig.tight_layout()
            path = out / f"{port.replace('.', '_')}_xy.png"
            fig.savefig(path, dpi=110)
            plt.close(fig)
            written.append(path)
    return written
