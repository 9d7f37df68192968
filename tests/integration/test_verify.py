"""`twmr verify` and `twmr.testing.assert_matches`: a run against a reference computed apart
(numpy's sine, written as CSV with its units in the header) passes inside its tube and fails outside
it, saying where and by how much; the tube's time window equals a brute-force one; units are
converted; what cannot be compared is refused."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import twmr
from twmr.core.errors import CosimError
from twmr.testing import assert_matches
from twmr.verify import Tolerance, tube, verify

pytestmark = pytest.mark.timeout(120)

F = 2.0  # [Hz]


def sine_run(tmp_path: Path, name: str, amplitude: float = 1.0, phase: float = 0.0,
             stop: float = 1.0) -> Path:
    scenario = twmr.load(f"""components:
  s: {{kind: sine, parameters: {{amplitude: {amplitude}, frequency: {F}, phase: {phase}}}}}
experiment: {{stop: {stop}, step: 0.01}}
record: {{signals: [s.y]}}
""")
    twmr.simulate(scenario, tmp_path / name)
    return tmp_path / name


def reference(tmp_path: Path, unit: str = "", scale: float = 1.0, phase: float = 0.0,
              name: str = "ref.csv", stop: float = 1.0) -> Path:
    """scale sin(2 pi F t + phase) every 5 ms, by numpy, as CSV."""
    t = np.arange(round(stop / 0.005) + 1) * 0.005
    path = tmp_path / name
    header = f"time [s],s.y [{unit}]" if unit else "time,s.y"
    np.savetxt(path, np.column_stack([t, scale * np.sin(2 * np.pi * F * t + phase)]),
               delimiter=",", header=header, comments="")
    return path


def test_a_run_inside_its_tube_passes_and_one_outside_fails_where_it_leaves(
        tmp_path: Path) -> None:
    ref = reference(tmp_path)
    good = verify(sine_run(tmp_path, "good"), ref, Tolerance(abs=1e-9, rel=1e-9))
    assert good.passed, good.text()
    # 1.01 sin against sin with rel 0.005: outside by 0.005 |sin| wherever sin != 0
    big = sine_run(tmp_path, "big", amplitude=1.01)
    verdict = verify(big, ref, Tolerance(rel=0.005))
    [s] = verdict.signals
    assert not verdict.passed and s.name == "s.y"
    t = np.arange(101) * 0.01
    assert s.worst == pytest.approx(0.005 * np.abs(np.sin(2 * np.pi * F * t)).max(), rel=1e-9)
    assert s.first_out == pytest.approx(0.01)  # the run's first point after 0
    assert "FAIL" in verdict.text() and "s.y" in verdict.text()
    with pytest.raises(AssertionError, match=r"s\.y\s+FAIL"):
        assert_matches(big, ref, rel=0.005)


def test_a_time_shift_is_inside_a_tube_as_wide_as_it(tmp_path: Path) -> None:
    """cos(2 pi F (t - 0.01)) against cos(2 pi F t): flat at both ends of the run, where the
    reference has no values beyond."""
    ref = reference(tmp_path, phase=math.pi / 2)
    late = sine_run(tmp_path, "late", phase=math.pi / 2 - 2 * math.pi * F * 0.01)
    assert not verify(late, ref, Tolerance(rel=1e-3)).passed
    assert not verify(late, ref, Tolerance(rel=1e-3, shift=0.005)).passed
    assert verify(late, ref, Tolerance(rel=1e-3, shift=0.0101)).passed


def test_the_tube_is_the_references_extremes_over_the_window() -> None:
    rng = np.random.default_rng(3)
    t_ref = np.cumsum(rng.uniform(0.001, 0.02, 300))
    y_ref = np.cumsum(rng.normal(size=300))
    t = rng.uniform(t_ref[0], t_ref[-1], 400)
    for shift in (0.0, 0.003, 0.05, 0.4):
        lo, hi = tube(t_ref, y_ref, t, shift)
        for k in range(0, 400, 7):
            dense = np.concatenate([np.linspace(t[k] - shift, t[k] + shift, 50),
                                    t_ref[(t_ref >= t[k] - shift) & (t_ref <= t[k] + shift)]])
            window = np.interp(dense, t_ref, y_ref)
            assert lo[k] == pytest.approx(window.min(), abs=1e-12)
            assert hi[k] == pytest.approx(window.max(), abs=1e-12)


def test_units_are_converted_and_a_short_run_fails(tmp_path: Path) -> None:
    run = reference(tmp_path, unit="m", name="run.csv")
    assert verify(run, reference(tmp_path, unit="mm", scale=1000.0), Tolerance(rel=1e-12)).passed
    assert not verify(run, reference(tmp_path, unit="m", scale=1.01), Tolerance(rel=1e-3)).passed
    with pytest.raises(CosimError, match=r"signal 's\.y' is in 'rad', the run's in 'm'"):
        verify(run, reference(tmp_path, unit="rad"))
    short = reference(tmp_path, unit="m", name="short.csv", stop=0.5)
    verdict = verify(short, reference(tmp_path, unit="m"), Tolerance(rel=1e-3))
    assert "the run covers 0 .. 0.5 s, the reference 0 .. 1 s" in verdict.text()


def test_the_command_prints_plots_and_exits_1_on_failure(tmp_path: Path) -> None:
    ref = reference(tmp_path)
    for name, amplitude, code in (("ok", 1.0, 0), ("off", 1.01, 1)):
        run = sine_run(tmp_path, name, amplitude=amplitude)
        command = [str(Path(sys.executable).parent / "twmr"), "verify", str(run),
                   "--reference", str(ref), "--rel", "0.005", "--plot", str(tmp_path / name)]
        done = subprocess.run(command, capture_output=True, text=True, timeout=100)
        assert done.returncode == code, done.stderr
        assert ("FAIL" in done.stdout) == bool(code)
        assert (tmp_path / f"{name}.png").stat().st_size > 1000


def test_nothing_in_common_is_refused(tmp_path: Path) -> None:
    other = tmp_path / "other.csv"
    other.write_text("time,x\n0,1\n1,2\n")
    with pytest.raises(CosimError, match="no signal in common"):
        verify(sine_run(tmp_path, "run"), other)
    with pytest.raises(CosimError, match="no signal 'x'"):
        verify(sine_run(tmp_path, "run2"), other, signals=["x"])
    with pytest.raises(CosimError, match="every tolerance is 0"):
        Tolerance(rel=0.0)
