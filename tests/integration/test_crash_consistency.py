"""Results survive the process: SIGKILL mid-run, a segfault inside an FMU, a write error in the
result store. Each leaves the rows recorded before it readable through `twmr.read_result`."""
from __future__ import annotations

import errno
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
from twmr.master.execution import ResultWriteError
from twmr.observers import store as store_module

ROOT = Path(__file__).resolve().parents[2]

COUNTING_RUN = textwrap.dedent("""
    import mmap, sys
    sys.path.insert(0, {root!r})
    from tests.helpers import system
    from twmr.blocks import Integrator, Sine
    from twmr.core import Component, Output
    from twmr.master import simulate

    class Counter(Component):
        '''Writes the number of steps it has taken into a shared page: the truth of how far
        the run got when it is killed.'''
        y = Output(0.0)

        def initialize(self):
            f = open({count!r}, "r+b")
            self.page = mmap.mmap(f.fileno(), 8)

        def do_step(self, t, h):
            self.y += 1.0
            self.page[:8] = int(self.y).to_bytes(8, "little")

    sysm = system([Sine("s"), Integrator("i"), Counter("n")], ["s.y -> i.u"], 1.0e4, 1.0e-3,
                  record=["s.y", "i.y", "n.y"])
    simulate(sysm, {out!r})
""")


def test_sigkill_leaves_at_least_90_percent_of_the_recorded_rows_readable(tmp_path) -> None:
    count, out = tmp_path / "count", tmp_path / "run"
    count.write_bytes(bytes(8))
    proc = subprocess.Popen([sys.executable, "-c", COUNTING_RUN.format(
        root=str(ROOT), count=str(count), out=str(out))])
    try:
        deadline = time.monotonic() + 60
        while int.from_bytes(count.read_bytes(), "little") == 0:
            assert time.monotonic() < deadline and proc.poll() is None
            time.sleep(0.05)
        time.sleep(2.0)  # stepping for 2 s
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    steps = int.from_bytes(count.read_bytes(), "little")
    result = twmr.read_result(out)
    assert result.status == "unknown"  # killed: no summary
    # one row per step from t = 0, each row recorded before the next step was taken
    assert steps > 1000 and 0.9 * steps <= len(result) <= steps + 1
    np.testing.assert_allclose(result["n.y"], np.arange(len(result)))
    np.testing.assert_allclose(result.time, np.arange(len(result)) * 1e-3, atol=1e-9)


@pytest.fixture(scope="module")
def faulty(tmp_path_factory) -> Path:
    return build_c_fmu("faulty", tmp_path_factory.mktemp("fmus"))


def test_segfault_in_an_fmu_keeps_the_rows_recorded_before(tmp_path, faulty) -> None:
    fail_after = 300_000  # ~3 s of stepping: a 0.1 s chunk is a few per cent of it
    scenario = tmp_path / "crash.yaml"
    scenario.write_text(textwrap.dedent(f"""
        components:
          src: {{kind: sine, parameters: {{frequency: 1.0}}}}
          dut:
            kind: fmu
            parameters: {{path: {faulty}, mode: 1, fail_after: {fail_after}}}
        connections: [src.y -> dut.u]
        experiment: {{stop: 1000.0, step: 1.0e-3}}
    """))
    out = tmp_path / "run"
    proc = subprocess.run([sys.executable, "-m", "twmr.cli", "run", str(scenario), "--out",
                           str(out), "--quiet"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == -signal.SIGSEGV, proc.stderr
    partial = list(tmp_path.glob("run.partial-*"))
    assert len(partial) == 1 and not out.exists()
    result = twmr.read_result(partial[0])
    assert 0.9 * fail_after <= len(result) <= fail_after
    np.testing.assert_array_equal(result["dut.y"], np.arange(len(result)))
    np.testing.assert_allclose(result["dut.y2"], 2.0 * result["src.y"])


class _FillsUp:
    """A file that takes `room` bytes, then fails like a full disk."""

    def __init__(self, f, room: int):
        self.f, self.room = f, room

    def write(self, data) -> int:
        if self.room < len(data):
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= len(data)
        return self.f.write(data)

    def __getattr__(self, name):
        return getattr(self.f, name)


def test_write_error_stops_the_run_with_a_clear_error_and_terminates(tmp_path,
                                                                       monkeypatch) -> None:
    real_open = open

    def small_disk(path, mode="r", *args, **kwargs):
        f = real_open(path, mode, *args, **kwargs)
        return _FillsUp(f, 200_000) if str(path).endswith(".arrows") else f

    monkeypatch.setattr(store_module, "open", small_disk, raising=False)
    terminated = []
    from twmr.blocks import Integrator

    monkeypatch.setattr(Integrator, "terminate", lambda self: terminated.append(self.name))
    text = (ROOT / "tests" / "fixtures" / "scenarios" / "loop.yaml").read_text()
    text = text.replace("stop: 1.0", "stop: 2000.0").replace("decimation: 2", "decimation: 1")
    with pytest.raises(ResultWriteError) as err:
        twmr.simulate(twmr.load(text), tmp_path / "run")
    message = str(err.value)
    assert "No space left on device" in message and "terminated" in message
    assert terminated == ["plant"]
    kept = twmr.read_result(tmp_path / "run.incomplete")
    assert len(kept) > 0 and kept.status == "failed"
    np.testing.assert_allclose(np.diff(kept.time), 0.01)
