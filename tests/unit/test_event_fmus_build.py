"""The event, type and unit test FMUs in tests/fmus/ (bounce2, bounce3, stair2, discin2, types3,
clock3, mixed2, units2, roberts3) built at test time and checked with fmpy alone (not with twmr)
against their analytic answers: the bouncing ball's bounce times, the staircase's time events,
discrete inputs applied in event mode (and rejected in continuous-time mode), every FMI 3.0 type fed
through, mixed-type feedthrough, unit definitions and Robertson's kinetics at t = 40."""
from __future__ import annotations

import math

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.validation import validate_fmu

from tests.fmu_build import build_c_fmu

FMI3 = {"bounce3", "types3", "clock3", "roberts3"}
ALL = ["bounce2", "bounce3", "stair2", "discin2", "types3", "clock3", "mixed2", "units2",
       "roberts3"]


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    out = tmp_path_factory.mktemp("event_fmus")
    built: dict[str, str] = {}

    def get(name: str) -> str:
        if name not in built:
            built[name] = str(build_c_fmu(name, out, fmi3=name in FMI3))
        return built[name]

    return get


def instance(fmu: str, cls, unzipdir, **instantiate):
    """An instantiated low-level fmpy FMU object (FMU2Model, FMU2Slave, FMU3Model or FMU3Slave)."""
    md = read_model_description(fmu)
    cs = cls.__name__.endswith("Slave")
    ident = (md.coSimulation if cs else md.modelExchange).modelIdentifier
    obj = cls(guid=md.guid, unzipDirectory=extract(fmu, unzipdir=str(unzipdir)),
              modelIdentifier=ident, instanceName="inst")
    obj.instantiate(**instantiate)
    return obj


def fmi2_logger(messages: list):
    """fmi2 callbacks whose logger appends (status, category, message) to messages."""
    from fmpy.fmi1 import calloc, free
    from fmpy.fmi2 import (
        fmi2CallbackAllocateMemoryTYPE,
        fmi2CallbackFreeMemoryTYPE,
        fmi2CallbackFunctions,
        fmi2CallbackLoggerTYPE,
    )

    def log(env, name, status, category, message):
        messages.append((status, category.decode(), message.decode()))

    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(log)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return callbacks


def at(result, t: float):
    """The last row of result at time t (after the event if there is one at t)."""
    rows = np.flatnonzero(np.isclose(result["time"], t, rtol=0, atol=1e-9))
    assert rows.size, f"no sample at t = {t}"
    return result[rows[-1]]


@pytest.mark.parametrize("name", ALL)
def test_fmu_validates(build, name) -> None:
    assert validate_fmu(build(name)) == []


# ---- bounce2 / bounce3 -------------------------------------------------------------------------

G, E, H0, V_REST = 9.81, 0.7, 1.0, 1e-3
V1 = math.sqrt(2 * G * H0)
N_BOUNCES = next(k for k in range(1, 100) if E ** k * V1 < V_REST)  # the last bounce: 24
BOUNCE_TIMES = [math.sqrt(2 * H0 / G)]
for _k in range(1, N_BOUNCES):
    BOUNCE_TIMES.append(BOUNCE_TIMES[-1] + 2 * E ** _k * V1 / G)


def ball_height(t: float) -> float:
    """Analytic h(t): free fall, arcs with speed e^k v1 after bounce k, at rest after the last."""
    if t < BOUNCE_TIMES[0]:
        return H0 - G * t * t / 2
    if t >= BOUNCE_TIMES[-1]:
        return 0.0
    k = int(np.searchsorted(BOUNCE_TIMES, t, side="right"))  # bounces so far
    s = t - BOUNCE_TIMES[k - 1]
    return E ** k * V1 * s - G * s * s / 2


