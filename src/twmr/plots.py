"""Report-ready figures of recorded signals, PNG and SVG: one figure per recorded port (an axis per
unit, elements named from the port's description), one XY figure of every recorded planar
position (`is_planar_position`: the robot's pose and its reference), and a
paced run's timing. The style (`COLOURS`, `line_style`, `legend_outside`, `save`) is shared by
`twmr compare` and the sweep report."""
from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

#: Okabe and Ito's colour-blind-safe palette; past 8 lines the dash pattern changes too
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000",
           "#F0E442")
DASHES = ("-", "--", ":", "-.")
STEPWISE_TYPES = ("Integer", "Boolean", "Enumeration")


def pyplot() -> Any:  # matplotlib without a screen
    from twmr.core.extras import require

    matplotlib = require("matplotlib", "plotting")

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def line_style(i: int) -> dict[str, Any]:
    """Colour and dashes of the i-th line of a figure: distinct for the first 32."""
    return {"color": COLOURS[i % len(COLOURS)], "linestyle": DASHES[i // len(COLOURS) % 4]}


def legend_outside(ax: Any) -> None:
    """The legend to the right of the axes, off the data."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)


def save(fig: Any, path: str | Path) -> list[Path]:
    """Write `fig` as PNG and SVG (`path` with each suffix) and close it; both paths."""
    plt = pyplot()
    base = Path(path).with_suffix("")
    base.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    written = []
    for suffix in (".png", ".svg"):
        fig.savefig(base.with_suffix(suffix), dpi=150, bbox_inches="tight")
        written.append(base.with_suffix(suffix))
    plt.close(fig)
    return written


def axis_label(name: str, unit: str) -> str:
    """'plant.pose [m]'; a signal without a unit has no brackets."""
    return f"{name} [{unit}]" if unit else name


def group_ports(names: list[str]) -> dict[str, list[str]]:
    """Columns grouped by port: 'a.p[1]', 'a.p[2]' -> {'a.p': [...]}; time left out."""
    groups: dict[str, list[str]] = {}
    for n in names:
        if n == "time":
            continue
        groups.setdefault(re.sub(r"\[\d+\]$", "", n), []).append(n)
    return groups


def element_names(port: str, columns: list[str], description: str) -> list[str]:
    """Names of a port's recorded elements: those its description lists in parentheses when
    they match in number ('(x_M, y_M, theta)'), else the column names."""
    found = re.search(r"\(([^()]*)\)", description or "")
    names = [n.strip() for n in found.group(1).split(",")] if found else []
    if len(columns) > 1 and len(names) == len(columns) and all(names):
        return names
    return [port] if len(columns) == 1 else columns


def is_stepwise(values: np.ndarray, port_type: str = "") -> bool:
    """Whether a signal is piecewise constant (drawn as steps): an integer, boolean or
    enumeration port, or one that changes at no more than a tenth of its samples."""
    if port_type in STEPWISE_TYPES:
        return True
    v = np.asarray(values, dtype=float)
    if v.size < 3:
        return False
    changes = np.count_nonzero(np.diff(v))
    return bool(0 < changes <= 0.1 * (v.size - 1))


def is_planar_position(port: str, units: list[str]) -> bool:
    """A pose (m, m, rad), or a position in the plane (m, m) whose name says so (`position`,
    `pos`, `path`, `xy`, `point`): the lines of the XY figure. An error in m, m is not one."""
    if units == ["m", "m", "rad"]:
        return True
    name = port.rpartition(".")[2].lower()
    return units == ["m", "m"] and re.search(r"pos|path|xy|point", name) is not None


def event_marks(summary: Mapping[str, Any]) -> list[tuple[float, str]]:
    """(time, text) of each event of a run's summary, in time order: a parameter set, a fault's
    start and end, each firing of a condition event."""
    marks: list[tuple[float, str]] = []
    for event in summary.get("events") or []:
        what = f"{event.get('port')} {event.get('fault')}"
        marks.append((float(event["at"]), what))
        if event.get("until") is not None:
            marks.append((float(event["until"]), f"{what} ends"))
    for fired in summary.get("fired") or []:  # condition events, as they happened
        what = f"{fired.get('target')} {fired.get('action')}"
        marks.append((float(fired["at"]), f"{what} ({fired.get('when')})"))
        if fired.get("until") is not None and math.isfinite(float(fired["until"])):
            marks.append((float(fired["until"]), f"{what} ends"))
    return sorted(marks)


def plot_result(data: np.ndarray, units: Mapping[str, str], out_dir: str | Path,
                title: str = "", ports: Mapping[str, Mapping[str, Any]] | None = None,
                marks: list[tuple[float, str]] | None = None) -> list[Path]:
    """Write the figures of a result (`result_figures`) into `out_dir`: `<port>.png/.svg` per
    recorded port and `xy.png/.svg` when a planar position is recorded; the paths written."""
    written: list[Path] = []
    for name, fig in result_figures(data, units, title, ports, marks).items():
        written += save(fig, Path(out_dir) / f"{name}.png")
    return written


def _mark(ax: Any, marks: list[tuple[float, str]] | None) -> None:
    """Events as vertical lines with their text."""
    for t, text in marks or []:
        ax.axvline(t, lw=0.8, color="#D55E00", alpha=0.7)
        ax.annotate(text, (t, 1.0), xycoords=("data", "axes fraction"), fontsize=7,
                    rotation=90, va="top", ha="right", color="#D55E00")


def result_figures(data: np.ndarray, units: Mapping[str, str], title: str = "",
                   ports: Mapping[str, Mapping[str, Any]] | None = None,
                   marks: list[tuple[float, str]] | None = None) -> dict[str, Any]:
    """The matplotlib figures of a result by file name ('plant_pose', 'xy'). `ports` gives each
    port's description, type and limits (a run's summary holds them), drawn dashed; `marks`
    ([(time, text)], `event_marks`) the events, as vertical lines."""
    plt = pyplot()
    ports = ports or {}
    t = np.asarray(data["time"])
    figures: dict[str, Any] = {}
    planar = []
    for port, cols in group_ports(list(data.dtype.names or ())).items():
        info = ports.get(port, {})
        names = dict(zip(cols, element_names(port, cols, info.get("description", "")),
                         strict=True))
        by_unit: dict[str, list[str]] = {}
        for c in cols:
            by_unit.setdefault(units.get(c, ""), []).append(c)
        fig, axes = plt.subplots(len(by_unit), 1, sharex=True, squeeze=False,
                                 figsize=(7.5, 2.2 + 1.6 * len(by_unit)))
        i = 0
        for ax, (unit, members) in zip(axes[:, 0], by_unit.items(), strict=True):
            for c in members:
                steps = "steps-post" if is_stepwise(data[c], info.get("type", "")) else "default"
                ax.plot(t, data[c], label=names[c], drawstyle=steps, lw=1.2, **line_style(i))
                i += 1
            for value in info.get("limits") or ():
                ax.axhline(value, ls="--", lw=0.8, color="0.4")
            _mark(ax, marks)
            ax.set_ylabel(axis_label(port, unit))
            ax.grid(True, alpha=0.3)
            if len(cols) > 1:
                legend_outside(ax)
        axes[-1, 0].set_xlabel("time [s]")
        what = f"{port}: {info['description']}" if info.get("description") else port
        span = f" over {t[-1] - t[0]:.3g} s" if len(t) > 1 else ""
        axes[0, 0].set_title(f"{f'{title}: ' if title else ''}{what}{span}", fontsize=10)
        figures[port.replace(".", "_")] = fig
        if is_planar_position(port, [units.get(c, "") for c in cols]):
            planar.append((port, cols))
    if planar:
        figures["xy"] = _plot_xy(data, planar, ports, title)
    if len(planar) > 1:
        figures["xy_time"] = _plot_xy_time(data, planar, ports, title, marks)
    return figures


def _plot_xy_time(data: np.ndarray, planar: list[tuple[str, list[str]]],
                  ports: Mapping[str, Mapping[str, Any]], title: str,
                  marks: list[tuple[float, str]] | None) -> Any:
    """x and y of every planar position over time, together (the tracked path on its
    reference)."""
    plt = pyplot()
    t = np.asarray(data["time"])
    fig, axes = plt.subplots(2, 1, sharex=True, figsize=(7.5, 5.2))
    for k, (ax, axis) in enumerate(zip(axes, ("x", "y"), strict=True)):
        for i, (port, cols) in enumerate(planar):
            description = ports.get(port, {}).get("description", "")
            ax.plot(t, data[cols[k]], lw=1.2, label=f"{port}: {description}" if description
                    else port, **line_style(i))
        _mark(ax, marks)
        ax.set_ylabel(f"{axis} [m]")
        ax.grid(True, alpha=0.3)
    legend_outside(axes[0])
    axes[1].set_xlabel("time [s]")
    names = " and ".join(p for p, _ in planar)
    axes[0].set_title(f"{f'{title}: ' if title else ''}{names} over time", fontsize=10)
    return fig


def _plot_xy(data: np.ndarray, planar: list[tuple[str, list[str]]],
             ports: Mapping[str, Mapping[str, str]], title: str) -> Any:
    """Every planar position in one XY figure, equal axes (the path with its reference)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 5.5))
    for i, (port, cols) in enumerate(planar):
        description = ports.get(port, {}).get("description", "")
        label = f"{port}: {description}" if description else port
        ax.plot(data[cols[0]], data[cols[1]], label=label, lw=1.4, **line_style(i))
        ax.plot(data[cols[0]][:1], data[cols[1]][:1], "o", ms=4, color=line_style(i)["color"])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    legend_outside(ax)
    names = " and ".join(p for p, _ in planar)
    ax.set_title(f"{f'{title}: ' if title else ''}{names} in the plane (dots: start)",
                 fontsize=10)
    return fig


