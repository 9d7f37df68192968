"""`kind: emulated_drives`: emulated ODrives with no host of their own on a `can_bus` block,
here answering a `can_drive` host (emulate: false) on the same bus in the bench scenario (1 s,
paced): every torque they apply is zero (before the first command) or one the host commanded
(float32 on the wire), in the median one or two steps before (the frames cross the bus on the
wall clock)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.hw_bench import WATCHDOG
from twmr.core.errors import CosimError
from twmr.master import simulate
from twmr.scenario import loads

BENCH = Path(__file__).resolve().parents[2] / "scenarios" / "bench_odrive_trajectory1.yaml"


def _scenario(drives: str = "{bus: can0, node_ids: [0, 1], torque_constant: 0.8}") -> str:
    text = BENCH.read_text()
    for old, new in (
            ("interface: virtual, channel: bench, ", "bus: can0, "),
            ("emulate: true}", f"emulate: false, watchdog_periods: {WATCHDOG}}}\n"
                               f"  can0: {{kind: can_bus}}\n  drives:\n"
                               f"    kind: emulated_drives\n    parameters: {drives}"),
            ("  - plant.pose -> slip.pose",
             "  - plant.pose -> slip.pose\n  - plant.wheel_speed -> drives.wheel_speed"),
            ("stop: 10.0", "stop: 1.0"),
            ("signals: [", "signals: [drives.torque, motor.torque, "), ("decimation: 5", "")):
        assert old in text
        text = text.replace(old, new)
    return text


def test_emulated_drives_apply_what_a_host_on_the_bus_commands(tmp_path: Path) -> None:
    r = simulate(loads(_scenario(), source="drives.yaml"), tmp_path)
    for i in (1, 2):
        sent = np.asarray(r[f"motor.torque[{i}]"])
        applied = np.asarray(r[f"drives.torque[{i}]"])
        assert applied[0] == 0.0  # before the first command
        # how many steps ago the host sent the torque each axis applies (exactly, float32);
        # None: zero, before the first command came
        lags = [next((j for j in range(min(k, WATCHDOG) + 1) if applied[k] == sent[k - j]),
                     None) for k in range(1, len(sent))]
        assert all(lag is not None or applied[k + 1] == 0.0 for k, lag in enumerate(lags))
        assert np.median([lag for lag in lags if lag is not None]) <= 2
        assert np.max(np.abs(applied)) == pytest.approx(40.0)


def test_emulated_drives_need_a_bus() -> None:
    with pytest.raises(CosimError, match="bus"):
        loads(_scenario("{node_ids: [0, 1]}"), source="drives.yaml")
