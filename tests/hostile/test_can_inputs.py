"""Hostile values for the CAN drive block, the emulator and `twmr replay`: each is refused with
one paragraph naming what is at fault and the fix (never a traceback, never a dead thread, never
"not a frame log" for a log that is one); a log with a frame too short for its identifier is
decoded with that frame skipped and counted."""
from __future__ import annotations

import struct
from pathlib import Path

import can
import pytest

from tests.hostile.runner import BENCH, assert_clean_error, assert_ok, run_cli, write
from twmr.hw import protocol as p


def bench_with(cwd: Path, old: str, new: str) -> str:
    text = BENCH.read_text()
    assert old in text, old
    write(cwd, "bench.yaml", text.replace(old, new))
    return "bench.yaml"


SCENARIO_CASES = {
    "protocol-misspelt": (("protocol: odrive", "protocol: odrvie"),
                          ("protocol", "odrvie", "did you mean 'odrive'")),
    "interface-misspelt": (("interface: virtual", "interface: virtul"),
                           ("interface", "virtul", "did you mean 'virtual'")),
    "firmware-unknown": (("firmware: 0.6.10", "firmware: 9.9"), ("firmware", "9.9")),
    "cia402-rated-torque-0": (("protocol: odrive, interface: virtual, channel: bench, "
                               "firmware: 0.6.10,\n                 node_ids: [0, 1], encoder: "
                               "polled,", "protocol: cia402, interface: virtual, channel: "
                               "bench, rated_torque: 0,\n                 node_ids: [1, 2],"),
                              ("rated_torque",)),
    "eds-with-odrive": (("firmware: 0.6.10,", "firmware: 0.6.10, eds: drive.eds,"),
                        ("eds", "odrive")),
}


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    folder = tmp_path / "cwd"
    folder.mkdir()
    return folder


@pytest.mark.parametrize("case", list(SCENARIO_CASES), ids=list(SCENARIO_CASES))
def test_bad_drive_parameter_is_one_paragraph_at_check_and_run(case: str, cwd: Path) -> None:
    (old, new), mentions = SCENARIO_CASES[case]
    name = bench_with(cwd, old, new)
    for command in (["check", name], ["run", name, "--set", "experiment.stop=0.05", "-q"]):
        o = run_cli(command, cwd, timeout=60)
        para = assert_clean_error(o, mentions=mentions)
        assert "bench.yaml:" in para[0], o.describe()
        assert "node id" not in "\n".join(para) or case == "cia402-rated-torque-0", o.describe()


def test_emulate_drive_with_an_unknown_firmware_is_refused(cwd: Path) -> None:
    o = run_cli(["emulate-drive", "--option", "firmware=9.9"], cwd, timeout=10)
    assert_clean_error(o, mentions=("--option firmware=9.9", "9.9"))


@pytest.fixture
def log_with_a_short_frame(cwd: Path) -> Path:
    """20 torque commands (0.5 N.m) to node 0, one of them cut to 1 byte."""
    path = cwd / "frames.blf"
    writer = can.Logger(str(path))
    ident = p.can_id(0, p.SET_INPUT_TORQUE)
    for i in range(20):
        data = b"\x01" if i == 7 else struct.pack("<f4x", 0.5)
        writer.on_message_received(can.Message(timestamp=1e-3 * i, arbitration_id=ident,
                                               data=data, is_extended_id=False))
    writer.stop()
    return path


def test_replay_skips_and_counts_a_frame_too_short_to_decode(log_with_a_short_frame: Path,
                                                             cwd: Path) -> None:
    o = run_cli(["replay", str(log_with_a_short_frame)], cwd)
    assert_ok(o)
    rows = o.stdout.strip().splitlines()[1:]
    assert len(rows) == 19 and all(r.endswith(",0,torque_command,0.5") for r in rows), \
        o.describe()
    assert "1 frame of the log too short for odrive, skipped" in o.stderr, o.describe()
    assert "0x00e [1] 01" in o.stderr, o.describe()


@pytest.mark.parametrize("args, mentions", [
    (["--gear", "0"], ("--gear", "gear 0")),
    (["--option", "firmware=9.9"], ("--option firmware=9.9",)),
    (["--protocol", "cia402", "-o", "rated_torque=0"], ("--option rated_torque=0",)),
    (["--protocol", "cia402"], ("no cia402 frames",)),
    (["--play", "--interface", "bogus"], ("bogus", "--interface")),
], ids=["gear-0", "firmware-9.9", "rated-torque-0", "wrong-protocol", "play-bogus-interface"])
def test_replay_names_the_option_at_fault(log_with_a_short_frame: Path, cwd: Path,
                                          args: list[str], mentions: tuple[str, ...]) -> None:
    o = run_cli(["replay", str(log_with_a_short_frame), *args], cwd)
    para = assert_clean_error(o, mentions=mentions)
    assert "cannot read it as a frame log" not in "\n".join(para), o.describe()
