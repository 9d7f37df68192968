"""Hostile FMUs (tests/fmus/faulty) against `twmr run`, in a subprocess: an FMU hung inside doStep
in this process still lets Ctrl-C and SIGTERM end the run; an FMU calling exit(0) in this process no
longer ends `twmr` with status 0 and no word; an isolated FMU that writes a length header to the
worker's socket and sleeps is still cut off by `timeout:`; an isolated FMU that forks leaves no
child behind; `timeout: .inf` means no limit.

The promise checked for each: the process ends (no hang), with a non-zero status, no traceback, and
one paragraph naming the component and the FMU and advising `isolate: true` where it was not used.
"""
from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest

from tests.fmu_build import build_c_fmu
from tests.hostile.runner import (
    FORBIDDEN,
    MAX_ERROR_LINES,
    Outcome,
    assert_clean_error,
    assert_ok,
    error_paragraph,
    run_cli,
)
from twmr.result import read_result

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="POSIX signals, /proc, glibc")

FAIL_AFTER = 30  # the 30th doStep misbehaves: the one from t = 0.29 s
LATE = 50_000  # a hang late enough for rows to be written before it: at t = 499.99 s
EXIT_TIMEOUT = 30.0  # s from the (last) signal to the end of the process


@pytest.fixture(scope="module")
def faulty(tmp_path_factory) -> Path:
    return build_c_fmu("faulty", tmp_path_factory.mktemp("fmus"))