def duration_text(us: float) -> str:
    """A duration [us] rounded to 3 significant digits in us, ms or s."""
    for scale, unit in ((1e6, "s"), (1e3, "ms")):
        if abs(us) >= scale:
            return f"{us / scale:.3g} {unit}"
    return f"{us:.3g} us"


def plot_timing(lateness_us: np.ndarray, period_s: float, path: str | Path,
                title: str = "") -> Path:
    """A paced run's step lateness (release past its deadline) over time and its distribution,
    the period marked; the PNG written (an SVG beside it)."""
    plt = pyplot()
    late = np.asarray(lateness_us, dtype=float)
    big = late.size and np.nanmax(np.abs(late)) >= 1e3
    scale, unit = (1e3, "ms") if big else (1.0, "us")
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.8), gridspec_kw={"width_ratios": [2, 1]})
    a.plot(np.arange(late.size) * period_s, late / scale, lw=0.6, **line_style(0))
    a.axhline(period_s * 1e6 / scale, lw=0.9, label=f"one period ({duration_text(period_s * 1e6)})",
              **line_style(1))
    a.set_xlabel("time [s]")
    a.set_ylabel(f"lateness [{unit}]")
    a.grid(True, alpha=0.3)
    a.legend(fontsize=8, loc="upper right")
    positive = late[late > 0]
    if positive.size:
        top = np.log10(max(positive.max(), 1.0)) + 0.1
        b.hist(positive / scale, bins=np.logspace(-2, top, 60) / scale, **line_style(0))
        b.set_xscale("log")
        b.set_yscale("log")
    b.set_xlabel(f"lateness [{unit}]")
    b.set_ylabel("steps")
    b.grid(True, alpha=0.3)
    if late.size:
        fig.suptitle(f"{f'{title}: ' if title else ''}99 % of the steps started within "
                     f"{duration_text(float(np.percentile(late, 99)))} of their deadline; the "
                     f"latest {duration_text(float(late.max()))}", fontsize=10)
    return save(fig, path)[0]


