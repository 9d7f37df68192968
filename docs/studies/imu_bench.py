"""The paper's robot with a real device's CAN database on its bus (docs/can_io.md): the bench
scenario scenarios/bench_imu_trajectory1.yaml, where the robot's yaw-rate gyro is published as the
Bosch MM5.10 inertial sensor of abs.dbc (cantools' test database) on a simulated 500 kbit/s bus
and an ECU node receives it; then the same run with the sensor's first message lost on the bus
from 10 to 10.5 s. Writes docs/studies/imu_bench_numbers.md and
docs/figures/studies/imu_bench_*.png; prints its wall time.

    .venv/bin/python docs/studies/imu_bench.py

Read back from the run: the gyro's yaw rate against what the ECU decoded (and what cantools
decodes from the frames of the bus's log), the age of the message at the ECU and its timeout
flag, the bus's frames and load.
"""
from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
FIGS = ROOT / "docs" / "figures" / "studies"
SCENARIO = ROOT / "scenarios" / "bench_imu_trajectory1.yaml"
DROP = (10.0, 10.5)  # [s]: MM5_10_TX1 (0x70) lost on the bus


def run(folder: Path, tag: str, bus: str = "") -> object:
    import twmr

    text = SCENARIO.read_text(encoding="utf-8").replace(
        "dbc: can/abs.dbc", f"dbc: {SCENARIO.parent / 'can' / 'abs.dbc'}")
    if bus:
        text = text.replace("{bitrate: 500000}", f"{{bitrate: 500000{bus}}}")
    path = folder / f"{tag}.yaml"
    path.write_text(text, encoding="utf-8")
    return twmr.simulate(path, folder / tag)


def wire_values(folder: Path) -> np.ndarray:
    """Yaw_Rate [deg/s] of the MM5_10_TX1 frames on the wire, decoded by cantools."""
    import cantools

    from twmr.hw.canbus import read_log

    db = cantools.database.load_file(str(SCENARIO.parent / "can" / "abs.dbc"))
    log = read_log(folder / "can0_frames.arrows")
    tx = log[(log.event == "transmit") & (log.id == 0x70)]
    return np.array([db.decode_message(0x70, bytes(d))["Yaw_Rate"] for d in tx.data])


def main() -> None:
    from twmr.plots import pyplot, save

    started = time.perf_counter()
    plt = pyplot()
    FIGS.mkdir(parents=True, exist_ok=True)
    lines = ["# Numbers of docs/studies/imu_bench.py", "",
             "Written by `.venv/bin/python docs/studies/imu_bench.py`; do not edit.", ""]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        clean = run(folder, "clean")
        lossy = run(folder, "lossy", f", fault_ids: '0x70', fault_start: {DROP[0]}, "
                                     f"fault_stop: {DROP[1]}")
        t = clean["time"]  # type: ignore[index]
        gyro = np.degrees(clean["imu.yaw_rate"])  # type: ignore[index]
        ecu = clean["ecu.MM5_10_TX1.Yaw_Rate"]  # type: ignore[index]
        wire = wire_values(folder / "clean")
        sent = np.round(gyro[::10][:len(wire)] / 0.005) * 0.005
        pacing = clean.summary["pacing"]  # type: ignore[attr-defined]
        age = clean["ecu.MM5_10_TX1.age"]  # type: ignore[index]
        lines += ["## The bench run (30 s, step 1 ms)", "",
                  f"- frames on the bus: {pacing['can0.frames']} (MM5_10_TX1..3 every 10 ms, "
                  f"the file's GenMsgCycleTime); sent period of MM5_10_TX1 measured in run "
                  f"time {pacing['imu_can.MM5_10_TX1']['period_ms']:.3f} ms, jitter (std) "
                  f"{pacing['imu_can.MM5_10_TX1']['jitter_std_ms']:.3f} ms",
                  f"- Yaw_Rate on the wire (cantools) against the gyro at each send: largest "
                  f"difference {np.abs(wire - sent).max():.2g} deg/s after quantising to the "
                  f"file's 0.005 deg/s; before quantising "
                  f"{np.abs(wire - gyro[::10][:len(wire)]).max():.4f} deg/s",
                  f"- at the ECU: age of MM5_10_TX1 at most {age.max() * 1e3:.1f} ms; "
                  f"timed out {int(clean['ecu.MM5_10_TX1.timed_out'].sum())} steps"  # type: ignore[index]
                  , ""]
        lt = lossy["time"]  # type: ignore[index]
        late = lossy["ecu.MM5_10_TX1.timed_out"].astype(bool)  # type: ignore[index]
        first = float(lt[np.argmax(late)])
        back = float(lt[len(late) - 1 - np.argmax(late[::-1])])
        lines += ["## MM5_10_TX1 lost on the bus from 10 to 10.5 s", "",
                  f"- frames lost: {lossy.summary['pacing'].get('can0.dropped', 'n/a')}",  # type: ignore[attr-defined]
                  f"- the ECU's timeout flag (3 x 10 ms) rises at t = {first:.3f} s and falls "
                  f"after t = {back:.3f} s; MM5_10_TX2 never timed out: "
                  f"{not lossy['ecu.MM5_10_TX2.timed_out'].any()}",  # type: ignore[index]
                  f"- the robot is not affected (the gyro is not in the loop): largest "
                  f"difference of the pose between the runs "
                  f"{np.abs(lossy['plant.pose[1]'] - clean['plant.pose[1]']).max():.2g} m", ""]  # type: ignore[index]

        fig, (ax, bx, cx) = plt.subplots(3, 1, figsize=(8, 6.4))
        ax.plot(clean["ref.position[1]"], clean["ref.position[2]"], "--", lw=0.8,  # type: ignore[index]
                label="reference (trajectory 1)")
        ax.plot(clean["plant.pose[1]"], clean["plant.pose[2]"], lw=1.0, label="robot")  # type: ignore[index]
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.legend(fontsize=7, frameon=False)
        window = (t >= 9.8) & (t <= 10.8)
        bx.plot(t[window], gyro[window], lw=0.6, color="0.6", label="gyro (1 ms samples)")
        bx.step(t[window], ecu[window], where="post", lw=1.0,
                label="ECU: MM5_10_TX1.Yaw_Rate (10 ms frames)")
        lwin = (lt >= 9.8) & (lt <= 10.8)
        bx.step(lt[lwin], lossy["ecu.MM5_10_TX1.Yaw_Rate"][lwin], where="post", lw=1.0,  # type: ignore[index]
                label=f"ECU, frames lost {DROP[0]:g}-{DROP[1]:g} s")
        bx.set_ylabel("yaw rate [deg/s]")
        bx.legend(fontsize=7, frameon=False)
        cx.plot(lt[lwin], lossy["ecu.MM5_10_TX1.age"][lwin] * 1e3, lw=1.0,  # type: ignore[index]
                label="age of MM5_10_TX1 at the ECU (frames lost)")
        cx.fill_between(lt[lwin], 0, 1, where=late[lwin], alpha=0.2, color="#D55E00",
                        transform=cx.get_xaxis_transform(), label="timed out (> 30 ms)")
        cx.set_ylabel("age [ms]")
        cx.set_xlabel("time [s]")
        cx.legend(fontsize=7, frameon=False)
        save(fig, FIGS / "imu_bench")
    (HERE / "imu_bench_numbers.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"written docs/studies/imu_bench_numbers.md and docs/figures/studies/imu_bench.png in "
          f"{time.perf_counter() - started:.1f} s")


if __name__ == "__main__":
    main()
