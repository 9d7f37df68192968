"""Run-time signals to `twmr run` in a subprocess: SIGINT (Ctrl-C), SIGTERM, SIGHUP, and a double
signal 50 ms apart, during (a) a long simulation-only run and (b) a bench run (ODrive drives on
the virtual CAN bus, emulated).

The promise checked: exit 130 for Ctrl-C, 128 + signum for SIGTERM / SIGHUP; stderr is one
paragraph, no traceback, saying the run was interrupted and where the results are; the rows so
far are in OUT.incomplete with status 'interrupted'; the previous result in OUT is unchanged and
no OUT.partial-<pid> nor half-written export is left behind; on the bench, the frame log in
OUT.incomplete ends, for both drives, with zero torque followed by Set_Axis_State IDLE. A double
signal is the first one's: its exit status and message.

The simulation-only run is tests/fixtures/scenarios/loop.yaml with decimation 1 and
`--set experiment.stop=1000`; at the fixture's step (10 ms) those 1e5 steps take about 0.1 s on
this machine, over before a signal could land, so the step is also set to 0.1 ms (1e7 steps).
The bench's channel name ends in a letter: a name ending in a number above 65535 breaks the BLF
frame log (test_can_faults.py::test_frame_log_on_a_channel_named_with_a_large_number).
"""
from __future__ import annotations

import contextlib
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time
import uuid
from pathlib import Path

import pytest

from tests.hostile.runner import (
    BENCH,
    FORBIDDEN,
    GOOD_TEXT,
    MAX_ERROR_LINES,
    MEMORY_CAP,
    Outcome,
    _lines,
    error_paragraph,
    run_cli,
    write,
)
from twmr.hw import protocol as p
from twmr.hw.replay import Decoder, decode_log
from twmr.result import read_result

LONG_TEXT = GOOD_TEXT.replace("decimation: 2", "decimation: 1")
assert LONG_TEXT != GOOD_TEXT
SIM_ARGS = ["long.yaml", "--set", "experiment.stop=1000", "--set", "experiment.step=0.0001"]
EXIT_TIMEOUT = 30.0  # s from the (last) signal to the end of the process


def _limits() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP, MEMORY_CAP))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


def tree(folder: Path) -> dict[str, bytes]:
    return {str(q.relative_to(folder)): q.read_bytes() for q in sorted(folder.rglob("*"))
            if q.is_file()}


_FIRST_SIZE: dict[Path, int] = {}


def _grown(cwd: Path, ready: str) -> bool:
    """A file matching `ready` exists and, for a result store (`*.arrows`), has grown since it
    was first seen: rows were written, so the run is stepping (a loaded machine may take
    seconds from creating the store to the first step)."""
    for path in cwd.glob(ready):
        if path.suffix != ".arrows":
            return True
        size = path.stat().st_size
        if size > _FIRST_SIZE.setdefault(path, size):
            return True
    return False


