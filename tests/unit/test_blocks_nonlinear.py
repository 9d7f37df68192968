"""The nonlinear blocks (`twmr.blocks.nonlinear`) against references we did not write
(numpy.clip, numpy.interp, scipy's interp1d and RegularGridInterpolator) and analytic answers
(rate-limited ramps, the backlash dead band, the relay's switching points); vectors of n
elements; bad tables refused at `twmr check`; each kind exported as a C FMU (`twmr export`) and
run in fmpy against the Python block; a scenario chaining them runs bit-identical compiled."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator, interp1d

import twmr
from twmr.core import CosimError, ScenarioError
from twmr.scenario import loads
from twmr.testing import Harness

U = np.linspace(-3.0, 3.0, 601)


def feed(kind: str, inputs: dict[str, np.ndarray], h: float = 1e-3, **params) -> np.ndarray:
    """y after each input row: write the inputs, evaluate (feedthrough), read y, then step."""
    rows = []
    first = {k: v[0] for k, v in inputs.items()}
    with Harness(kind, parameters=params, step=h) as dut:
        dut.set(**{k: _port(v) for k, v in first.items()})
        dut.initialize()
        for i in range(len(next(iter(inputs.values())))):
            dut.set(**{k: _port(v[i]) for k, v in inputs.items()})
            if dut.component.has_feedthrough:
                dut.evaluate()
            rows.append(dut["y"])
            dut.step()
    return np.array(rows, dtype=float)


def _port(v: np.ndarray | float) -> float | tuple[float, ...]:
    return tuple(float(x) for x in v) if np.ndim(v) else float(v)


def wide(x: np.ndarray, n: int = 3) -> np.ndarray:
    """Rows of n elements: x, x + 0.37, x - 0.61, ... (distinct values per element)."""
    return np.column_stack([x + 0.37 * k * (-1.65) ** k for k in range(n)])


def test_saturation_is_numpy_clip_element_wise() -> None:
    u = wide(U)
    y = feed("saturation", {"u": u}, n=3, lower=-1.2, upper=0.7)
    np.testing.assert_array_equal(y, np.clip(u, -1.2, 0.7))
    assert np.array_equal(feed("saturation", {"u": U}, lower=-1, upper=1), np.clip(U, -1, 1))


def test_dead_zone_removes_the_band_and_shifts_the_rest() -> None:
    u = wide(U)
    y = feed("dead_zone", {"u": u}, n=3, lower=-0.4, upper=0.9)
    expect = np.where(u > 0.9, u - 0.9, np.where(u < -0.4, u + 0.4, 0.0))
    np.testing.assert_allclose(y, expect, rtol=0, atol=1e-15)


def test_quantizer_rounds_to_the_nearest_level() -> None:
    u = wide(U)
    y = feed("quantizer", {"u": u}, n=3, interval=0.25)
    levels = y / 0.25
    np.testing.assert_allclose(levels, np.round(levels), atol=1e-12)  # on the grid
    assert np.all(np.abs(y - u) <= 0.125 + 1e-12)  # the nearest level
    assert feed("quantizer", {"u": np.array([0.125, -0.125, 0.3, 1.0])}, interval=0.25
                ).tolist() == [0.25, 0.0, 0.25, 1.0]  # halves go up


def test_rate_limiter_follows_a_step_at_the_given_rates() -> None:
    h, n = 1e-3, 3000
    u = np.where(np.arange(n) < 1500, 2.0, -1.0)  # up by 2, then down by 3
    y = feed("rate_limiter", {"u": u}, h=h, rising=4.0, falling=1.5, y0=0.0)
    k = np.arange(n)
    up = np.minimum(4.0 * h * k, 2.0)  # 0.5 s to reach 2 at 4 per second
    down = np.maximum(2.0 - 1.5 * h * (k - 1500), -1.0)  # 2 s to fall by 3 at 1.5 per second
    np.testing.assert_allclose(y, np.where(k <= 1500, up, down), rtol=0, atol=1e-9)
    assert np.max(np.abs(np.diff(y))) <= 4.0 * h + 1e-12


def test_backlash_holds_within_its_dead_band_and_follows_outside() -> None:
    up, down = np.linspace(0.0, 2.0, 201), np.linspace(2.0, -1.0, 301)
    u = np.concatenate([up, down[1:]])
    y = feed("backlash", {"u": u}, width=0.6, y0=0.0)
    np.testing.assert_allclose(y[:201], np.maximum(up - 0.3, 0.0), atol=1e-12)  # pushed up
    turn = down[1:]
    held = turn > 2.0 - 0.6  # reversed: the slack is crossed first, the output stays
    np.testing.assert_allclose(y[201:][held], 1.7, atol=1e-12)
    np.testing.assert_allclose(y[201:][~held], turn[~held] + 0.3, atol=1e-12)  # pulled down


def test_relay_switches_at_its_points_with_hysteresis() -> None:
    t = np.arange(0, 4.0, 1e-3)
    u = np.sin(2 * np.pi * t + 0.001)  # off the exact switching points
    y = feed("relay", {"u": u}, on_point=0.5, off_point=-0.5, on_value=2.0, off_value=-3.0)
    on = y == 2.0
    assert np.all((y == 2.0) | (y == -3.0))
    rising = np.flatnonzero(~on[:-1] & on[1:]) + 1
    falling = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    # on at the first sample with sin >= 0.5 (phase pi/6), off at sin <= -0.5 (phase 7 pi/6)
    assert len(rising) == 4 and len(falling) == 4
    assert np.all(u[rising] >= 0.5) and np.all(u[rising - 1] < 0.5)
    assert np.all(u[falling] <= -0.5) and np.all(u[falling - 1] > -0.5)
    np.testing.assert_allclose(np.mod(2 * np.pi * t[rising], 2 * np.pi), np.pi / 6, atol=0.01)
    np.testing.assert_allclose(np.mod(2 * np.pi * t[falling], 2 * np.pi), 7 * np.pi / 6,
                               atol=0.01)
    between = (u > -0.5) & (u < 0.5)
    assert np.any(on & between) and np.any(~on & between)  # the state decides in the band


BP, VAL = [-1.0, 0.0, 0.5, 2.0], [3.0, -1.0, 0.0, 4.0]


@pytest.mark.parametrize("extrapolation", ["hold", "linear", "error"])
def test_lookup_1d_matches_numpy_interp_and_scipy_interp1d(extrapolation: str) -> None:
    u = wide(U)
    y = feed("lookup_1d", {"u": u}, n=3, breakpoints=BP, values=VAL,
             extrapolation=extrapolation)
    if extrapolation == "hold":
        ref = np.interp(u, BP, VAL)
    elif extrapolation == "linear":
        ref = interp1d(BP, VAL, fill_value="extrapolate")(u)
    else:
        ref = interp1d(BP, VAL, bounds_error=False, fill_value=np.nan)(u)
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12)
    assert (extrapolation == "error") == bool(np.isnan(y).any())


@pytest.mark.parametrize("extrapolation", ["hold", "linear", "error"])
def test_lookup_2d_matches_regular_grid_interpolator(extrapolation: str) -> None:
    bx, by = np.array([-1.0, 0.5, 2.0]), np.array([0.0, 1.0, 1.5, 3.0])
    grid = np.add.outer(bx ** 2, np.sin(by)) * np.array([1.0, -2.0, 0.5, 3.0])
    rng = np.random.default_rng(4)
    u1, u2 = rng.uniform(-2.0, 3.0, (400, 2)), rng.uniform(-1.0, 4.0, (400, 2))
    y = feed("lookup_2d", {"u1": u1, "u2": u2}, n=2, breakpoints1=bx, breakpoints2=by,
             values=grid, extrapolation=extrapolation)
    if extrapolation == "hold":
        f = RegularGridInterpolator((bx, by), grid)
        ref = f(np.stack([np.clip(u1, -1, 2), np.clip(u2, 0, 3)], axis=-1))
    else:
        f = RegularGridInterpolator((bx, by), grid, bounds_error=False,
                                    fill_value=None if extrapolation == "linear" else np.nan)
        ref = f(np.stack([u1, u2], axis=-1))
    np.testing.assert_allclose(y, ref, rtol=0, atol=1e-12)


SCENARIO = """components:
  blk: {{kind: {kind}, parameters: {{{params}}}}}
