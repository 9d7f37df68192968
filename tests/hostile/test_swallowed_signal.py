"""A stop signal whose handler's exception is swallowed still stops the run. Python runs a
signal handler in whatever the main thread executes; inside a C callback (numba's compiler calls
back into Python through llvmlite; here a ctypes callback) the handler's exception is printed
and dropped, and the run used to go on — compiling, then stepping to the end — ignoring the
signal until SIGKILL. The run now notes the signal and stops at its next step or component."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

BLOCK = '''
import ctypes
import os
import signal
import time

from twmr.core import Component, Output


class SignalledInCallback(Component):
    """Sends itself SIGTERM from inside a C callback while it initializes."""

    y = Output()

    def initialize(self):
        def callback():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(0.2)  # the handler runs here, inside the callback

        ctypes.CFUNCTYPE(None)(callback)()
'''


@pytest.mark.timeout(120)
def test_a_sigterm_swallowed_by_a_c_callback_still_stops_the_run(tmp_path: Path) -> None:
    (tmp_path / "blocks.py").write_text(BLOCK)
    (tmp_path / "s.yaml").write_text(
        "components:\n  b: {kind: 'blocks.py:SignalledInCallback'}\n"
        "  g: {kind: gain}\nconnections: [b.y -> g.u]\n"
        "experiment: {start: 0.0, stop: 200.0, step: 0.001}\n")
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "run", "s.yaml", "--out", "out",
                           "-q"], cwd=tmp_path, capture_output=True, text=True, timeout=100)
    assert done.returncode == 143, done.stderr[-2000:]
    assert "SIGTERM" in done.stderr
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