def signal_run(args: list[str], cwd: Path, ready: str, delay: float,
               signals: list[tuple[int, float]]) -> Outcome:
    """`twmr *args` in `cwd`; once a file matching the glob `ready` exists (the run is under way)
    and `delay` s more have passed, each (signal, pause before it) of `signals` is sent."""
    with tempfile.TemporaryDirectory(prefix="twmr-signal-io-") as io_dir:
        io = Path(io_dir)
        env = dict(os.environ, MPLBACKEND="Agg")
        env.pop("PYTHONSTARTUP", None)
        with open(io / "stdout", "wb") as fout, open(io / "stderr", "wb") as ferr:
            t0 = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "twmr.cli", *args], cwd=cwd,
                                    stdin=subprocess.DEVNULL, stdout=fout, stderr=ferr, env=env,
                                    preexec_fn=_limits, start_new_session=True)

            def kill(why: str) -> None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
                err = (io / "stderr").read_bytes().decode(errors="replace")
                pytest.fail(f"{why}: twmr {' '.join(args)}\nstderr:\n{err[-2000:]}",
                            pytrace=False)

            deadline = time.monotonic() + 60
            while not _grown(cwd, ready):
                if proc.poll() is not None:
                    err = (io / "stderr").read_bytes().decode(errors="replace")
                    pytest.fail(f"the run ended (exit {proc.returncode}) before {ready} "
                                f"appeared; stderr:\n{err[-2000:]}", pytrace=False)
                if time.monotonic() > deadline:
                    kill(f"{ready} did not appear within 60 s")
                time.sleep(0.02)
            time.sleep(delay)
            if proc.poll() is not None:
                err = (io / "stderr").read_bytes().decode(errors="replace")
                pytest.fail(f"the run ended by itself (exit {proc.returncode}) {delay:g} s after "
                            f"{ready} appeared, before the signal; stderr:\n{err[-2000:]}",
                            pytrace=False)
            for sig, pause in signals:
                time.sleep(pause)
                with contextlib.suppress(ProcessLookupError):
                    os.kill(proc.pid, sig)
            sent = time.monotonic()
            status = usage = None
            while status is None:
                pid, st, ru = os.wait4(proc.pid, os.WNOHANG)
                if pid:
                    status, usage = st, ru
                elif time.monotonic() - sent > EXIT_TIMEOUT:
                    kill(f"hang: still running {EXIT_TIMEOUT:g} s after the signal")
                else:
                    time.sleep(0.02)
            code = os.waitstatus_to_exitcode(status)
            proc.returncode = code
            elapsed = time.perf_counter() - t0
        stdout = (io / "stdout").read_bytes().decode(errors="replace")
        stderr = (io / "stderr").read_bytes().decode(errors="replace")
    return Outcome(list(args), cwd, code, stdout, stderr, elapsed, proc.pid,
                   usage.ru_maxrss * 1024)


def label(sig: int) -> str:
    return "Ctrl-C" if sig == signal.SIGINT else signal.Signals(sig).name


def expected_exit(sig: int) -> int:
    return 130 if sig == signal.SIGINT else 128 + int(sig)


def interrupted_problems(o: Outcome, out: Path, sig: int, previous: dict[str, bytes]
                         ) -> list[str]:
    """What breaks the promise, every item of it (not only the first): [] when all hold."""
    problems: list[str] = []
    want = expected_exit(sig)
    if o.returncode != want:
        problems.append(f"exit {o.returncode}, expected {want}")
    incomplete = out.with_name(out.name + ".incomplete")
    for stream in (o.stderr, o.stdout):
        problems += [f"{marker!r} printed" for marker in FORBIDDEN if marker in stream]
    lines = _lines(o.stderr.rstrip())
    para = error_paragraph(o)
    if not o.stderr.strip():
        problems.append("nothing on stderr")
    elif para != lines or not all(line.strip() for line in lines) or \
            len(lines) > MAX_ERROR_LINES:
        problems.append("stderr is not one paragraph starting with 'interrupted'")
    text = "\n".join(lines)
    if o.stderr.strip() and not text.startswith(f"interrupted ({label(sig)})"):
        problems.append(f"stderr does not start with 'interrupted ({label(sig)})'")
    if o.stderr.strip() and incomplete.name not in text:
        problems.append(f"stderr does not say the results are in {incomplete.name}/")
    if tree(out) != previous:
        problems.append(f"the previous result in {out.name}/ changed")
    left = sorted(q.name for q in out.parent.glob(out.name + ".partial-*"))
    if left:
        problems.append(f"left behind: {left}")
    if not incomplete.is_dir():
        problems.append(f"no {incomplete.name}/")
        return problems
    temporary = sorted(q.name for q in incomplete.iterdir() if q.name.startswith(".partial-"))
    if temporary:
        problems.append(f"half-written files left in {incomplete.name}/: {temporary}")
    try:
        result = read_result(incomplete)
    except Exception as err:  # noqa: BLE001 - reported with the rest
        problems.append(f"{incomplete.name}/ unreadable: {err}")
        return problems
    if not len(result):
        problems.append(f"no rows in {incomplete.name}/")
    if result.status != "interrupted":
        problems.append(f"status {result.status!r} in {incomplete.name}/")
    error = str(result.summary.get("error", ""))
    if not error.startswith(f"interrupted ({label(sig)})"):
        problems.append(f"summary error {error!r}")
    return problems


