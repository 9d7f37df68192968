"""The paper's robot under faults (docs/events.md): a payload put on at 10 s, the encoders
dropping out for 0.5 s, a sweep of that dropout's time over the run, and a lost torque frame on
the emulated ODrive bench. Writes docs/studies/faults_numbers.md and
docs/figures/studies/faults_*.png; prints its wall time.

    .venv/bin/python docs/studies/faults.py

- payload: trajectory 1 (the shipped ASMC) with `set plant.scale 1.25 -> 1.75` at 10 s against
  the same run without it: the tracking error |e| (ctrl.error, of the look-ahead point) over
  time; its mean and worst after 10 s.
- dropout: the encoder scenario (paper_trajectory1_asmc_sensors.yaml) with encoder.speed
  dropped to 0 from 10 to 10.5 s (the controller reads no wheel speed), and frozen instead.
- sweep: that dropout at each whole second from 2 to 28 s: the worst |e| after it and |e| at
  the end (30 s), against the run without a fault; a timing "breaks tracking" when |e| at the
  end is above 0.07 m (the paper's band).
- lost frame: the bench scenario (bench_odrive_trajectory1.yaml, two emulated ODrives 0.6.10 on
  a can_bus block, the host's own watchdog at 100 periods so the drive's trips first) with node
  0's Set_Input_Torque lost from 2 s: when the drive's watchdog (0.1 s, set by the host)
  expires, its heartbeat's axis error and state, and how the host ends the run; read from the
  bus's frame log with cantools and the firmware's DBC.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIGS = ROOT / "docs" / "figures" / "studies"
SCENARIOS = ROOT / "scenarios"
BAND = 0.07  # [m]
PAYLOAD = "  - {at: 10.0, set: plant.scale, value: 1.75}\n"
DROPOUT = "  - {at: %g, until: %g, port: encoder.speed, fault: %s}\n"


def with_events(name: str, events: str, folder: Path, tag: str, decimation: int = 10) -> Path:
    text = (SCENARIOS / name).read_text(encoding="utf-8")
    text = text.replace("decimation: 10", f"decimation: {decimation}")
    path = folder / f"{tag}.yaml"
    path.write_text(text + (f"events:\n{events}" if events else ""), encoding="utf-8")
    return path


def error_norm(result: object) -> tuple[np.ndarray, np.ndarray]:
    t = np.asarray(result["time"])  # type: ignore[index]
    e = np.hypot(result["ctrl.error[1]"], result["ctrl.error[2]"])  # type: ignore[index]
    return t, e


def payload(folder: Path, plt: object, lines: list[str]) -> None:
    import twmr

    runs = {label: error_norm(twmr.simulate(with_events("paper_trajectory1_asmc.yaml", ev,
                                                        folder, tag)))
            for label, ev, tag in (("no payload", "", "plain"),
                                   ("payload from 10 s (scale 1.25 -> 1.75)", PAYLOAD, "load"))}
    lines += ["## Payload at 10 s", "", "| run | mean \\|e\\| after 10 s [m] | worst after 10 s "
              "[m] | \\|e\\| at 30 s [m] |", "|---|---|---|---|"]
    fig, ax = plt.subplots(figsize=(8, 3.2))  # type: ignore[attr-defined]
    for label, (t, e) in runs.items():
        after = t >= 10.0
        lines.append(f"| {label} | {e[after].mean():.4f} | {e[after].max():.4f} | "
                     f"{e[-1]:.4f} |")
        ax.plot(t, e, lw=0.9, label=label)
    ax.axvline(10.0, color="#999999", lw=0.6, ls="--")
    finish(ax, fig, "faults_payload", "tracking error |e| [m]")
    lines.append("")


def dropout(folder: Path, plt: object, lines: list[str]) -> None:
    import twmr

    name = "paper_trajectory1_asmc_sensors.yaml"
    runs = {"no fault": "", "encoders drop out 10-10.5 s": DROPOUT % (10.0, 10.5, "dropout"),
            "encoders freeze 10-10.5 s": DROPOUT % (10.0, 10.5, "freeze")}
    lines += ["## Encoders lost for 0.5 s at 10 s", "", "| run | worst \\|e\\| after 10 s [m] | "
              "\\|e\\| at 30 s [m] |", "|---|---|---|"]
    fig, ax = plt.subplots(figsize=(8, 3.2))  # type: ignore[attr-defined]
    for k, (label, ev) in enumerate(runs.items()):
        t, e = error_norm(twmr.simulate(with_events(name, ev, folder, f"drop{k}")))
        after = t >= 10.0
        lines.append(f"| {label} | {e[after].max():.4f} | {e[-1]:.4f} |")
        ax.plot(t, e, lw=0.9, label=label)
    ax.axvspan(10.0, 10.5, color="#E69F00", alpha=0.2, lw=0)
    finish(ax, fig, "faults_dropout", "tracking error |e| [m]")
    lines.append("")


def sweep(folder: Path, plt: object, lines: list[str]) -> None:
    import twmr

    name = "paper_trajectory1_asmc_sensors.yaml"
    _, e0 = error_norm(twmr.simulate(with_events(name, "", folder, "base")))
    starts = np.arange(2.0, 29.0, 1.0)
    worst, end = [], []
    for s in starts:
        t, e = error_norm(twmr.simulate(with_events(name, DROPOUT % (s, s + 0.5, "dropout"),
                                                    folder, "sweep")))
        worst.append(e[t >= s].max())
        end.append(e[-1])
    broken = [f"{s:g}" for s, x in zip(starts, end, strict=True) if x > BAND]
    lines += ["## When a 0.5 s encoder dropout breaks tracking", "",
              f"Without a fault |e| at 30 s is {e0[-1]:.4f} m. A dropout from each whole "
              f"second s to s + 0.5 s:", "", "| start s [s] | worst \\|e\\| after s [m] | "
              "\\|e\\| at 30 s [m] |", "|---|---|---|"]
    lines += [f"| {s:g} | {w:.4f} | {x:.4f} |" for s, w, x in zip(starts, worst, end,
                                                                   strict=True)]
    lines += ["", f"Timings that leave |e| above {BAND} m at 30 s: "
              f"{', '.join(broken) if broken else 'none'} ({len(broken)} of {len(starts)}).", ""]
    fig, ax = plt.subplots(figsize=(8, 3.2))  # type: ignore[attr-defined]
    ax.plot(starts, worst, "o-", ms=3, lw=0.9, label="worst |e| after the dropout")
    ax.plot(starts, end, "s-", ms=3, lw=0.9, label="|e| at 30 s")
    ax.axhline(BAND, color="#999999", lw=0.6, ls="--", label=f"{BAND} m")
    ax.set_xlabel("dropout start [s]")
    finish(ax, fig, "faults_sweep", "tracking error [m]", xlabel=False)


def lost_frame(folder: Path, plt: object, lines: list[str]) -> None:
    import cantools

    import twmr
    from twmr.hw import protocol as p
    from twmr.hw.canbus import read_log

    text = (SCENARIOS / "bench_odrive_trajectory1.yaml").read_text(encoding="utf-8")
    text = text.replace("stop: 10.0", "stop: 4.0").replace(
        "emulate: true}", "emulate: true, watchdog_periods: 100}").replace(
        "interface: virtual, channel: bench,", "bus: can0,").replace(
        "  plant:\n", "  can0:\n    kind: can_bus\n    parameters: {bitrate: 1000000, fault_ids: "
        f"'{p.can_id(0, p.SET_INPUT_TORQUE):#x}', fault_start: 2.0}}\n  plant:\n", 1)
    path = folder / "bench_drop.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        twmr.simulate(path, folder / "bench")
        stopped = "the run was not stopped"
    except twmr.CosimError as err:
        stopped = str(err).split(" Fix:")[0]
    log = read_log(folder / "bench.incomplete" / "can0_frames.arrows")
    db = cantools.database.load_file(str(p.dbc_path("0.6.10")))
    sent = log[log.event == "transmit"]
    beats = sent[sent.id.astype(int) == p.can_id(0, p.HEARTBEAT)]
    decoded = [(t, db.decode_message(p.HEARTBEAT, bytes(d), decode_choices=False))
               for t, d in zip(beats.time, beats.data, strict=True)]
    lost = log[log.event == "dropped"]
    trip = next(((t, m) for t, m in decoded if m["Axis_Error"]), None)
    lines += ["## A lost torque frame on the emulated ODrive bench", "",
              f"Set_Input_Torque of node 0 lost from 2 s: {len(lost)} frames lost, the first "
              f"at {lost.time.min():.4f} s."]
    if trip is not None:
        lines.append(f"The drive's first heartbeat after its watchdog expired: t = "
                     f"{trip[0]:.4f} s, Axis_Error "
                     f"{p.axis_error_text(int(trip[1]['Axis_Error']), '0.6.10')}, Axis_State "
                     f"{int(trip[1]['Axis_State'])} (1: IDLE).")
    lines += [f"The host stopped the run: \"{stopped}\".", ""]
    torque = sent[(sent.sender == "motor") &
                  (sent.id.astype(int) == p.can_id(0, p.SET_INPUT_TORQUE))]
    values = [p.decode_torque(bytes(d), 1.0) for d in torque.data]
    fig, (ax, bx) = plt.subplots(2, 1, figsize=(8, 4.2), sharex=True)  # type: ignore[attr-defined]
    ax.plot(torque.time, values, ".", ms=2, label="Set_Input_Torque received (node 0)")
    ax.plot(lost.time, [p.decode_torque(bytes(d), 1.0) for d in lost.data], "x", ms=3,
            color="#D55E00", label="lost on the bus")
    ax.set_ylabel("motor torque [N.m]")
    ax.legend(fontsize=7, frameon=False)
    state = [int(db.decode_message(p.HEARTBEAT, bytes(d), decode_choices=False)["Axis_State"])
             for d in beats.data]
    bx.step(beats.time, state, where="post", lw=0.9)
    bx.set_yticks([1, 8], ["IDLE", "CLOSED_LOOP"])
    bx.set_ylabel("axis state (heartbeat)")
    finish(bx, fig, "faults_lost_frame", None)


def finish(ax: object, fig: object, name: str, ylabel: str | None, xlabel: bool = True) -> None:
    from twmr.plots import save

    if ylabel:
        ax.set_ylabel(ylabel)  # type: ignore[attr-defined]
    if xlabel:
        ax.set_xlabel("time [s]")  # type: ignore[attr-defined]
    ax.legend(fontsize=7, frameon=False)  # type: ignore[attr-defined]
    save(fig, FIGS / name)


def main() -> None:
    from twmr.plots import pyplot

    started = time.perf_counter()
    plt = pyplot()
    lines = ["# Numbers of docs/studies/faults.py", "",
             "Written by `.venv/bin/python docs/studies/faults.py`; do not edit.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for part in (payload, dropout, sweep, lost_frame):
            part(folder, plt, lines)
    wall = time.perf_counter() - started
    lines.append(f"Wall time of the study: {wall:.0f} s.")
    (HERE / "faults_numbers.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