def scenario(folder: Path, fmu: Path, mode: int, isolate: bool, timeout: str = "1",
             fail_after: int = FAIL_AFTER, stop: float = 1.0) -> Path:
    path = folder / "hostile.yaml"
    path.write_text(textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          dut:
            kind: fmu
            parameters: {{path: {fmu}, isolate: {str(isolate).lower()}, timeout: {timeout},
                          mode: {mode}, fail_after: {fail_after}}}
        connections: [src.y -> dut.u]
        experiment: {{stop: {stop}, step: 0.01}}
    """))
    return path


def processes_of(fmu: Path) -> list[int]:
    """Live processes whose command line names `fmu` (the worker and what it forked)."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            cmdline = (entry / "cmdline").read_bytes()
            state = (entry / "stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if entry.name.isdigit() and str(fmu).encode() in cmdline and state != "Z":
            found.append(int(entry.name))
    return found


def left_alive(fmu: Path, within: float = 5.0) -> list[int]:
    """`processes_of(fmu)` once none is left, or after `within` s: a process killed with
    SIGKILL is gone a moment later, longer on a loaded machine; one nobody killed stays."""
    end = time.monotonic() + within
    while (found := processes_of(fmu)) and time.monotonic() < end:
        time.sleep(0.05)
    return found


def interrupt(args: list[str], cwd: Path, signals: list[int]) -> Outcome:
    """`twmr *args` in `cwd`; once the FMU logs that it hangs, each signal of `signals` is sent
    (0.2 s apart); the run must end within EXIT_TIMEOUT s of the last."""
    with tempfile.TemporaryDirectory(prefix="twmr-fmu-signal-") as io_dir:
        err_path = Path(io_dir) / "stderr"
        with open(err_path, "wb") as ferr:
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", *args], cwd=cwd,
                                    stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                    stderr=ferr, start_new_session=True)
            try:
                deadline = time.monotonic() + 60
                while b"faulty: hanging in doStep" not in err_path.read_bytes():
                    assert proc.poll() is None, err_path.read_text()
                    assert time.monotonic() < deadline, "the FMU never hung"
                    time.sleep(0.05)
                time.sleep(0.3)  # inside the C loop by now
                for sig in signals:
                    os.kill(proc.pid, sig)
                    time.sleep(0.2)
                try:
                    proc.wait(EXIT_TIMEOUT)
                except subprocess.TimeoutExpired:
                    pytest.fail(f"hang: twmr still running {EXIT_TIMEOUT:g} s after the signal; "
                                f"stderr:\n{err_path.read_text()[-2000:]}", pytrace=False)
            finally:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        stderr = err_path.read_text(errors="replace")
    return Outcome(args, cwd, proc.returncode, "", stderr, time.perf_counter() - t0, proc.pid, 0)


@pytest.mark.parametrize("signals", [[signal.SIGINT], [signal.SIGTERM],
                                     [signal.SIGINT, signal.SIGINT]],
                         ids=["ctrl-c", "SIGTERM", "double-ctrl-c"])
def test_a_stop_signal_ends_a_run_hung_inside_an_in_process_fmu(faulty, tmp_path,
                                                                 signals) -> None:
    path = scenario(tmp_path, faulty, 3, isolate=False, fail_after=LATE, stop=1000.0)
    o = interrupt(["run", str(path), "--out", "out", "--fmu-log"], tmp_path, signals)
    sig = signals[0]
    assert o.returncode == (130 if sig == signal.SIGINT else 128 + sig), o.describe()
    assert not any(marker in o.stderr for marker in FORBIDDEN), o.describe()
    para = error_paragraph(o)
    text = " ".join(para)
    how = "Ctrl-C" if sig == signal.SIGINT else "SIGTERM"
    assert text.startswith(f"interrupted ({how}): component 'dut' at t = 499.99 s: FMU "
                           f"'faulty.fmu' did not return from doStep"), o.describe()
    assert "isolate: true" in text and len(para) <= MAX_ERROR_LINES, o.describe()
    partial = [p for p in tmp_path.glob("out.partial-*")]
    assert len(partial) == 1 and f"{partial[0]}/" in text, o.describe()
    kept = read_result(partial[0])  # the rows up to the last chunk written before the hang
    assert 0 < len(kept) <= LATE and list(kept["dut.y"]) == list(range(len(kept)))


def test_a_stop_signal_ends_a_compiled_run_hung_inside_an_fmu(faulty, tmp_path) -> None:
    """With --compiled on the FMU is called from compiled code, where no Python frame names the
    call: a Ctrl-C still ends the process, naming the FMUs the compiled loop calls."""
    path = scenario(tmp_path, faulty, 3, isolate=False, fail_after=LATE, stop=1000.0)
    o = interrupt(["run", str(path), "--out", "out", "--fmu-log", "--compiled", "on"], tmp_path,
                  [signal.SIGINT])
    assert o.returncode == 130, o.describe()
    assert not any(marker in o.stderr for marker in FORBIDDEN), o.describe()
    text = " ".join(error_paragraph(o))
    assert text.startswith("interrupted (Ctrl-C): the compiled step loop, calling FMU 'dut' "
                           "(faulty.fmu), did not return from an FMU call"), o.describe()
    assert "isolate: true" in text, o.describe()


def test_exit_inside_an_in_process_fmu_is_an_error_not_success(faulty, tmp_path) -> None:
    path = scenario(tmp_path, faulty, 2, isolate=False)
    o = run_cli(["run", str(path), "--out", "out"], tmp_path)
    para = assert_clean_error(o, mentions=["component 'dut' at t = 0.29 s", "'faulty.fmu'",
                                           "called exit()", "doStep", "isolate: true"])
    assert o.returncode == 1
    partial = list(tmp_path.glob("out.partial-*"))
    assert len(partial) == 1 and f"{partial[0]}/" in " ".join(para)


def test_an_isolated_fmu_writing_a_length_header_is_still_cut_off_by_the_timeout(
        faulty, tmp_path) -> None:
    path = scenario(tmp_path, faulty, 8, isolate=True)
    o = run_cli(["run", str(path), "--out", "out"], tmp_path, timeout=60)
    assert_clean_error(o, mentions=["component 'dut' at t = 0.29 s", "'faulty.fmu'"])
    text = " ".join(error_paragraph(o))
    assert "within 1 s" in text or "not a reply" in text, o.describe()
    assert left_alive(faulty) == []
    assert len(read_result(tmp_path / "out.incomplete")) == FAIL_AFTER


def test_an_isolated_fmu_that_forks_leaves_no_child(faulty, tmp_path) -> None:
    path = scenario(tmp_path, faulty, 7, isolate=True)
    o = run_cli(["run", str(path), "--out", "out"], tmp_path)
    assert_ok(o)
    left = left_alive(faulty)
    for pid in left:  # do not leave them to the next test
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)
    assert left == []
    assert read_result(tmp_path / "out")["dut.y"][-1] == 100


def test_timeout_inf_means_no_limit(faulty, tmp_path) -> None:
    path = scenario(tmp_path, faulty, 0, isolate=True, timeout=".inf")
    o = run_cli(["run", str(path), "--out", "out"], tmp_path)
    assert_ok(o)
    assert len(read_result(tmp_path / "out")) == 101


def test_check_advises_isolation_for_an_fmu_run_in_the_process(faulty, tmp_path) -> None:
    advice = "component 'dut' runs FMU 'faulty.fmu' in this process"
    inside = run_cli(["check", str(scenario(tmp_path, faulty, 0, isolate=False))], tmp_path)
    assert_ok(inside)
    assert advice in inside.stderr and "isolate: true" in inside.stderr, inside.describe()
    isolated = run_cli(["check", str(scenario(tmp_path, faulty, 0, isolate=True))], tmp_path)
    assert_ok(isolated)
    assert advice not in isolated.stderr, isolated.describe()
