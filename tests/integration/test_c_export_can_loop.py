"""The ASMC exported as an ODrive CAN node FMU (`--can odrive`) drives the simulated robot of
the bench scenario (scenarios/bench_odrive_trajectory1.yaml: trajectory 1, plant scale 1.25,
paper slip) through an ideal wire — its torque frames decoded and its encoder frames encoded by
hw's Python protocol (twmr.hw.protocol), each delivered at the point it is sent, as the
`can_drive` bench does — and tracks as the ASMC block does in the same loop with what the
`can_drive` block does to its torque (limited to 40 N.m, float32 on the wire). They differ by the
float32 wheel speeds of the encoder frames only (the block reads the plant's in double)."""
from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from twmr.fmi.cexport import export_c_fmu
from twmr.fmi.lsbus.operations import CanTransmit, decode, encode
from twmr.hw import protocol as p
from twmr.hw.safety import clamp
from twmr.testing import Harness

H, STOP = 2e-3, 10.0
CTRL = {"drive": "backward", "lookahead": 0.05}  # the bench's controller
DRIVE = {"drive.torque_limit": 40.0, "drive.torque_constant": 0.8, "drive.speed_limit": 50.0}
NODES, GEAR, LIMIT = (0, 1), 1.0, 40.0
RX, RX_CLOCK, TX = "CanChannel.Rx_Data", "CanChannel.Rx_Clock", "CanChannel.Tx_Data"
#: [m, m, rad]; measured 2026-12-02: 1.6e-6 m, 8.3e-7 m, 9.9e-7 rad (docs/export.md)
POSE_BOUND = (1e-4, 1e-4, 1e-4)


def _robot() -> tuple[Harness, Harness, Harness]:
    ref = Harness("trajectory", parameters={"shape": "paper1"}, step=H)
    plant = Harness("twmr_plant", parameters={"scale": 1.25},
                    initial={"pose": [0.5, 0.0, -math.pi / 4]}, step=H)
    slip = Harness("slip_disturbance", parameters={"profile": "paper"}, step=H)
    return ref, plant, slip


def _run(ctrl: Harness, bus: bool) -> np.ndarray:
    """Poses [x, y, theta] at every point of a 10 s run; `bus`: `ctrl` is the CAN node FMU."""
    ref, plant, slip = _robot()
    for h in (ref, plant, slip):
        h.initialize()
    slip.set(pose=plant["pose"]).evaluate()

    def inputs() -> dict[str, Any]:
        return {"ref_position": ref["position"], "ref_velocity": ref["velocity"],
                "ref_acceleration": ref["acceleration"], "pose": plant["pose"]}

    ctrl.set(**inputs(), **({RX: b"", RX_CLOCK: False} if bus else
                            {"wheel_speed": plant["wheel_speed"]}))
    ctrl.initialize()
    poses = [plant["pose"]]
    for _ in range(round(STOP / H)):
        if bus:  # the estimates in; the torques the FMU sends at once, as the drives get them
            encoder = [CanTransmit(*p.encode_encoder(n, 0.0, w, GEAR))
                       for n, w in zip(NODES, plant["wheel_speed"], strict=True)]
            ctrl.step(**inputs(), **{RX: encode(encoder), RX_CLOCK: True})
            frames = [op for op in decode(ctrl[TX]) if isinstance(op, CanTransmit)
                      and not op.rtr and p.split_id(op.id)[1] == p.SET_INPUT_TORQUE]
            torque = tuple(p.decode_torque(op.data, GEAR) for op in frames)
        else:  # the can_drive block: limited, then float32 on the wire
            ctrl.set(**inputs(), wheel_speed=plant["wheel_speed"]).evaluate()
            torque = tuple(p.decode_torque(p.encode_torque(0, t, GEAR)[1], GEAR)
                           for t in clamp(ctrl["torque"], LIMIT))
            ctrl.step()
        slip.set(pose=plant["pose"]).evaluate()
        disturbance = {k: slip[k] for k in ("slip_rate", "slip_accel", "disturbance")}
        plant.step(torque=torque, **disturbance)
        ref.step()
        slip.step(pose=plant["pose"])
        poses.append(plant["pose"])
    return np.array(poses)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> tuple[np.ndarray, np.ndarray]:
    path = export_c_fmu("asmc", tmp_path_factory.mktemp("can_loop") / "asmc_odrive.fmu",
                        {**CTRL, **DRIVE}, fmi=3, can="odrive")
    on_bus = _run(Harness("fmu", parameters={"path": str(path)}, step=H), bus=True)
    block = _run(Harness("asmc", parameters=CTRL, step=H), bus=False)
    return on_bus, block


def test_the_can_node_fmu_tracks_as_the_block_behind_a_can_drive(
        runs: tuple[np.ndarray, np.ndarray]) -> None:
    on_bus, block = runs
    diff = np.max(np.abs(on_bus - block), axis=0)
    print(f"max |pose difference| over {STOP:g} s: x {diff[0]:.3g} m, y {diff[1]:.3g} m, "
          f"theta {diff[2]:.3g} rad")
    assert np.all(diff <= POSE_BOUND), diff
    assert np.any(diff > 0)  # the wire and the delay changed something


def test_both_track_the_trajectory(runs: tuple[np.ndarray, np.ndarray]) -> None:
    t = STOP
    target = np.array([-t, math.sin(0.5 * t) + 0.5 * t + 1.0])
    for poses in runs:
        assert np.hypot(*(poses[-1, :2] - target)) < 0.2  # the look-ahead offset and slip