@pytest.mark.parametrize("name", ["bounce2", "bounce3"])
def test_ball_model_exchange_bounce_times(build, name) -> None:
    r = simulate_fmu(build(name), fmi_type="ModelExchange", solver="CVode", stop_time=3.0,
                     relative_tolerance=1e-8, output_interval=0.01, record_events=True)
    for k in (1, 2, 3):  # the first sample with bounces == k is at the k-th bounce
        t_k = r["time"][np.argmax(r["bounces"] >= k)]
        assert abs(t_k - BOUNCE_TIMES[k - 1]) < 1e-4, (k, t_k)
    assert r["bounces"][-1] == N_BOUNCES  # then at rest: no chattering
    assert r["h"][-1] == 0.0 and r["v"][-1] == 0.0
    assert np.all(r["h"] > -1e-6)
    regular = ~np.isin(r["time"], r["time"][np.flatnonzero(np.diff(r["time"]) == 0)])
    expected = np.array([ball_height(t) for t in r["time"][regular]])
    np.testing.assert_allclose(r["h"][regular], expected, atol=1e-5)


@pytest.mark.parametrize("name", ["bounce2", "bounce3"])
def test_ball_co_simulation_matches_the_analytic_height(build, name) -> None:
    r = simulate_fmu(build(name), fmi_type="CoSimulation", stop_time=3.0, output_interval=0.01)
    expected = np.array([ball_height(t) for t in r["time"]])
    np.testing.assert_allclose(r["h"], expected, atol=1e-9)
    bounces = np.searchsorted(BOUNCE_TIMES, r["time"] + 1e-12, side="right")
    np.testing.assert_array_equal(r["bounces"], bounces)
    assert r["bounces"][-1] == N_BOUNCES and r["v"][-1] == 0.0


def test_ball_start_values_and_parameters(build) -> None:
    h0, g, e = 2.0, 1.62, 0.5
    r = simulate_fmu(build("bounce3"), fmi_type="ModelExchange", stop_time=4.0,
                     relative_tolerance=1e-8, output_interval=0.05,
                     start_values={"h": h0, "g": g, "e": e})
    t1 = math.sqrt(2 * h0 / g)
    t2 = t1 + 2 * e * math.sqrt(2 * g * h0) / g  # 3.14 s
    assert abs(r["time"][np.argmax(r["bounces"] >= 1)] - t1) < 1e-4
    assert abs(r["time"][np.argmax(r["bounces"] >= 2)] - t2) < 1e-4


# ---- stair2 ------------------------------------------------------------------------------------

@pytest.mark.parametrize("fmi_type", ["ModelExchange", "CoSimulation"])
def test_stair_counter_is_floor_t_plus_1(build, fmi_type) -> None:
    r = simulate_fmu(build("stair2"), fmi_type=fmi_type, stop_time=5.0, output_interval=0.5,
                     solver="CVode", record_events=True)
    for t in (0.0, 0.5, 1.5, 4.5):
        assert at(r, t)["counter"] == math.floor(t) + 1
    if fmi_type == "ModelExchange":  # time events: sampled before and after at t = 1, 2, ...
        for t in (1.0, 2.0, 3.0):
            assert list(r["counter"][np.isclose(r["time"], t)]) == [t, t + 1]


# ---- discin2 -----------------------------------------------------------------------------------

DISCIN_SIGNALS = np.array(
    [(0.0, 1, False, 0.5, 1.0), (0.25, 1, True, 0.5, 1.0), (0.5, 1, True, 0.5, 1.0),
     (0.5, 3, True, 0.5, -1.0), (0.75, 3, False, 0.5, -1.0), (1.0, 3, False, 0.5, -1.0)],
    dtype=[("time", np.float64), ("k", np.int32), ("on", np.bool_), ("r_d", np.float64),
           ("u", np.float64)])


def discin_x(t: float) -> float:
    """x(t) for DISCIN_SIGNALS: der(x) = 1 on [0, .25), 2.5 on [.25, .75), -1 on [.75, 1]."""
    return (min(t, 0.25) + 2.5 * min(max(t - 0.25, 0.0), 0.5) - max(t - 0.75, 0.0))


