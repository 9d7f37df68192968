"""Hostile scenarios around the bus block (`kind: can_bus`) and the drives' own buses: each is
refused by `twmr check` (and `twmr run`) in one paragraph naming the file and line, the component
and the parameter at fault, and the fix, never a traceback."""
from __future__ import annotations

from pathlib import Path

import pytest

from tests.hostile.runner import BENCH, assert_clean_error, run_cli, write

OWN_BUS = "interface: virtual, channel: bench,"
BUS_BLOCK = "  can0:\n    kind: can_bus\n    parameters: {bitrate: 1000000}\n"


def scenario(cwd: Path, *edits: tuple[str, str]) -> str:
    text = BENCH.read_text()
    for old, new in edits:
        assert old in text, old
        text = text.replace(old, new, 1)
    write(cwd, "bench.yaml", text)
    return "bench.yaml"


def line_of(cwd: Path, needle: str) -> int:
    lines = (cwd / "bench.yaml").read_text().splitlines()
    return next(i for i, line in enumerate(lines, 1) if needle in line)


def with_bus(block: str = BUS_BLOCK) -> tuple[str, str]:
    return ("  plant:\n", block + "  plant:\n")


CASES = {
    "bus-names-the-plant": (((OWN_BUS, "bus: plant,"),),
                            ("'motor'", "bus", "'plant'", "not a can_bus"), "bus: plant"),
    "bus-misspelt": (((OWN_BUS, "bus: can1,"), with_bus()),
                     ("'motor'", "can1", "did you mean 'can0'"), "bus: can1"),
    "bus-and-interface": (((OWN_BUS, "bus: can0, interface: virtual,"), with_bus()),
                          ("'motor'", "interface", "both say where the frames go"), "bus: can0"),
    "bus-joined-to-a-bus": (((OWN_BUS, "bus: can0,"), with_bus(
        "  can0:\n    kind: can_bus\n    parameters: {interface: twmr, channel: x}\n")),
        ("'can0'", "interface", "two buses joined"), "interface: twmr"),
    "two-buses-one-channel": (((OWN_BUS, "bus: can0,"), with_bus(
        "  can0:\n    kind: can_bus\n    parameters: {interface: virtual, channel: shared}\n"
        "  can1:\n    kind: can_bus\n    parameters: {interface: virtual, channel: shared}\n")),
        ("can_bus", "virtual:shared", "two buses joined"), "channel: shared"),
    "bus-stuffing-unknown": (((OWN_BUS, "bus: can0,"), with_bus(
        "  can0:\n    kind: can_bus\n    parameters: {stuffing: some}\n")),
        ("'can0'", "stuffing", "exact, worst"), "stuffing: some"),
    "virtual-for-real-drives": ((("emulate: true", "emulate: false"),),
                                ("'motor'", "interface 'virtual'", "one process",
                                 "udp_multicast"), "interface: virtual"),
}


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    folder = tmp_path / "cwd"
    folder.mkdir()
    return folder


@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_a_bad_bus_is_refused_at_check_naming_file_line_component_parameter(
        case: str, cwd: Path) -> None:
    edits, mentions, at = CASES[case]
    name = scenario(cwd, *edits)
    for command in (["check", name], ["run", name, "--set", "experiment.stop=0.05", "-q"]):
        o = run_cli(command, cwd, timeout=90)
        para = assert_clean_error(o, mentions=mentions)
        assert f"bench.yaml:{line_of(cwd, at)}" in "\n".join(para), o.describe()