open: [{open}]
experiment: {{stop: 1.0, step: 0.001}}
"""


@pytest.mark.parametrize(("kind", "params", "names"), [
    ("saturation", "lower: 2, upper: 1", "lower = 2 is above upper = 1"),
    ("dead_zone", "lower: 0.5, upper: -0.5", "lower"),
    ("relay", "on_point: -1, off_point: 1", "off_point"),
    ("quantizer", "interval: 0", "interval"),
    ("lookup_1d", "breakpoints: [0, 2, 1], values: [1, 2, 3]",
     "breakpoints must be strictly increasing, but breakpoints[3] = 1 follows breakpoints[2]"),
    ("lookup_1d", "breakpoints: [0, 1, 1], values: [1, 2, 3]", "breakpoints"),
    ("lookup_1d", "breakpoints: [0, 1, 2], values: [1, 2]", "values has 2 values"),
    ("lookup_1d", "extrapolation: nearest", "extrapolation"),
    ("lookup_2d", "breakpoints1: [0, 1], breakpoints2: [0, 1, 2], values: [[1, 2], [3, 4]]",
     "2 rows (one per breakpoints1) of 3 values"),
    ("lookup_2d", "breakpoints1: [1, 0]", "breakpoints1"),
])
def test_bad_parameters_are_refused_at_check_naming_block_and_parameter(
        kind: str, params: str, names: str) -> None:
    ins = "blk.u1, blk.u2" if kind == "lookup_2d" else "blk.u"
    with pytest.raises(ScenarioError) as err:
        loads(SCENARIO.format(kind=kind, params=params, open=ins))
    text = str(err.value)
    assert f"component 'blk' ({kind})" in text and names in text, text
    assert "Fix:" in text and "Traceback" not in text and text.count("\n") <= 1


KINDS = ["saturation", "dead_zone", "rate_limiter", "quantizer", "backlash", "relay",
         "lookup_1d", "lookup_2d", "ramp", "pulse", "table", "noise", "chirp"]


@pytest.mark.parametrize("kind", KINDS)
def test_each_kind_exports_with_twmr_export_and_runs_in_fmpy(kind: str, tmp_path: Path) -> None:
    """`twmr export KIND --set n=2`, then the FMU driven by fmpy as `feed` drives the block:
    inputs written, outputs read, a step; its rows equal the Python block's within 1e-12."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from twmr.cli import main
    from twmr.registry import lookup

    declared = lookup(kind).declared()
    sized = "n" in declared
    out = tmp_path / f"{kind}.fmu"
    assert main(["export", kind, "--out", str(out), *(["--set", "n=2"] if sized else [])]) == 0
    h, n = 0.01, 150
    wave = 2.5 * np.sin(3.0 * h * np.arange(n))
    ins = {name: wide(wave, 2) if sized else wave
           for name, var in declared.items() if var.kind == "input"}
    if kind == "lookup_2d":
        ins["u2"] = ins["u2"][:, ::-1] * 0.7
    md = read_model_description(str(out))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(out)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName=kind)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    ys = [refs[f"y[{i + 1}]"] for i in range(2)] if sized else [refs["y"]]
    rows = []
    for k in range(n):
        for name, values in ins.items():
            names = [f"{name}[{i + 1}]" for i in range(2)] if sized else [name]
            fmu.setReal([refs[m] for m in names], list(np.ravel(values[k])))
        rows.append(fmu.getReal(ys))
        fmu.doStep(k * h, h)
    fmu.terminate()
    fmu.freeInstance()
    params = {"n": 2} if sized else {}
    python = feed(kind, ins, h=h, **params) if ins else _source(kind, h, n - 1, **params)
    np.testing.assert_allclose(np.array(rows), python.reshape(n, -1), rtol=0, atol=1e-12)
    assert np.ptp(python) > 0  # the run exercised the block