@pytest.mark.parametrize("fmi_type", ["ModelExchange", "CoSimulation"])
def test_discrete_inputs_drive_the_state(build, fmi_type) -> None:
    r = simulate_fmu(build("discin2"), fmi_type=fmi_type, stop_time=1.0, output_interval=0.05,
                     solver="CVode", relative_tolerance=1e-8, input=DISCIN_SIGNALS,
                     output=["x", "xo", "y"])
    for t in (0.1, 0.25, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0):
        row = at(r, t)
        assert row["x"] == pytest.approx(discin_x(t), abs=1e-6), t
        assert row["xo"] == row["x"]
        # co-simulation samples t = 0.5 before the inputs after the event go in (at the next step)
        k = 1 if t < 0.5 or (t == 0.5 and fmi_type == "CoSimulation") else 3
        assert row["y"] == 2 * k


def test_discrete_input_is_rejected_in_continuous_time_mode(build, tmp_path) -> None:
    from fmpy.fmi2 import FMU2Model

    messages: list = []
    fmu = instance(build("discin2"), FMU2Model, tmp_path, callbacks=fmi2_logger(messages))
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.setInteger([0], [2])  # k, instantiated: allowed
        fmu.enterInitializationMode()
        fmu.setBoolean([1], [True])  # on, initialization mode: allowed
        fmu.exitInitializationMode()
        fmu.setReal([2], [0.25])  # r_d, event mode: allowed
        fmu.newDiscreteStates()
        fmu.enterContinuousTimeMode()
        fmu.setReal([3], [1.0])  # u is continuous: allowed
        assert messages == []
        for setter, vr, value in ((fmu.setInteger, 0, 5), (fmu.setBoolean, 1, False),
                                  (fmu.setReal, 2, 9.0)):
            with pytest.raises(FMICallException) as e:
                setter([vr], [value])
            assert e.value.status == 3  # fmi2Error
        assert messages == [(3, "logStatusError", "discrete input set outside event mode")] * 3
        assert fmu.getInteger([0, 6]) == [2, 4] and fmu.getBoolean([1]) == [True]  # unchanged
        assert fmu.getReal([2]) == [0.25]
        assert fmu.getReal([5]) == [pytest.approx(2 + 0.25 + 1.0)]  # der(x) = k + r_d + u
        fmu.enterEventMode()
        fmu.setInteger([0], [5])  # event mode again: allowed
        assert fmu.getInteger([6]) == [10]
        fmu.terminate()
    finally:
        fmu.freeInstance()


# ---- types3 ------------------------------------------------------------------------------------

TYPES3_STARTS = {"Float32": 1.5, "Float64": 2.25, "Int8": -8, "UInt8": 200, "Int16": -300,
                 "UInt16": 60000, "Int32": -70000, "UInt32": 4000000000, "Int64": -7,
                 "UInt64": 9000000000, "Boolean": True, "Enumeration": 2}
TYPES3_NEW = {"Float32": -0.25, "Float64": 1e300, "Int8": -128, "UInt8": 255, "Int16": 32767,
              "UInt16": 1, "Int32": -2147483648, "UInt32": 4294967295, "Int64": -(2 ** 63),
              "UInt64": 2 ** 64 - 1, "Boolean": False, "Enumeration": 3}


@pytest.mark.parametrize("fmi_type", ["ModelExchange", "CoSimulation"])
def test_types3_outputs_equal_inputs(build, fmi_type) -> None:
    fmu = build("types3")
    r = simulate_fmu(fmu, fmi_type=fmi_type, stop_time=1.0, output_interval=0.5)
    for t, start in TYPES3_STARTS.items():
        assert np.all(r[f"{t}_output"] == start), t
    np.testing.assert_array_equal(r["vec_out"], [[2.0, 4.0, 6.0]] * len(r))
    np.testing.assert_array_equal(r["scaled"], [[1.0, 2.0, 3.0]] * len(r))

    starts = {f"{t}_input": v for t, v in TYPES3_NEW.items()}
    starts.update({"vec_in": [4.0, -5.0, 6.5], "gains": [2.0, 3.0, -1.0]})
    r = simulate_fmu(fmu, fmi_type=fmi_type, stop_time=1.0, output_interval=0.5,
                     start_values=starts)
    for t, value in TYPES3_NEW.items():
        assert np.all(r[f"{t}_output"] == value), t
    np.testing.assert_array_equal(r["vec_out"][-1], [8.0, -10.0, 13.0])
    np.testing.assert_array_equal(r["scaled"][-1], [8.0, -15.0, -6.5])