def panels_of(spec: str, columns: list[str]) -> list[list[str]]:
    """The panels of an overlay from '--signals' text: panels separated by commas, the signals
    of one panel by '+'; a vector port stands for its elements ('plant.pose' ->
    'plant.pose[1]', ...), each element in a panel of its own unless joined by '+'. KeyError
    naming a signal that no result has."""
    panels: list[list[str]] = []
    for part in (p.strip() for p in spec.split(",")):
        if not part:
            continue
        members = [m.strip() for m in part.split("+") if m.strip()]
        expanded = [_columns_of(m, columns) for m in members]
        if len(members) == 1:
            panels += [[c] for c in expanded[0]]
        else:  # a+b: element i of each together
            for row in zip(*expanded, strict=False):
                panels.append(list(row))
    return panels


def port_columns(name: str, columns: list[str]) -> list[str]:
    """`name` as the columns it is: itself, or the elements of a vector port ('plant.pose' ->
    'plant.pose[1]', ...); [] when neither is recorded."""
    if name in columns:
        return [name]
    return [c for c in columns if c.startswith(f"{name}[") and c.endswith("]")]


def _columns_of(name: str, columns: list[str]) -> list[str]:
    found = port_columns(name, columns)
    if not found:
        from twmr.registry import suggest

        raise KeyError(f"no signal '{name}'{suggest(name, sorted(group_ports(columns)))}")
    return found