def bench_log_problems(out: Path) -> list[str]:
    """The frame log in OUT.incomplete: both drives driven, then zero torque and IDLE last."""
    log = out.with_name(out.name + ".incomplete") / "motor_frames.blf"
    if not log.is_file():
        return [f"no frame log {log.parent.name}/{log.name}"]
    try:
        decoded = decode_log(log, Decoder())
    except Exception as err:  # noqa: BLE001 - reported with the rest
        return [f"the frame log does not decode: {type(err).__name__}: {err}"]
    problems = []
    for node in (0, 1):
        sent = [d for d in decoded if d.direction == "Tx" and d.node == node
                and d.signal in ("torque_command", "requested_state", "estop")]
        if not any(abs(d.value) > 1.0 for d in sent if d.signal == "torque_command"):
            problems.append(f"node {node}: never driven in the log")
        tail = [(d.signal, d.value) for d in sent[-2:]]
        if tail != [("torque_command", 0.0), ("requested_state", p.AXIS_IDLE)]:
            problems.append(f"node {node}: the log ends with {tail}, not zero torque then IDLE")
    return problems


@pytest.fixture
def cwd(tmp_path: Path) -> Path:
    """A folder with loop.yaml, long.yaml and a good result of loop.yaml in out/. Only the
    result is required here (completed, with rows): how `twmr run` exits is what the signal
    cases check."""
    write(tmp_path, "loop.yaml", GOOD_TEXT)
    write(tmp_path, "long.yaml", LONG_TEXT)
    good = run_cli(["run", "loop.yaml", "--out", "out", "-q"], tmp_path)
    result = read_result(tmp_path / "out")
    assert result.status == "completed" and len(result) > 0, good.describe()
    return tmp_path


SIGNALS = {
    "SIGINT": [(signal.SIGINT, 0.0)],
    "SIGTERM": [(signal.SIGTERM, 0.0)],
    "SIGHUP": [(signal.SIGHUP, 0.0)],
    "double-ctrl-c": [(signal.SIGINT, 0.0), (signal.SIGINT, 0.05)],
    "double-SIGTERM": [(signal.SIGTERM, 0.0), (signal.SIGTERM, 0.05)],
}


@pytest.mark.parametrize("how", list(SIGNALS))
def test_signal_during_a_long_simulation(cwd: Path, how: str) -> None:
    out = cwd / "out"
    previous = tree(out)
    signals = SIGNALS[how]
    o = signal_run(["run", *SIM_ARGS, "--out", "out", "-q"], cwd, "out.partial-*/result.arrows",
                   0.3, signals)
    problems = interrupted_problems(o, out, signals[0][0], previous)
    assert not problems, "\n".join(problems) + "\n" + o.describe()


@pytest.mark.parametrize("how", list(SIGNALS))
def test_signal_during_a_bench_run(cwd: Path, how: str) -> None:
    out = cwd / "out"
    previous = tree(out)
    signals = SIGNALS[how]
    # the host's and the drives' watchdogs and the heartbeat timeout sized for a loaded machine
    # (the emulated drives' own 0.1 s watchdog tripped at load 20): this case is about signals,
    # not a late frame
    o = signal_run(["run", str(BENCH), "--out", "out", "-q", "--set",
                    f"motor.channel=sig-{uuid.uuid4().hex[:12]}-x",
                    "--set", "motor.watchdog_periods=50", "--set", "motor.drive_watchdog=0.5",
                    "--set", "motor.heartbeat_timeout=1.0"], cwd,
                   "out.partial-*/result.arrows", 0.5, signals)
    problems = interrupted_problems(o, out, signals[0][0], previous) + bench_log_problems(out)
    assert not problems, "\n".join(problems) + "\n" + o.describe()
