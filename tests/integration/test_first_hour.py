"""Frictions a new user met in the first hour, each at its cause: swapping a block for its
exported FMU with a parameter the export fixed in the code."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]
TWMR = [sys.executable, "-m", "twmr.cli"]


def test_a_parameter_the_export_fixed_says_how_to_export_again(tmp_path: Path) -> None:
    fmu = tmp_path / "asmc.fmu"
    subprocess.run([*TWMR, "export", "asmc", "--fmi", "3", "--out", str(fmu), "-q"],
                   check=True, timeout=240)
    text = (ROOT / "scenarios" / "bench_odrive_trajectory1.yaml").read_text().replace(
        "kind: asmc\n    parameters: {drive: backward",
        f"kind: fmu\n    parameters: {{path: {fmu}, drive: backward")
    (tmp_path / "swap.yaml").write_text(text)
    done = subprocess.run([*TWMR, "check", str(tmp_path / "swap.yaml")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "'drive' is not a parameter of this FMU: twmr export fixed it to auto" in done.stderr
    assert f"twmr export asmc --fmi 3 --set drive=<value> --out {fmu}" in done.stderr


def test_emulate_drive_takes_the_drives_of_a_scenario(tmp_path: Path) -> None:
    """The shipped bench says torque constant 0.8 N.m/A and a 50 rad/s speed limit; the
    emulator's own defaults are 0.04 and 200, which clipped the bench's torques at 2 N.m."""
    (tmp_path / "can.ini").write_text("[default]\ninterface = udp_multicast\n"
                                      "channel = 239.74.163.9\nport = 43119\n")
    bench = (ROOT / "scenarios" / "bench_odrive_trajectory1.yaml").read_text().replace(
        "interface: virtual, channel: bench,", "can_config: can.ini,")
    (tmp_path / "bench.yaml").write_text(bench)
    proc = subprocess.Popen([*TWMR, "emulate-drive", "--scenario", str(tmp_path / "bench.yaml"),
                             "--node", "3"], stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        lines = [proc.stderr.readline() for _ in range(2)]
    finally:
        proc.terminate()
        proc.wait(timeout=30)
    assert "the drives of 'motor'" in lines[0]
    # the node given on the command line wins; the rest is the scenario's
    assert lines[1].startswith("emulating odrive drives [3] on udp_multicast:239.74.163.9")
    assert "torque_constant 0.8" in lines[1] and "speed_limit 50.0" in lines[1]
    assert "firmware 0.6.10" in lines[1] and "encoder polled" in lines[1]


def test_emulate_drive_names_the_drives_to_choose_from(tmp_path: Path) -> None:
    text = (ROOT / "scenarios" / "bench_odrive_trajectory1.yaml").read_text()
    second = "  motor2:\n    kind: can_drive\n    parameters: {channel: other}\n  plant:\n"
    (tmp_path / "two.yaml").write_text(text.replace("  plant:\n", second, 1))
    done = subprocess.run([*TWMR, "emulate-drive", "--scenario", str(tmp_path / "two.yaml")],
                          capture_output=True, text=True, timeout=60)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    assert "has can_drive components motor, motor2. Fix: give --component NAME" in done.stderr


SWEEP = '''import twmr

{indent}runs = twmr.sweep({scenario!r}, {{"plant.scale": "uniform:1:1.25"}}, samples=2,
{indent}                  out={out!r}, workers=1, overrides=["experiment.stop=0.2"])
{indent}print("rows", len(runs.frame()))
'''


@pytest.mark.parametrize("guarded", [False, True])
def test_a_sweep_script_without_the_main_guard_is_told_before_any_worker_starts(
        tmp_path: Path, guarded: bool) -> None:
    text = SWEEP.format(indent="    " if guarded else "", out=str(tmp_path / "out"),
                        scenario=str(ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"))
    if guarded:
        text = text.replace("\n    runs", '\nif __name__ == "__main__":\n    runs', 1)
    (tmp_path / "study.py").write_text(text)
    done = subprocess.run([sys.executable, str(tmp_path / "study.py")], capture_output=True,
                          text=True, timeout=240, cwd=tmp_path)
    if guarded:
        assert done.returncode == 0 and "rows 2" in done.stdout, done.stderr[-2000:]
        return
    assert done.returncode == 1
    assert f"{tmp_path / 'study.py'} line 3 starts local worker processes" in done.stderr
    assert "Nanny" not in done.stderr and len(done.stderr.splitlines()) < 20


def test_the_shipped_ls_bus_bench_says_the_one_command_that_builds_its_fmu(
        tmp_path: Path) -> None:
    """On a fresh clone the controller FMU of the LS-BUS bench does not exist yet: `twmr check`
    says the command (the scenario's `built_by:`), and that command, run from the scenario's
    folder, makes the scenario valid."""
    (tmp_path / "scenarios").mkdir()
    text = (ROOT / "scenarios" / "bench_odrive_lsbus_trajectory1.yaml").read_text()
    path = tmp_path / "scenarios" / "lsbus.yaml"
    path.write_text(text)
    done = subprocess.run([*TWMR, "check", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    command = done.stderr.split("Fix: run it once, from the scenario's folder: ")[1].strip()
    assert command.startswith("twmr export asmc --fmi 3 --can odrive --out ../fmus/")
    subprocess.run([*TWMR, *command.split()[1:]], cwd=path.parent, check=True, timeout=240,
                   capture_output=True)
    done = subprocess.run([*TWMR, "check", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr
