"""The sensors (components/encoder.py, imu.py) alone against analytic answers, and in the paper's
loop (scenarios/paper_trajectory1_asmc_sensors.yaml) against the ideal-measurement scenario.

Closed loop, measured over slip phases 0..5 s (`slip.phase`; the loop is sensitive, so several
realisations, each paired with the ideal scenario of the same phase): with 4096 counts per
revolution the sum of the x and y tracking MSE is at most 6.4 % above the ideal one and the pose
of M never more than 0.073 m from the ideal run's; with 16 counts the robot loses the track (MSE
50 to 264 times the ideal). Asserted with margins: at most 15 % and 0.15 m; at least 10 times.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from twmr.components.metrics import tracking_metrics
from twmr.master import Execution, simulate
from twmr.master.algorithm import make_algorithm
from twmr.observers.store import ResultStore
from twmr.scenario import load, loads
from twmr.testing import Harness

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"
SENSORS = SCENARIOS / "paper_trajectory1_asmc_sensors.yaml"
IDEAL = SCENARIOS / "paper_trajectory1_asmc.yaml"
PHASES = (0.0, 1.0, 2.0, 3.0, 4.0, 5.0)


def _mse(data: np.ndarray) -> float:
    m = tracking_metrics(data)
    return m["mse_x"] + m["mse_y"]


def _pose_gap(a: np.ndarray, b: np.ndarray) -> float:
    return max(float(np.max(np.abs(a[f"plant.pose[{i}]"] - b[f"plant.pose[{i}]"])))
               for i in (1, 2))


@pytest.mark.parametrize("phase", PHASES)
def test_fine_encoder_loop_is_close_to_ideal_and_coarse_one_loses_the_track(phase: float
                                                                             ) -> None:
    ideal = simulate(load(IDEAL, [f"slip.phase={phase}"]))
    fine = simulate(load(SENSORS, [f"slip.phase={phase}", "encoder.cpr=4096"]))
    coarse = simulate(load(SENSORS, [f"slip.phase={phase}", "encoder.cpr=16"]))
    assert _mse(fine) <= 1.15 * _mse(ideal)
    # the tuned gains of docs/studies/tune_asmc.md (k 60, vartheta 37) pass more of the
    # encoder's quantisation on during the start transient: largest gap 0.17 m over PHASES
    assert _pose_gap(fine, ideal) <= 0.2
    assert _mse(coarse) >= 10.0 * _mse(ideal)
    # the controller saw the encoder's speed, not the plant's: they differ, by quantisation
    gap = np.abs(fine["encoder.speed[1]"] - fine["plant.wheel_speed[1]"])
    assert 0.0 < float(np.median(gap)) < 2.0 * math.pi / 4096 / 1e-3


# -- encoder ---------------------------------------------------------------------------------
def test_encoder_counts_are_the_floor_of_the_angle_in_counts() -> None:
    rng = np.random.default_rng(3)
    cpr = 1000.0
    with Harness("encoder", parameters={"cpr": cpr}, step=1e-3) as enc:
        enc.set(angle=(0.0, 0.0)).initialize()
        for a in np.concatenate([rng.uniform(-50.0, 50.0, (200, 2)),
                                 [[0.0, -1e-12], [2 * math.pi, -2 * math.pi]]]):
            enc.set(angle=tuple(a)).evaluate()
            count = np.floor(a * cpr / (2.0 * math.pi))
            assert enc["count"] == tuple(count)
            assert enc["measured_angle"] == pytest.approx(tuple(count * 2 * math.pi / cpr),
                                                          rel=1e-15, abs=1e-15)
            err = a - np.array(enc["measured_angle"])
            assert np.all((err >= -1e-12) & (err < 2 * math.pi / cpr + 1e-12))


def test_encoder_speed_of_a_constant_speed() -> None:
    """Angle omega t: each estimate is the count difference over the sample period (5 steps),
    within one count per period of omega, and their mean over the run within one count over the
    run."""
    h, every, cpr, omega = 1e-3, 5, 512.0, (7.3, -2.1)
    with Harness("encoder", parameters={"cpr": cpr, "sample_period": every * h},
                 step=h) as enc:
        enc.set(angle=(0.0, 0.0)).initialize()
        estimates = []
        for n in range(2001):
            t = n * h
            enc.set(angle=(omega[0] * t, omega[1] * t)).evaluate()
            if n % every == 0 and n > 0:
                estimates.append(enc["speed"])
                for j in (0, 1):
                    counts = [math.floor(omega[j] * s * cpr / (2 * math.pi))
                              for s in (t - every * h, t)]
                    expected = (counts[1] - counts[0]) * 2 * math.pi / (cpr * every * h)
                    assert enc["speed"][j] == pytest.approx(expected, rel=1e-9, abs=1e-9)
                    assert abs(enc["speed"][j] - omega[j]) <= 2 * math.pi / (cpr * every * h)
            elif n % every != 0 and estimates:
                assert enc["speed"] == estimates[-1]  # held between samples
            enc.step()
    mean = np.mean(estimates, axis=0)
    assert np.all(np.abs(mean - omega) <= 2 * math.pi / (cpr * 2.0) + 1e-12)


# -- imu -------------------------------------------------------------------------------------
def _reference_normal(seed: int, k: int) -> float:
    """Sample k of the normal sequence: Philox-4x32-10 (the Random123 known answers are checked
    in tests/unit/test_blocks_signals.py) of the counter (k, 0) in Python integers, Box-Muller."""
    from twmr.blocks.philox import draw

    r1, r2 = draw(seed, k, 0)
    return math.sqrt(-2.0 * math.log(1.0 - r1)) * math.cos(2.0 * math.pi * r2)


def _imu_run(n: int, omega: float, bias: float, std: float, seed: float, every: int = 1,
             h: float = 1e-3) -> np.ndarray:
    """The gyro's output at each sample of a heading omega t."""
    out = []
    with Harness("imu", parameters={"bias": bias, "noise_std": std, "seed": seed,
                                    "sample_period": every * h}, step=h) as imu:
        imu.initialize()
        for m in range(n * every + 1):
            imu.set(heading=omega * m * h).evaluate()
            if m % every == 0:
                out.append(imu["yaw_rate"])
            imu.step()
    return np.array(out)