@pytest.mark.parametrize("interface", ["FMU3Model", "FMU3Slave"])
def test_types3_string_binary_and_structural_parameter(build, tmp_path, interface) -> None:
    import fmpy.fmi3

    messages: list = []

    def log(env, status, category, message):
        messages.append((status, category, message))

    fmu = instance(build("types3"), getattr(fmpy.fmi3, interface), tmp_path, logMessage=log)
    try:
        assert fmu.getString([23, 24]) == ["abc", "abc"]
        assert fmu.getBinary([25, 26]) == [b"\x0a\x0b", b"\x0a\x0b"]
        fmu.enterConfigurationMode()
        fmu.setUInt64([31], [2])  # n = 2 resizes gains and scaled
        fmu.exitConfigurationMode()
        fmu.setFloat64([32], [10.0, 100.0])
        fmu.enterInitializationMode(startTime=0.0)
        fmu.setString([23], ["h\u00e9llo w\u00f6rld"])
        fmu.setBinary([25], [b"\x00\x01\xff"])
        fmu.exitInitializationMode()
        assert fmu.getString([24]) == ["h\u00e9llo w\u00f6rld"]
        assert fmu.getBinary([26]) == [b"\x00\x01\xff"]
        assert fmu.getUInt64([31]) == [2]
        assert fmu.getFloat64([32, 33, 30], nValues=2 + 2 + 3) == [10.0, 100.0,  # gains
                                                                   10.0, 200.0,  # scaled
                                                                   2.0, 4.0, 6.0]  # vec_out
        assert messages == []
        with pytest.raises(FMICallException):
            fmu.getFloat64([33], nValues=3)  # scaled has n = 2 elements now
        with pytest.raises(FMICallException):
            fmu.setUInt64([31], [4])  # n is fixed after configuration
        with pytest.raises(FMICallException):
            fmu.setInt64([27], [4])  # not an item of the enumeration
        assert len(messages) == 3 and all(m[:2] == (3, b"logStatusError") for m in messages)
        fmu.terminate()
    finally:
        fmu.freeInstance()


def test_clock3_declares_a_triggered_input_clock(build, tmp_path) -> None:
    from fmpy.fmi3 import FMU3Slave

    fmu = build("clock3")
    md = read_model_description(fmu)
    clocks = [v for v in md.modelVariables if v.type == "Clock"]
    assert [(v.name, v.causality, v.intervalVariability) for v in clocks] == [
        ("tick", "input", "triggered")]
    assert [v.clocks for v in md.modelVariables if v.name == "ticks"] == [clocks]
    assert md.modelExchange is None and md.coSimulation.modelIdentifier == "clock3"
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.5)
    assert list(r["ticks"]) == [0, 0, 0]
    s = instance(fmu, FMU3Slave, tmp_path, eventModeUsed=True)
    try:
        s.enterInitializationMode(startTime=0.0)
        s.exitInitializationMode()  # event mode
        s.setClock([1], [True])
        s.updateDiscreteStates()
        s.enterStepMode()
        s.doStep(0.0, 0.1)
        assert s.getInt32([2]) == [1]
    finally:
        s.freeInstance()


# ---- mixed2 ------------------------------------------------------------------------------------

