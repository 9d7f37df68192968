"""docs/bench.md, "Every stop of the shipped benches", walked row by row on both shipped benches:
each row is made to happen in `twmr run` (a process of its own) and the drives' end is read from
the frame log the run leaves — the host's last torque command to each drive and the drive's last
heartbeat (state and error bits, decoded by twmr.hw.protocol). The table and this file name the
same rows; a row here that the table lacks, or the other way round, fails."""
from __future__ import annotations

import re
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.fmu_build import build_lsbus_fmu
from tests.hostile.test_signals import signal_run
from tests.hw_bench import WATCHDOG
from twmr.hw import protocol as p
from twmr.hw.canbus import read_log

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "bench.md"
SCENARIOS = ROOT / "scenarios"
BENCHES = ("bench_odrive_trajectory1.yaml", "bench_odrive_lsbus_trajectory1.yaml")
STOP = 1.0  # [s] of each run
#: the bench's controller FMU (scenarios/bench_odrive_lsbus_trajectory1.yaml's export command)
EXPORT = {"drive": "backward", "lookahead": 0.05, "drive.torque_limit": 40.0,
          "drive.torque_constant": 0.8, "drive.speed_limit": 50.0,
          "drive.watchdog_periods": WATCHDOG}
#: the drives' own watchdog in these runs [s]: a loaded machine stalls a process for more than
#: the 0.1 s of the shipped setting, and the rows here are not about it
DRIVE_WATCHDOG = 0.5
FAILING_BLOCK = '''
from twmr.core import Component, Input


class FailsAt(Component):
    """Raises at 0.3 s."""

    kind = "fails_at"
    u = Input()

    def do_step(self, t, h):
        if t >= 0.3:
            raise RuntimeError("the block gave up")
'''


def table() -> dict[str, dict[str, str]]:
    """The rows of the stop table: stop -> column -> cell."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("## Every stop of the shipped benches", 1)[1].split("\n## ", 1)[0]
    lines = [ln for ln in section.splitlines() if ln.startswith("|")]
    head = [c.strip().split()[0].strip("`") if c.strip().startswith("`") else c.strip()
            for c in lines[0].strip("|").split("|")]
    return {cells[0]: dict(zip(head, cells, strict=True))
            for cells in ([c.strip() for c in ln.strip("|").split("|")] for ln in lines[2:])}


@dataclass(frozen=True)
class Case:
    """What makes a row happen: a node on the bus (its parameters), a user block, a signal."""

    node: str = ""
    block: bool = False
    sigterm: bool = False
    words: tuple[str, ...] = ()
    host_watchdog: int = WATCHDOG  # [host periods]


CASES: dict[str, Case] = {
    "normal end": Case(),
    "SIGTERM": Case(sigterm=True),
    "a block fails": Case(block=True, words=("'boom'", "the block gave up")),
    "a node writes malformed operations": Case(node="id: 0x600, fault: 1",
                                               words=("cannode_triggered.fmu",
                                                      "malformed bus operations")),
    # 200 frames a step: the bus stays flooded however slow a loaded machine steps; the hosts'
    # watchdogs (starved of feedback) given room, so the bus's watch is what stops the run
    "a node floods the bus": Case(node="id: 0, period: 1.0e-5, delay: 0.2",
                                  words=("flooded", "participant 'other'"), host_watchdog=250),
}


def test_the_table_and_this_file_name_the_same_rows() -> None:
    assert set(table()) == set(CASES)


@pytest.fixture(scope="module")
def parts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    from twmr.fmi.cexport import export_c_fmu

    d = tmp_path_factory.mktemp("bench_stops")
    return {"ctrl": export_c_fmu("asmc", d / "asmc_odrive.fmu", EXPORT, fmi=3, can="odrive"),
            "node": build_lsbus_fmu("cannode_triggered", d)}


def scenario(bench: str, case: Case, parts: dict[str, Path]) -> str:
    """The shipped bench as this row runs it."""
    text = (SCENARIOS / bench).read_text(encoding="utf-8")
    text = sub(text, "stop: 10.0", f"stop: {STOP}")
    if "lsbus" in bench:
        text = sub(text, "path: ../fmus/asmc_odrive.fmu", f"path: {parts['ctrl']}\n      "
                   f"drive.watchdog_periods: {case.host_watchdog}")
        text = sub(text, "encoder_period: 0.0}", f"encoder_period: 0.0, watchdog: "
                   f"{DRIVE_WATCHDOG}}}")
    else:  # the can_drive host on a bus block
        text = sub(text, "interface: virtual, channel: bench,", "bus: can0,")
        text = sub(text, "emulate: true}", f"emulate: true, watchdog_periods: "
                   f"{case.host_watchdog}, drive_watchdog: {DRIVE_WATCHDOG}}}")
        text = sub(text, "  plant:\n", "  can0:\n    kind: can_bus\n    parameters: {bitrate: "
                   "1000000}\n  plant:\n")
    if case.node:
        text = sub(text, "  plant:\n", f"  other:\n    kind: fmu\n    parameters: {{path: "
                   f"{parts['node']}, bitrate: 1000000, {case.node}}}\n  plant:\n")
        text = sub(text, "connections:\n", "connections:\n  - other.CanChannel -> can0.other\n")
        text = sub(text, "record:\n", "open: [other.payload]\nrecord:\n")
    if case.block:
        text = sub(text, "  plant:\n", "  boom:\n    kind: fails.py:FailsAt\n  plant:\n")
        text = sub(text, "connections:\n", "connections:\n  - plant.wheel_speed[1] -> boom.u\n")
    return text


def sub(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new, 1)


def drives_end(log_path: Path, host: str, drives: str) -> dict[int, tuple[float | None, int, int]]:
    """Per node: the host's last torque command [N.m] (None: none logged), and the drive's last
    heartbeat's axis state and error bits."""
    log = read_log(log_path)
    sent = log[log.event.isin(["transmit", "unheard"])]  # unheard: after the host has left
    out = {}
    for node in (0, 1):
        torques = [p.decode_torque(bytes(r.data), 1.0) for r in sent.itertuples()
                   if r.sender == host and r.id == p.can_id(node, p.SET_INPUT_TORQUE)]
        beats = [p.decode_heartbeat(bytes(r.data), "0.6.10") for r in sent.itertuples()
                 if r.sender == drives and r.id == p.can_id(node, p.HEARTBEAT)]
        assert beats, f"no heartbeat of node {node} in {log_path}"
        out[node] = (torques[-1] if torques else None, beats[-1].axis_state,
                     beats[-1].axis_error)
    return out