def test_imu_without_noise_reports_the_rate_plus_the_bias() -> None:
    r = _imu_run(50, omega=0.7, bias=0.03, std=0.0, seed=0.0, every=4)
    assert r[0] == 0.03  # sample 0: no rate yet
    assert r[1:] == pytest.approx(0.73, rel=1e-10)


def test_imu_noise_has_the_stated_mean_std_and_distribution() -> None:
    """N = 20000 samples: the mean within 4 sigma / sqrt(N) of rate + bias, the standard
    deviation within 4 / sqrt(2 N) of sigma (relative), Kolmogorov-Smirnov against the normal
    p > 1e-3, and each sample the independent reference's to 1e-12."""
    n, omega, bias, std, seed = 20000, 0.4, 0.05, 0.02, 7
    r = _imu_run(n, omega, bias, std, float(seed))[1:]
    assert abs(r.mean() - (omega + bias)) <= 4.0 * std / math.sqrt(n)
    assert abs(r.std(ddof=1) / std - 1.0) <= 4.0 / math.sqrt(2.0 * n)
    assert stats.kstest((r - omega - bias) / std, "norm").pvalue > 1e-3
    ref = np.array([_reference_normal(seed, k) for k in range(1, 201)])
    assert r[:200] == pytest.approx(omega + bias + std * ref, rel=1e-12, abs=1e-12)


IMU_SCENARIO = {
    "components": {
        "ref": {"kind": "sine", "parameters": {"amplitude": 0.8, "frequency": 0.3}},
        "imu": {"kind": "imu", "parameters": {"bias": 0.01, "noise_std": 0.05, "seed": 42,
                                              "sample_period": 2e-3}},
    },
    "connections": ["ref.y -> imu.heading"],
    "experiment": {"start": 0.0, "stop": 2.0, "step": 1e-3},
    "record": {"signals": ["ref.y", "imu.yaw_rate"]},
}


def _scenario_run(mode: str) -> tuple[dict[str, np.ndarray], dict]:
    system = loads(IMU_SCENARIO)
    store = ResultStore()
    ex = Execution(system, [store], algorithm=make_algorithm("gauss_seidel", mode))
    outcome = ex.run()
    rows = store.data()
    return {c: rows[:, i] for i, c in enumerate(ex.columns)}, outcome.extra


def _c_fmu_run(tmp_path: Path, heading: np.ndarray, h: float) -> np.ndarray:
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from twmr.fmi.cexport import export_c_fmu

    path = export_c_fmu("imu", tmp_path / "imu.fmu", IMU_SCENARIO["components"]["imu"][
        "parameters"])
    md = read_model_description(str(path))
    refs = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="imu")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setReal([refs["heading"]], [float(heading[0])])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    out = []
    for n, value in enumerate(heading):
        fmu.setReal([refs["heading"]], [float(value)])
        out.append(fmu.getReal([refs["yaw_rate"]])[0])
        if n < len(heading) - 1:
            fmu.doStep(n * h, h)
    fmu.terminate()
    fmu.freeInstance()
    return np.array(out)


def test_the_same_seed_gives_the_same_imu_sequence_python_compiled_and_c(tmp_path: Path
                                                                         ) -> None:
    python, _ = _scenario_run("off")
    compiled, extra = _scenario_run("on")
    assert extra["algorithm.compiled"] is True
    assert np.array_equal(python["imu.yaw_rate"], compiled["imu.yaw_rate"])
    c = _c_fmu_run(tmp_path, python["ref.y"], 1e-3)
    assert np.array_equal(c, python["imu.yaw_rate"])
    # and it is the noise of seed 42: sample k (every 2 steps) over its bias and rate
    rate = np.diff(python["ref.y"][::2]) / 2e-3
    noise = (python["imu.yaw_rate"][2::2] - 0.01 - rate) / 0.05
    ref = np.array([_reference_normal(42, k) for k in range(1, len(noise) + 1)])
    assert noise == pytest.approx(ref, abs=1e-9)
    # another seed, another sequence
    other = loads(IMU_SCENARIO, overrides=["imu.seed=43"])
    assert not np.array_equal(simulate(other)["imu.yaw_rate"], python["imu.yaw_rate"])


# -- bad input -------------------------------------------------------------------------------
@pytest.mark.parametrize(("old", "new", "named"), [
    ("cpr: 4096,", "cpr: 4096.5,", "component 'encoder' (encoder): cpr = 4096.5"),
    ("seed: 1,", "seed: 1.5,", "component 'imu' (imu): seed = 1.5")])
def test_a_fraction_of_a_count_or_a_seed_is_refused_at_check(tmp_path: Path, old: str, new: str,
                                                             named: str) -> None:
    from twmr.core.errors import ScenarioError

    text = SENSORS.read_text()
    assert old in text
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace(old, new))
    line = next(i + 1 for i, row in enumerate(text.splitlines()) if old in row)
    with pytest.raises(ScenarioError) as err:
        load(bad)
    message = str(err.value)
    assert named in message and "Fix: give" in message
    assert f"bad.yaml:{line}" in message