def spans_decades(values: Any, decades: float = 2.0) -> bool:
    """Whether `values` (their finite ones) are all positive and span more than `decades`
    powers of ten: drawn on a log axis, so that one large value does not flatten the rest."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    return bool(v.size > 1 and np.all(v > 0) and v.max() / v.min() > 10.0 ** decades)


def overlay_figure(results: list[tuple[str, Any]], panels: list[list[str]],
                   marks: list[tuple[float, str]] | None = None) -> Any:
    """One figure, a panel per entry of `panels` (its signals together), every result
    (label, `Result`) drawn in each with its own line style; the limits of each port (the
    results' summaries) as dashed lines, `marks` ([(time, text)]: events) as vertical lines."""
    plt = pyplot()
    fig, axes = plt.subplots(len(panels), 1, sharex=True, squeeze=False,
                             figsize=(8, 1.2 + 1.9 * len(panels)))
    for ax, panel in zip(axes[:, 0], panels, strict=True):
        i = 0
        units = set()
        for label, result in results:
            for signal in panel:
                if signal not in result.columns:
                    continue
                units.add(result.units.get(signal, ""))
                name = signal if len(results) == 1 else f"{label}: {signal}"
                ax.plot(result.time, result[signal], lw=1.2, label=name, **line_style(i))
                i += 1
        drawn = {v for _, r in results for s in panel
                 for v in (r.summary.get("ports", {}).get(s.partition("[")[0], {})
                           .get("limits") or ())}
        for value in drawn:
            ax.axhline(value, ls="--", lw=0.8, color="0.4")
        _mark(ax, marks)
        unit = units.pop() if len(units) == 1 else ""
        ax.set_ylabel(axis_label(" + ".join(panel) if len(panel) < 3 else panel[0], unit),
                      fontsize=8)
        ax.grid(True, alpha=0.3)
        if i > 1:
            ax.legend(fontsize=7, frameon=False)
        if spans_decades(np.concatenate([r[s] for _, r in results for s in panel
                                         if s in r.columns] or [np.zeros(1)])):
            ax.set_yscale("log")
    axes[-1, 0].set_xlabel("time [s]")
    return fig