def expected(cell: str) -> tuple[bool, int, int | None]:
    """From a cell: whether the host's last command is zero torque, the state, and the error
    bits that must be set (None: no error at all)."""
    zero = cell.startswith("zero torque")
    assert "IDLE" in cell, cell
    bits = [p.error_bit({"WATCHDOG_TIMER_EXPIRED": "watchdog", "ESTOP_REQUESTED": "estop"}[b],
                        "0.6.10") for b in re.findall(r"[A-Z_]{6,}", cell) if b != "IDLE"]
    return zero, p.AXIS_IDLE, None if "no error" in cell else sum(bits)


@pytest.mark.timeout(240)
@pytest.mark.parametrize("bench", BENCHES)
@pytest.mark.parametrize("row", list(CASES))
def test_every_stop_leaves_every_drive_stopped(bench: str, row: str, parts, tmp_path) -> None:
    case, cells = CASES[row], table()[row]
    (tmp_path / "bench.yaml").write_text(scenario(bench, case, parts), encoding="utf-8")
    if case.block:
        (tmp_path / "fails.py").write_text(FAILING_BLOCK, encoding="utf-8")
    args = ["run", "bench.yaml", "--out", "out", "-q"]
    if case.sigterm:
        o = signal_run(args, tmp_path, "out.partial-*/result.arrows", 0.3,
                       [(signal.SIGTERM, 0.0)])
        code, stderr = o.returncode, o.stderr
    else:
        done = subprocess.run([sys.executable, "-m", "twmr.cli", *args], cwd=tmp_path,
                              capture_output=True, text=True, timeout=180)
        code, stderr = done.returncode, done.stderr
    ends = cells["the run ends"]
    want = int(re.search(r"exit (\d+)", ends).group(1))  # type: ignore[union-attr]
    if case.node.startswith("id: 0,") and code == 0:
        # a node stepped with the run floods only as fast as the run steps: a machine too
        # loaded to keep the pace never saturates the bus (no frame waited flood_time: the
        # watch itself is tested in tests/unit/test_bus_flood_watch.py); the drives' end still
        # holds below
        assert "flooded" not in stderr, stderr[-3000:]
    else:
        assert code == want, stderr[-3000:]
        for words in case.words:
            assert words in stderr, stderr[-3000:]
    assert "Traceback" not in stderr, stderr[-3000:]
    lsbus = "lsbus" in bench
    host, drives = ("ctrl", "drives") if lsbus else ("motor", "motor (emulated)")
    zero, state, bits = expected(cells[bench])
    logs = sorted(tmp_path.glob("out*/can0_frames.arrows"))  # out/, or out.incomplete/
    assert len(logs) == 1, logs
    for node, (torque, axis_state, error) in drives_end(logs[0], host, drives).items():
        what = f"{row}, {bench}, node {node}: torque {torque}, state {axis_state}, error {error:#x}"
        if zero:
            assert torque == 0.0, what
        assert axis_state == state, what
        assert error == 0 if bits is None else error & bits == bits, what


def test_a_case_builds_what_it_says(parts) -> None:
    """The scenario texts: each row's node, block or nothing, on both benches."""
    for bench in BENCHES:
        plain = scenario(bench, CASES["normal end"], parts)
        assert "other:" not in plain and "boom:" not in plain and f"stop: {STOP}" in plain
        flood = scenario(bench, CASES["a node floods the bus"], parts)
        assert "id: 0, period: 1.0e-5" in flood and "other.CanChannel -> can0.other" in flood