def _source(kind: str, h: float, steps: int, **params) -> np.ndarray:
    with Harness(kind, parameters=params, step=h) as dut:
        dut.initialize()
        rows = [dut["y"]]
        for _ in range(steps):
            dut.step()
            rows.append(dut["y"])
    return np.array(rows, dtype=float)


CHAIN = """components:
  sig: {kind: chirp, parameters: {amplitude: 3.0, f0: 0.5, f1: 5.0, duration: 2.0}}
  wob: {kind: noise, parameters: {n: 1, seed: 3, stddev: 0.2, period: 0.004}}
  mix: {kind: sum}
  sat: {kind: saturation, parameters: {lower: -2.0, upper: 2.5}}
  dz: {kind: dead_zone, parameters: {lower: -0.2, upper: 0.2}}
  rl: {kind: rate_limiter, parameters: {rising: 20.0, falling: 10.0}}
  q: {kind: quantizer, parameters: {interval: 0.05}}
  bl: {kind: backlash, parameters: {width: 0.3}}
  rel: {kind: relay, parameters: {on_point: 0.5, off_point: -0.5}}
  lut: {kind: lookup_1d, parameters: {breakpoints: [-2, 0, 1, 3], values: [1, 0, 2, -1],
                                      extrapolation: linear}}
  lut2: {kind: lookup_2d, parameters: {extrapolation: linear}}
  tab: {kind: table, parameters: {times: [0, 0.5, 1.5], values: [0, 1, -1],
                                   interpolation: hold}}
  pul: {kind: pulse, parameters: {period: 0.25, width: 0.1}}
  ramp: {kind: ramp, parameters: {slope: 0.5}}
  vn: {kind: noise, parameters: {n: 3, seed: 9, distribution: uniform}}
  vs: {kind: saturation, parameters: {n: 3, lower: -0.5, upper: 0.5}}
  vr: {kind: relay, parameters: {n: 3, on_point: 0.2, off_point: -0.2}}
  vl: {kind: lookup_2d, parameters: {n: 3, extrapolation: linear}}
  vb: {kind: backlash, parameters: {n: 3, width: 0.2}}
  vrl: {kind: rate_limiter, parameters: {n: 3, rising: 30.0, falling: 30.0}}
  vq: {kind: quantizer, parameters: {n: 3, interval: 0.1}}
  vlut: {kind: lookup_1d, parameters: {n: 3}}
  vdz: {kind: dead_zone, parameters: {n: 3}}
connections:
  - sig.y -> mix.u1
  - wob.y -> mix.u2
  - mix.y -> sat.u
  - sat.y -> dz.u
  - dz.y -> rl.u
  - rl.y -> q.u
  - q.y -> bl.u
  - bl.y -> rel.u
  - bl.y -> lut.u
  - lut.y -> lut2.u1
  - tab.y -> lut2.u2
  - vn.y -> vs.u
  - vn.y -> vr.u
  - vs.y -> vl.u1
  - vr.y -> vl.u2
  - vl.y -> vb.u
  - vb.y -> vrl.u
  - vrl.y -> vq.u
  - vq.y -> vlut.u
  - vlut.y -> vdz.u
experiment: {stop: 2.0, step: 0.001}
"""


