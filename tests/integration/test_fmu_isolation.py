"""FMU isolation (`isolate: true`): an isolated FMU gives the same results as one loaded in the
process, and a segfault, exit(0) or hang inside it (tests/fmus/faulty) ends the run with an
FmuError naming the FMU, the call and the time, keeps the rows recorded before it and leaves no
worker process behind, also when the run is the `twmr run` command or is killed."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.fmu_build import build_c_fmu
from twmr.core.errors import FmuError
from twmr.fmi.isolated import IsolatedFmu

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="isolation is POSIX only")

ROOT = Path(__file__).resolve().parents[2]
FAIL_AFTER = 30  # the 30th doStep fails: the one from t = 0.29 s, after 30 rows (t = 0 .. 0.29)
FAULTS = {1: "crashed (signal SIGSEGV) during doStep",
          2: "the FMU process exited with status 0 during doStep",
          3: "did not return within 1 s from doStep"}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("fmus")
    return {name: build_c_fmu(name, folder) for name in ("lag2", "faulty", "bounce2s")}


def workers(fmu: Path) -> list[int]:
    """Live worker processes serving `fmu` (zombies do not count)."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes().split(b"\0")
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if b"twmr.fmi.worker" in cmdline and str(fmu).encode() in cmdline and state != "Z":
            found.append(int(entry.name))
    return found


@pytest.fixture(autouse=True)
def no_worker_left(fmus):
    yield
    for fmu in fmus.values():
        assert workers(fmu) == []


def faulty_scenario(fmu: Path, mode: int, isolate: bool = True) -> str:
    return textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          dut:
            kind: fmu
            parameters: {{path: {fmu}, isolate: {str(isolate).lower()}, timeout: 1,
                          mode: {mode}, fail_after: {FAIL_AFTER}}}
        connections: [src.y -> dut.u]
        experiment: {{stop: 1.0, step: 0.01}}
    """)


def check_kept_rows(folder: Path) -> None:
    kept = twmr.read_result(folder)
    assert kept.status == "failed" and len(kept) == FAIL_AFTER
    np.testing.assert_array_equal(kept["dut.y"], np.arange(FAIL_AFTER))
    np.testing.assert_array_equal(kept["dut.y2"], 2.0 * kept["src.y"])


def test_isolated_lag2_has_the_same_ports_and_bit_identical_results(fmus) -> None:
    text = textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          lag:
            kind: fmu
            parameters: {{path: {fmus["lag2"]}, T: 0.25, isolate: ISOLATE}}
        connections: ["src.y -> lag.u[1]", "src.y -> lag.u[2]"]
        experiment: {{stop: 2.0, step: 0.001}}
    """)
    plain, isolated = (twmr.load(text.replace("ISOLATE", flag)) for flag in ("false", "true"))
    a, b = plain.system.components["lag"], isolated.system.components["lag"]
    assert isinstance(b, IsolatedFmu) and not isinstance(a, IsolatedFmu)
    assert list(b.variables) == list(a.variables) and b.has_feedthrough == a.has_feedthrough
    for name, var in a.variables.items():
        assert b.variables[name] == var and b.get(name) == a.get(name)
    ra, rb = twmr.simulate(plain), twmr.simulate(isolated)
    assert rb.columns == ra.columns and len(ra) == 2001
    np.testing.assert_array_equal(rb.data, ra.data)  # bit for bit
    assert np.ptp(rb["lag.y[1]"]) > 1.0  # it did follow its input


def test_an_isolated_model_exchange_fmu_has_its_events_located_as_in_the_process(fmus) -> None:
    """Under the adaptive master the worker's FMU holds, stops at and reports its state events
    as one in the process does: the same rows bit for bit, each bounce in two rows at the
    crossing CVODE finds."""
    text = textwrap.dedent(f"""
        components:
          ball:
            kind: fmu
            parameters: {{path: {fmus["bounce2s"]}, interface: model_exchange, rtol: 1.0e-8,
                          isolate: ISOLATE}}
        experiment: {{stop: 1.2, step: 1.0e-3, algorithm: adaptive, rtol: 1.0e-6,
                      atol: 1.0e-8, max_step: 0.1}}
        record: {{signals: [ball.h, ball.v, ball.bounces]}}
    """)
    plain, isolated = (twmr.simulate(twmr.load(text.replace("ISOLATE", flag)))
                       for flag in ("false", "true"))
    np.testing.assert_array_equal(isolated.data, plain.data)
    t = isolated["time"]
    at = [t[i] for i in range(1, len(t)) if t[i] == t[i - 1]]
    assert len(at) == 2 and abs(at[0] - (2 / 9.81) ** 0.5) < 1e-6


@pytest.mark.parametrize("mode", sorted(FAULTS))
def test_fault_ends_the_run_with_an_fmu_error_and_keeps_the_rows(fmus, mode, tmp_path) -> None:
    t0 = time.monotonic()
    with pytest.raises(FmuError) as err:
        twmr.simulate(twmr.load(faulty_scenario(fmus["faulty"], mode)), out=tmp_path / "run")
    assert time.monotonic() - t0 < 10
    message = str(err.value)
    assert message.startswith("component 'dut' at t = 0.29 s: FMU 'faulty.fmu'")
    assert FAULTS[mode] in message
    check_kept_rows(err.value.partial_results)


@pytest.mark.parametrize("mode", sorted(FAULTS))
def test_fault_in_twmr_run_is_a_one_line_error(fmus, mode, tmp_path) -> None:
    scenario, out, tmp = tmp_path / "faulty.yaml", tmp_path / "run", tmp_path / "tmp"
    scenario.write_text(faulty_scenario(fmus["faulty"], mode))
    tmp.mkdir()
    proc = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(scenario), "--out",
                           str(out), "--quiet"], capture_output=True, text=True, timeout=60,
                          cwd=ROOT, env=dict(os.environ, TMPDIR=str(tmp)))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    assert "FMU 'faulty.fmu'" in errors[0] and FAULTS[mode] in errors[0]
    assert "t = 0.29 s" in errors[0] and f"{out}.incomplete" in errors[0]
    check_kept_rows(Path(f"{out}.incomplete"))
    assert list(tmp.iterdir()) == []  # the worker's temporary folder is gone


def test_fmi_error_inside_the_worker_is_passed_through(fmus) -> None:
    errors = []
    for isolate in (False, True):
        with pytest.raises(FmuError) as err:
            twmr.simulate(twmr.load(faulty_scenario(fmus["faulty"], 4, isolate)))
        errors.append(str(err.value))
    assert errors[1] == errors[0]
    assert "t = 0.29 s" in errors[1] and "doStep failed on purpose at step 30" in errors[1]


def test_worker_ends_when_its_parent_is_killed_during_a_hang(fmus, tmp_path) -> None:
    scenario, tmp = tmp_path / "hang.yaml", tmp_path / "tmp"
    scenario.write_text(faulty_scenario(fmus["faulty"], 3).replace("timeout: 1", "timeout: 60"))
    tmp.mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", "run", str(scenario), "--out",
                             str(tmp_path / "run"), "--quiet"], cwd=ROOT,
                            stderr=subprocess.DEVNULL, env=dict(os.environ, TMPDIR=str(tmp)))
    try:
        deadline = time.monotonic() + 30
        while not workers(fmus["faulty"]):
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.05)
        time.sleep(1.0)  # the worker is inside the hanging doStep
        assert proc.poll() is None
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    deadline = time.monotonic() + 5
    while workers(fmus["faulty"]) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert workers(fmus["faulty"]) == []
    assert list(tmp.iterdir()) == []  # the worker removed its temporary folder
