"""The signal sources (`twmr.blocks.signals`) against analytic answers and references we did not
write: scipy.signal.square and scipy.signal.chirp, numpy.interp and scipy's interp1d, the
Philox-4x32-10 known-answer vectors of Random123 (kat_vectors), scipy.stats for the noise; the
noise gives one sequence in Python, compiled (numba) and C (an FMU through fmpy)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.signal
import scipy.stats
from scipy.interpolate import interp1d

from twmr.blocks.philox import philox
from twmr.core import ComponentError, ScenarioError
from twmr.scenario import loads
from twmr.testing import Harness


def series(kind: str, points: int, h: float = 1e-3, start: float = 0.0, **params) -> np.ndarray:
    """Output y at start + k h, k = 0..points-1 (rows; a vector output gives columns)."""
    with Harness(kind, parameters=params, start=start, step=h) as dut:
        dut.initialize()
        rows = [dut["y"]]
        for _ in range(points - 1):
            dut.step()
            rows.append(dut["y"])
    return np.array(rows, dtype=float)


def times(n: int, h: float = 1e-3, start: float = 0.0) -> np.ndarray:
    return start + h * np.arange(n)


def test_ramp_rises_at_its_slope_from_its_start_time() -> None:
    y, t = series("ramp", 2001, slope=2.5, time=0.4, offset=-1.0), times(2001)
    np.testing.assert_allclose(y, -1.0 + 2.5 * np.maximum(t - 0.4, 0.0), rtol=0, atol=1e-12)
    slope = np.diff(y[t > 0.4005]) / 1e-3
    np.testing.assert_allclose(slope, 2.5, rtol=1e-9)
    assert np.all(y[t <= 0.4] == -1.0)


def test_pulse_train_matches_scipy_square_and_its_duty() -> None:
    period, width, delay, n = 0.0937, 0.031, 0.2, 20001
    y, t = series("pulse", n, amplitude=3.0, period=period, width=width, delay=delay,
                  offset=0.5), times(n)
    ref = np.where(t >= delay, 0.5 + 3.0 * (scipy.signal.square(
        2 * np.pi * (t - delay) / period, duty=width / period) + 1) / 2, 0.5)
    phase = np.mod(t - delay, period)
    edges = np.array([0.0, width, period])
    clear = np.min(np.abs(phase[:, None] - edges), axis=1) > 1e-9  # not on an edge
    np.testing.assert_array_equal(y[clear], ref[clear])
    on = y[t >= delay] > 1.0
    assert on.mean() == pytest.approx(width / period, abs=2e-3)  # the duty cycle
    assert np.all(y[t < delay] == 0.5)


@pytest.mark.parametrize("interpolation", ["linear", "hold"])
def test_table_matches_numpy_interp_and_scipy_previous(interpolation: str) -> None:
    ts, vs = [0.1, 0.35, 0.35, 0.8, 1.3], [2.0, -1.0, 4.0, 0.5, 0.0]
    n = 1801
    y, t = series("table", n, times=ts, values=vs, interpolation=interpolation), times(n)
    keep = np.min(np.abs(t[:, None] - ts), axis=1) > 1e-9  # on a point (t + h rounded): either
    if interpolation == "linear":
        ref = np.interp(t, ts, vs)
    else:
        ref = interp1d(ts, vs, kind="previous", bounds_error=False,
                       fill_value=(vs[0], vs[-1]))(t)
    np.testing.assert_allclose(y[keep], ref[keep], rtol=0, atol=1e-12)
    assert y[0] == 2.0 and y[-1] == 0.0  # held outside the times


def test_philox_gives_the_random123_known_answers() -> None:
    """Random123's kat_vectors for philox4x32_10."""
    assert philox(0, 0, 0, 0, 0, 0) == (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)
    m = 0xFFFFFFFF
    assert philox(m, m, m, m, m, m) == (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)
    assert philox(0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344, 0xA4093822,
                     0x299F31D0) == (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)
    assert philox.jit(m, m, m, m, m, m) == (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)


N = 40000
#: 5 standard errors: a correct generator fails one of these bounds with probability ~1e-6
Z = 5.0


@pytest.mark.parametrize("distribution", ["gaussian", "uniform"])
def test_noise_mean_variance_distribution_and_independence(distribution: str) -> None:
    y = series("noise", N, distribution=distribution, mean=0.3, stddev=2.0, seed=7, n=2)
    for x in y.T:
        assert abs(x.mean() - 0.3) < Z * 2.0 / math.sqrt(N)
        # var of the sample variance: sigma^4 (kurtosis - 1) / N; kurtosis 3 (gauss), 1.8
        kurt = 3.0 if distribution == "gaussian" else 1.8
        assert abs(x.var() - 4.0) < Z * 4.0 * math.sqrt((kurt - 1) / N)
        r1 = np.corrcoef(x[:-1], x[1:])[0, 1]  # successive samples
        assert abs(r1) < Z / math.sqrt(N)
        ref = scipy.stats.norm(0.3, 2.0) if distribution == "gaussian" else \
            scipy.stats.uniform(0.3 - 2.0 * math.sqrt(3), 4.0 * math.sqrt(3))
        assert scipy.stats.kstest(x, ref.cdf).pvalue > 1e-4
    assert abs(np.corrcoef(y[:, 0], y[:, 1])[0, 1]) < Z / math.sqrt(N)  # the two elements
    if distribution == "uniform":
        assert y.min() >= 0.3 - 2.0 * math.sqrt(3) and y.max() < 0.3 + 2.0 * math.sqrt(3)