def test_mixed2_co_simulation_outputs(build, tmp_path) -> None:
    from fmpy.fmi2 import FMU2Slave

    fmu = build("mixed2")
    md = read_model_description(fmu)
    assert md.modelExchange is None
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.1)
    last = r[-1]
    outputs = ("r1o", "r2o", "i1o", "i2o", "b1o")
    assert tuple(last[o] for o in outputs) == (3.0, 1.5, 4, -12, True)
    np.testing.assert_allclose(r["acc"], 1.5 * r["time"], atol=1e-12)
    assert r["acc"][0] == 0.0  # not direct feedthrough
    signals = np.array([(0.0, 2.0, -1.0, 7, 5, True), (0.5, 2.0, -1.0, 7, 5, True),
                        (0.5, -4.0, 3.0, -2, 0, False), (1.0, -4.0, 3.0, -2, 0, False)],
                       dtype=[("time", float), ("r1", float), ("r2", float), ("i1", np.int32),
                              ("i2", np.int32), ("b1", np.bool_)])
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.1, input=signals)
    assert tuple(at(r, 0.4)[o] for o in outputs) == (4.0, 0.0, 8, 15, False)
    row = r[-1]
    assert tuple(row[o] for o in outputs) == (-8.0, 4.0, -1, 0, True)
    assert row["acc"] == pytest.approx(2.0 * 0.5 - 4.0 * 0.5)
    s = instance(fmu, FMU2Slave, tmp_path)
    try:
        assert s.getString([5, 11]) == [b"hello", b"hello"]
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        s.setString([5], ["a \u00fcml\u00e4ut string"])
        s.setReal([0], [0.5])
        assert s.getString([11]) == ["a \u00fcml\u00e4ut string".encode()]
        assert s.getReal([6, 12]) == [1.0, 0.0]  # r1o follows r1 at once, acc only after a step
        s.doStep(0.0, 0.2)
        assert s.getReal([12]) == [pytest.approx(0.1)]
        s.terminate()
    finally:
        s.freeInstance()


# ---- units2 ------------------------------------------------------------------------------------

def test_units2_unit_definitions(build) -> None:
    fmu = build("units2")
    md = read_model_description(fmu)
    units = {u.name: u for u in md.unitDefinitions}
    assert set(units) == {"degF", "myLen", "widget"}
    deg_f = units["degF"].baseUnit
    assert (deg_f.K, deg_f.m) == (1, 0)
    assert deg_f.factor == pytest.approx(5 / 9) and deg_f.offset == pytest.approx(255.3722222222222)
    assert deg_f.factor * 32 + deg_f.offset == pytest.approx(273.15)  # 32 degF is 0 degC
    my_len = units["myLen"].baseUnit
    assert (my_len.m, my_len.K, my_len.factor, my_len.offset) == (1, 0, 0.3048, 0)
    assert units["widget"].baseUnit is None
    var_units = {v.name: v.unit for v in md.modelVariables}
    assert var_units == {"temp_in": "degF", "temp_out": "degF", "len_in": "myLen",
                         "len_out": "myLen", "w": "widget", "plain": None}
    assert md.modelExchange is None
    r = simulate_fmu(fmu, stop_time=1.0, output_interval=0.5,
                     start_values={"temp_in": -40.0, "len_in": 3.0})
    assert list(r[-1]) == [1.0, -40.0, 3.0, 1.0, 5.0]
    assert r.dtype.names == ("time", "temp_out", "len_out", "w", "plain")


# ---- roberts3 ----------------------------------------------------------------------------------

def test_roberts_matches_the_published_solution_at_40_s(build) -> None:
    """Robertson's problem at t = 40: y1 = 0.7158271, y2 = 9.185535e-6 (Hairer & Wanner)."""
    r = simulate_fmu(build("roberts3"), stop_time=40.0, output_interval=1.0,
                     relative_tolerance=1e-10, output=["y1", "y2", "y3"])
    assert r["y1"][-1] == pytest.approx(0.7158271, abs=2e-7)
    assert r["y2"][-1] == pytest.approx(9.185535e-6, rel=1e-5)
    np.testing.assert_allclose(r["y1"] + r["y2"] + r["y3"], 1.0, rtol=0, atol=1e-15)
