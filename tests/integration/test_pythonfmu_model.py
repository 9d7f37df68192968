"""An FMU exported by pythonfmu from a plain class (not ours, with pythonfmu's own binary), run by
the master in a scenario: the importer neither frees it nor gives it our callbacks (see
FmuComponent.__init__), and the process exits cleanly."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
from pythonfmu import FmuBuilder

SOURCE = Path(__file__).resolve().parents[1] / "fmus" / "pyfmu" / "Accumulator.py"
RUN = """
import numpy as np
from twmr.master import simulate
from twmr.scenario import loads
r = simulate(loads('''
components:
  src: {kind: sine, parameters: {frequency: 0.5}}
  acc: {kind: fmu, parameters: {path: %s, k: 3.0}}
connections: [src.y -> acc.u]
experiment: {start: 0.0, stop: 2.0, step: 0.01}
record: {signals: [src.y, acc.y]}
''', source="pyfmu.yaml"))
np.save(%r, np.array(r))
"""


def test_plain_pythonfmu_class_runs_in_a_scenario(tmp_path) -> None:
    fmu = FmuBuilder.build_FMU(SOURCE, dest=tmp_path)
    out = tmp_path / "r.npy"
    subprocess.run([sys.executable, "-c", RUN % (fmu, str(out))], check=True, timeout=120)
    r = np.load(out)
    # y_n = 3 h sum_{k<n} u_k (input held over each step)
    expected = np.concatenate([[0.0], np.cumsum(r["src.y"][:-1]) * 3.0 * 0.01])
    np.testing.assert_allclose(r["acc.y"], expected, atol=1e-12)