def test_a_chain_of_the_blocks_runs_bit_identical_in_python_and_compiled(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    results = {}
    for mode in ("off", "on"):
        monkeypatch.setenv("TWMR_COMPILED", mode)
        result = twmr.simulate(twmr.load(CHAIN), tmp_path / mode)
        summary = (tmp_path / mode / "summary.json").read_text()
        assert ('"algorithm.compiled": true' in summary) == (mode == "on"), summary
        results[mode] = result.to_pandas()
    python, compiled = results["off"], results["on"]
    assert list(python.columns) == list(compiled.columns)
    np.testing.assert_array_equal(python.to_numpy(), compiled.to_numpy())
    assert python["rel.y"].nunique() == 2 and python["sat.y"].max() == 2.5
    assert math.isclose(python["ramp.y"].iloc[-1], 1.0)
    assert python["vdz.y[3]"].abs().max() > 0 and python["vr.y[2]"].nunique() == 2


UNITS = """components:
  speed: {kind: constant, parameters: {value: 10.0}}
  a: {kind: saturation, parameters: {unit: rad/s, lower: -1000, upper: 1000}}
  b: {kind: saturation, parameters: {unit: rpm, lower: -3000, upper: "5 rad/s"}}
connections: [speed.y -> a.u, a.y -> b.u]
experiment: {stop: 0.01, step: 0.001}
"""


def test_a_unit_makes_the_ports_and_limits_convert(tmp_path: Path) -> None:
    system = loads(UNITS)
    b = system.components["b"]
    assert b.variables["u"].unit == b.variables["y"].unit == b.variables["upper"].unit == "rpm"
    assert b.upper == pytest.approx(5 * 60 / (2 * math.pi))  # "5 rad/s" given, held in rpm
    frame = twmr.simulate(twmr.load(UNITS)).to_pandas()
    assert frame["a.y"].iloc[-1] == 10.0  # rad/s
    # the wire converts 10 rad/s to 95.5 rpm, which the limit of 5 rad/s = 47.7 rpm clips (10
    # unconverted would pass)
    assert frame["b.y"].iloc[-1] == pytest.approx(5 * 60 / (2 * math.pi))
    with pytest.raises(ScenarioError, match="furlong"):
        loads(UNITS.replace("unit: rpm", "unit: furlong"))
    from fmpy import read_model_description

    from twmr.fmi.cexport import export_c_fmu

    md = read_model_description(str(export_c_fmu("saturation", tmp_path / "s.fmu",
                                                  {"unit": "N.m", "n": 2})))
    units = {v.name: v.declaredType or v.unit for v in md.modelVariables}
    assert units["u[1]"] == units["y[2]"] == units["lower"] == "N.m"


def test_lookup_error_extrapolation_stops_the_run_naming_the_block() -> None:
    text = """components:
  ramp: {kind: ramp, parameters: {slope: 1.0}}
  lut: {kind: lookup_1d, parameters: {breakpoints: [0, 0.5], values: [0, 1], extrapolation: error}}
connections: [ramp.y -> lut.u]
experiment: {stop: 1.0, step: 0.01}
"""
    with pytest.raises(CosimError) as err:
        twmr.simulate(twmr.load(text))
    assert "component 'lut'" in str(err.value) and "output 'y' is nan" in str(err.value)
    assert "t = 0.51" in str(err.value)  # the first point past the last breakpoint


@pytest.mark.parametrize("kind", ["relay", "backlash", "rate_limiter", "noise"])
def test_a_saved_state_restores_the_memory_of_the_block(kind: str) -> None:
    wave = 2.0 * np.sin(np.linspace(0.0, 12.0, 120))
    inputs = {"u": wave} if kind != "noise" else {}
    with Harness(kind, parameters={"n": 2}, step=0.01) as dut:
        dut.initialize()

        def run(k0: int, k1: int) -> list:
            rows = []
            for k in range(k0, k1):
                dut.step(**{name: (float(v[k]), -float(v[k])) for name, v in inputs.items()})
                rows.append(dut["y"])
            return rows
        run(0, 40)
        saved = dut.component.get_state()
        first = run(40, 120)
        dut.component.set_state(saved)
        dut.n = 40
        assert run(40, 120) == first