def test_noise_is_held_over_its_period_and_set_by_its_seed() -> None:
    a = series("noise", 301, h=1e-3, seed=11, period=5e-3)
    changes = np.flatnonzero(np.diff(a))  # a new sample at k * 5 steps only
    assert set(changes + 1) <= set(range(0, 301, 5)) and len(changes) > 50
    assert np.array_equal(a, series("noise", 301, h=1e-3, seed=11, period=5e-3))
    assert not np.array_equal(a, series("noise", 301, h=1e-3, seed=12, period=5e-3))
    # sample k is the same whatever the step that reaches it
    b = series("noise", 61, h=5e-3, seed=11, period=5e-3)
    np.testing.assert_array_equal(a[::5], b)


def test_noise_sequence_is_the_same_in_python_compiled_and_c(tmp_path: Path) -> None:
    from fmpy import simulate_fmu

    from twmr.fmi.cexport import export_c_fmu

    params = {"n": 3, "seed": 2**40 + 5, "period": 2e-3, "mean": 1.0, "stddev": 0.5}
    h, n = 1e-3, 200
    python = series("noise", n + 1, h=h, **params)
    with Harness("noise", parameters=params, step=h) as dut:
        dut.initialize()
        kern, y = dut.component.kernel(h), (tuple(dut["y"]),)
        compiled = [y[0]]
        for k in range(n):
            _, y = kern.step.jit(k * h, h, kern.state, y, (), kern.params)
            compiled.append(y[0])
    np.testing.assert_array_equal(python, np.array(compiled))
    fmu = export_c_fmu("noise", tmp_path / "noise.fmu", params)
    res = simulate_fmu(str(fmu), stop_time=n * h, step_size=h, output_interval=h)
    c = np.column_stack([res[f"y[{i}]"] for i in (1, 2, 3)])
    np.testing.assert_array_equal(python, c)


def test_chirp_matches_scipy_chirp_and_its_instantaneous_frequency() -> None:
    n, h = 20001, 1e-3
    y, t = series("chirp", n, h=h, amplitude=2.0, f0=1.0, f1=9.0, duration=15.0, time=1.0,
                  phase=0.3), times(n, h)
    tau = np.maximum(t - 1.0, 0.0)
    ref = 2.0 * scipy.signal.chirp(tau, f0=1.0, t1=15.0, f1=9.0, method="linear",
                                   phi=np.degrees(0.3) - 90.0)  # sin(x) = cos(x - 90 deg)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-9)
    up = np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))  # upward zero crossings
    ups = t[up] - y[up] * h / (y[up + 1] - y[up])
    mid, freq = (ups[1:] + ups[:-1]) / 2, 1.0 / np.diff(ups)
    expect = 1.0 + (9.0 - 1.0) * (mid - 1.0) / 15.0
    late = mid > 2.0
    np.testing.assert_allclose(freq[late], expect[late], rtol=2e-3)


SCENARIO = """components:
  src: {{kind: {kind}, parameters: {{{params}}}}}
experiment: {{stop: 1.0, step: 0.001}}
"""


@pytest.mark.parametrize(("kind", "params", "names"), [
    ("pulse", "period: 0.1, width: 0.2", "'width'"),
    ("pulse", "period: 0.0", "'period'"),
    ("table", "times: [0, 2, 1], values: [1, 2, 3]", "times"),
    ("table", "times: [0, 1, 2], values: [1, 2]", "values"),
    ("table", "interpolation: cubic", "interpolation"),
    ("noise", "distribution: pink", "distribution"),
    ("chirp", "duration: 0", "duration"),
])
def test_bad_parameters_are_refused_at_check_naming_block_and_parameter(
        kind: str, params: str, names: str) -> None:
    with pytest.raises(ScenarioError) as err:
        loads(SCENARIO.format(kind=kind, params=params))
    text = str(err.value)
    assert f"component 'src' ({kind})" in text and names.strip("'") in text
    assert "Fix:" in text and "Traceback" not in text


def test_noise_period_off_the_step_is_refused_at_check_with_the_instance_step() -> None:
    text = SCENARIO.format(kind="noise", params="period: 0.0025")
    with pytest.raises(ScenarioError, match=r"component 'src' \(noise\): period = 0.0025 s is "
                       r"not a multiple of the step 0.001 s \(2.5 steps\).*Fix: give period"):
        loads(text)
    loads(text.replace("0.0025", "0.003"))
    multiple = text.replace("src: {", "src: {step_multiple: 2, ")
    with pytest.raises(ScenarioError, match=r"not a multiple of the step 0\.002 s"):
        loads(multiple.replace("0.0025", "0.003"))


def test_noise_period_off_the_step_is_refused_before_the_run() -> None:
    with pytest.raises(ComponentError, match=r"noise: period = 0.0025 s is not a multiple of "
                       r"the step 0.001 s.*Fix:"), Harness("noise",
                                                          parameters={"period": 2.5e-3}) as dut:
        dut.initialize()
