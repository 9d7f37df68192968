"""The misbehaving test FMU tests/fmus/faulty/ built at test time and checked with fmpy alone: it
counts its steps when well behaved, and once fail_after steps are done it returns fmi2Error, sets
y to NaN, segfaults, calls exit(0) or hangs (the last three in a child process)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from fmpy import simulate_fmu

from tests.fmu_build import build_c_fmu

MARKER = "SIMULATE_FMU_RETURNED"
STARTED = "SIMULATE_FMU_STARTED"
CHILD = f"""
import sys
from fmpy import simulate_fmu
print({STARTED!r}, flush=True)
simulate_fmu(sys.argv[1], stop_time=1.0, output_interval=0.01,
             start_values={{"mode": int(sys.argv[2]), "fail_after": 5}})
print({MARKER!r}, flush=True)
"""


@pytest.fixture(scope="module")
def faulty(tmp_path_factory) -> str:
    return str(build_c_fmu("faulty", tmp_path_factory.mktemp("fmus")))


def run_child(fmu: str, mode: int, timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", CHILD, fmu, str(mode)], check=False,
                          capture_output=True, text=True, timeout=timeout)


def test_mode_0_counts_steps_and_the_fmu_validates(faulty) -> None:
    u = np.zeros(2, dtype=[("time", float), ("u", float)])
    u["time"], u["u"] = [0.0, 1.0], 1.5
    r = simulate_fmu(faulty, stop_time=1.0, output_interval=0.01, input=u, output=["y", "y2"])
    assert r["y"][-1] == 100
    np.testing.assert_array_equal(r["y"], np.arange(len(r)))  # y(t) after k steps is k
    np.testing.assert_array_equal(r["y2"], 3.0)
    validation = pytest.importorskip("fmpy.validation")
    assert validation.validate_fmu(faulty) == []


def test_mode_4_returns_fmi2error_and_simulate_fmu_raises(faulty, capfd) -> None:
    from fmpy.fmi1 import FMICallException

    with pytest.raises(FMICallException) as e:
        simulate_fmu(faulty, stop_time=1.0, output_interval=0.01,
                     start_values={"mode": 4, "fail_after": 5})
    assert e.value.function == "fmi2DoStep" and e.value.status == 3
    assert "faulty: doStep failed on purpose at step 5" in capfd.readouterr().out


def test_mode_5_sets_y_to_nan(faulty) -> None:
    r = simulate_fmu(faulty, stop_time=1.0, output_interval=0.01,
                     start_values={"mode": 5, "fail_after": 5})
    np.testing.assert_array_equal(r["y"][:5], np.arange(5))
    assert np.isnan(r["y"][5:]).all()


@pytest.mark.skipif(sys.platform == "win32", reason="a POSIX signal ends the child")
def test_mode_1_segfaults_the_host_process(faulty) -> None:
    p = run_child(faulty, 1, timeout=60)
    assert p.returncode == -11, (p.returncode, p.stdout, p.stderr)  # SIGSEGV
    assert STARTED in p.stdout and MARKER not in p.stdout


def test_mode_2_exits_the_host_process_with_code_0(faulty) -> None:
    p = run_child(faulty, 2, timeout=60)
    assert p.returncode == 0, (p.stdout, p.stderr)
    assert STARTED in p.stdout and MARKER not in p.stdout


def test_mode_3_hangs_the_host_process(faulty) -> None:
    with pytest.raises(subprocess.TimeoutExpired) as e:
        run_child(faulty, 3, timeout=3)
    out = e.value.stdout or ""  # what the child printed before it was killed
    out = out.decode() if isinstance(out, bytes) else out
    assert STARTED in out and MARKER not in out
