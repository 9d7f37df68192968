"""`twmr tune` on a first-order loop (tests/fixtures/scenarios/loop_tune.yaml: a step of height h
at 0.1 s into e = r - y, u = k e, y' = u) whose objective has a known minimum.

Objective: mean over the realisations (h drawn from uniform:0.5:1.5) of ms(e) + R ms(u), the mean
squares over the recorded samples. u = k e, so J(k) = E[h^2] ms(e1)(1 + R k^2) with e1 the error
of a unit step: its minimum is found here from scipy's simulation of the closed loop k/(s + k),
not from our code.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import optimize, signal

import twmr
from twmr.cli import main
from twmr.sweeps import SweepError

LOOP = "tests/fixtures/scenarios/loop_tune.yaml"
R = 0.1
OBJECTIVE = f"ms_err_y + {R}*ms_ctrl_y"
HEIGHT = "ref.height=uniform:0.5:1.5"


def unit_step_ms(k: float) -> float:
    """ms(e) of the unit step into k/(s + k), at the recorded samples (scipy)."""
    t = np.linspace(0.0, 1.0, 101)
    r = np.where(t >= 0.1 - 1e-12, 1.0, 0.0)
    _, y, _ = signal.lsim(signal.lti([k], [1.0, k]), r, t)
    return float(np.mean((r - y) ** 2))


def reference_objective(k: float, heights: np.ndarray) -> float:
    return float(np.mean(heights**2)) * unit_step_ms(k) * (1.0 + R * k * k)


def tune(tmp_path, trials: int, objective_text: str = OBJECTIVE, **options):
    options = {"vary": [HEIGHT], "realisations": 3, "metrics": ["signals"], "seed": 0,
               "out": tmp_path / "tune", **options}
    return twmr.tune(LOOP, ["ctrl.k=log:0.3:30"], objective_text, trials=trials, **options)


def test_tune_finds_the_analytic_optimum(tmp_path):
    outcome = tune(tmp_path, 30)
    heights = pd.read_parquet(tmp_path / "tune" / "realisations.parquet").groupby(
        "sample")["ref.height"].first().to_numpy()
    best = optimize.minimize_scalar(lambda lk: reference_objective(np.exp(lk), heights),
                                    bounds=(np.log(0.3), np.log(30)), method="bounded")
    k_star = float(np.exp(best.x))
    assert 2.8 < k_star < 3.4  # about 1/sqrt(R), the horizon's and the sampling's share aside
    k = outcome.best["ctrl.k"]
    assert abs(k / k_star - 1) < 0.1
    assert outcome.best["objective"] == pytest.approx(reference_objective(k, heights), rel=0.03)
    assert outcome.best["objective"] == pytest.approx(best.fun, rel=0.03)
    trials = pd.read_parquet(tmp_path / "tune" / "trials.parquet")
    assert len(trials) == 30 and (trials["status"] == "ok").all()
    assert (trials["objective"] >= outcome.best["objective"]).all()
    assert (tmp_path / "tune" / "report" / "history.png").exists()
    scenario = twmr.load(tmp_path / "tune" / "best.yaml")
    assert scenario.system.components["ctrl"].get("k") == pytest.approx(k)


def test_realisations_are_common_to_every_trial(tmp_path):
    tune(tmp_path, 6)
    runs = pd.read_parquet(tmp_path / "tune" / "realisations.parquet")
    assert len(runs) == 18
    drawn = 0.5 + np.random.default_rng(0).random((3, 1))[:, 0]  # a sweep's draws of seed 0
    for _, group in runs.groupby("trial"):
        assert group.sort_values("sample")["ref.height"].to_numpy() == pytest.approx(drawn)
        # the drawn height is the one simulated: ms(e) scales with h^2 within a trial
        scaled = (group["ms_err_y"] / group["ref.height"] ** 2).to_numpy()
        assert scaled == pytest.approx(np.full(3, scaled[0]), rel=1e-9)
    trials = pd.read_parquet(tmp_path / "tune" / "trials.parquet")
    spreads = runs.groupby("trial")["value"].std(ddof=1)
    assert trials.set_index("trial")["spread"].to_numpy() == pytest.approx(spreads.to_numpy())


def test_resumption_adds_trials_without_re_evaluating(tmp_path):
    first = tune(tmp_path, 4)
    assert first.ran == 4
    again = tune(tmp_path, 7)
    assert again.ran == 3 and len(again.trials) == 7
    trials = pd.read_parquet(tmp_path / "tune" / "trials.parquet")
    assert list(trials["trial"]) == list(range(7))
    assert list(trials["ctrl.k"][:4]) == [t["ctrl.k"] for t in first.trials]
    assert len(pd.read_parquet(tmp_path / "tune" / "realisations.parquet")) == 21
    assert tune(tmp_path, 7).ran == 0
    with pytest.raises(SweepError, match=r"another study.*objective"):
        twmr.tune(LOOP, ["ctrl.k=log:0.3:30"], "ms_err_y", vary=[HEIGHT], realisations=3,
                  metrics=["signals"], trials=8, out=tmp_path / "tune")


def test_constraint_excludes_violating_trials(tmp_path):
    # peak |u| = k h at the step (e = h there): k max(h) <= 3 keeps k below the optimum
    outcome = tune(tmp_path, 25, constraints=["peak_ctrl_y<=3"])
    h_max = pd.read_parquet(tmp_path / "tune" / "realisations.parquet")["ref.height"].max()
    trials = pd.read_parquet(tmp_path / "tune" / "trials.parquet")
    peak = trials["ctrl.k"] * h_max
    assert (trials.loc[peak > 3.0 * 1.001, "status"] == "infeasible").all()
    assert (trials.loc[peak < 3.0 * 0.999, "status"] == "ok").all()
    assert (trials["status"] == "infeasible").any()
    assert outcome.best["ctrl.k"] * h_max <= 3.0
    assert outcome.best["ctrl.k"] == pytest.approx(3.0 / h_max, rel=0.1)  # J falls up to k*


def test_dask_workers_give_the_same_trials(tmp_path):
    """The proposals depend on the batch, not on where the runs go nor on when they end: a
    batch of 2 in this process and on 2 Dask workers (their default batch, the next batch
    queued while one runs) give the same trials, past the sampler's random start-up too."""
    here = tune(tmp_path, 14, out=tmp_path / "one", batch=2)
    there = tune(tmp_path, 14, out=tmp_path / "two", workers=2)
    assert [t["ctrl.k"] for t in there.trials] == [t["ctrl.k"] for t in here.trials]
    assert [t["objective"] for t in there.trials] == pytest.approx(
        [t["objective"] for t in here.trials], rel=1e-12)
    walls = pd.read_parquet(tmp_path / "one" / "trials.parquet")["wall_time_s"].to_numpy()
    assert walls[0] == walls[1] and walls[2] == walls[3]  # trials 0, 1 ran as one batch, 2, 3


def test_lockstep_proposes_as_a_plain_ask_tell_loop(tmp_path):
    """Lockstep, batch 1: each trial is asked once the one before is told, so the proposals are
    those of Optuna's own ask/tell loop with the same seeded sampler told the same values; the
    default (the next trial asked while one runs) differs from it past the random start-up."""
    import optuna

    lock = tune(tmp_path, 14, out=tmp_path / "lock", lockstep=True)
    ahead = tune(tmp_path, 14, out=tmp_path / "ahead")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with warnings.catch_warnings():  # constant_liar is "experimental"
        warnings.simplefilter("ignore")
        sampler = optuna.samplers.TPESampler(seed=0, constant_liar=True)
    study = optuna.create_study(sampler=sampler)
    dist = {"ctrl.k": optuna.distributions.FloatDistribution(0.3, 30.0, log=True)}
    for row in lock.trials:
        trial = study.ask(dist)
        assert trial.params["ctrl.k"] == row["ctrl.k"]
        study.tell(trial, row["objective"])
    plain = [t.params["ctrl.k"] for t in study.trials]
    ahead_k = [t["ctrl.k"] for t in ahead.trials]
    assert ahead_k[:10] == plain[:10]  # the random start-up asks without the told values
    assert ahead_k[10:] != plain[10:]


def test_start_points_are_tried_first(tmp_path):
    outcome = tune(tmp_path, 3, start=[{"ctrl.k": 3.0}, {"ctrl.k": 0.5}])
    assert [t["ctrl.k"] for t in outcome.trials[:2]] == [3.0, 0.5]
    assert outcome.best["ctrl.k"] == 3.0  # the optimum is near 3.1: no random trial beats it
    assert tune(tmp_path, 4, start=[{"ctrl.k": 3.0}, {"ctrl.k": 0.5}]).ran == 1
    with pytest.raises(SweepError, match=r"ctrl.k=50.0 is outside its range log:0.3:30"):
        tune(tmp_path, 2, out=tmp_path / "out", start=[{"ctrl.k": 50.0}])
    assert main(["tune", LOOP, "--param", "ctrl.k=log:0.3:30", "--objective", OBJECTIVE,
                 "--metrics", "signals", "--trials", "1", "--start", "ctrl.k=2.5",
                 "--out", str(tmp_path / "cli"), "-q"]) == 0
    assert pd.read_parquet(tmp_path / "cli" / "trials.parquet")["ctrl.k"].tolist() == [2.5]


def test_a_batch_spreads_its_trials(tmp_path):
    """The pending trials of a batch count as constant liars: the trials of a batch of 4, after
    the random start-up, are not proposed at one point."""
    outcome = tune(tmp_path, 16, batch=4)
    late = [t["ctrl.k"] for t in outcome.trials[12:16]]
    assert len(set(late)) == 4
    assert max(late) / min(late) > 1.01


def test_a_baseline_gives_its_figures_per_realisation(tmp_path):
    """A baseline (the loop with k = 2) run once over the same realisations: base_ms_err_y is
    its ms(e) in the same realisation, so the ratio does not depend on the drawn height."""
    import yaml

    data = yaml.safe_load(Path(LOOP).read_text(encoding="utf-8"))
    data["components"]["ctrl"]["parameters"]["k"] = 2.0
    baseline = tmp_path / "baseline.yaml"
    baseline.write_text(yaml.safe_dump(data))
    ratio = "ms_err_y / base_ms_err_y"
    outcome = tune(tmp_path, 4, ratio, baseline=baseline, constraints=[f"{ratio} >= 0"])
    folder = tmp_path / "tune"
    base = pd.read_parquet(folder / "baseline.parquet").sort_values("sample")
    runs = pd.read_parquet(folder / "realisations.parquet")
    assert len(base) == 3 and base["status"].eq("ok").all()
    for _, group in runs.groupby("trial"):
        group = group.sort_values("sample")
        assert group["ref.height"].to_numpy() == pytest.approx(base["ref.height"].to_numpy())
        expected = group["ms_err_y"].to_numpy() / base["ms_err_y"].to_numpy()
        assert group["value"].to_numpy() == pytest.approx(expected, rel=1e-12)
        assert np.ptp(group["value"]) < 1e-9 * group["value"].mean()
    for t in outcome.trials:  # ms(e) falls with k: the ratio is below 1 exactly when k > 2
        assert (t["objective"] < 1.0) == (t["ctrl.k"] > 2.0)
    assert tune(tmp_path, 5, ratio, baseline=baseline, constraints=[f"{ratio} >= 0"]).ran == 1
    assert len(pd.read_parquet(folder / "baseline.parquet")) == 3  # not run again
    wins = tune(tmp_path, 2, baseline=baseline, out=tmp_path / "wins",
                objective_text="(ms_err_y < base_ms_err_y) + 0")
    for t in wins.trials:
        assert t["objective"] == (1.0 if t["ctrl.k"] > 2.0 else 0.0)
    with pytest.raises(SweepError, match="no baseline is given"):
        tune(tmp_path, 2, out=tmp_path / "none", objective_text=ratio)


@pytest.mark.parametrize(("extra", "expected"), [
    (["--param", "ctrl.kk=1:5"], "--param ctrl.kk: 'ctrl' has no parameter"),
    (["--param", "ctrl.k=log:-1:10"], "a log range starts above 0"),
    (["--param", "ctrl.k=5:1"], "LO 5 is not below HI 1"),
    (["--param", "ctrl.k=1:5", "--objective", "ms_err_z"], "'ms_err_z' is not a figure"),
    (["--param", "ctrl.k=1:5", "--objective", "__import__('os')"], "is not allowed in it"),
    (["--param", "ctrl.k=1:5", "--constraint", "peak_ctrl_y<3"], "no <= or >="),
    (["--param", "ctrl.k=1:5", "--start", "ctrl.kk=2"], "--start 1: no value of ctrl.k"),
    (["--param", "ctrl.k=1:5", "--objective", "base_ms_err_y"], "no baseline is given"),
    (["--param", "ctrl.k=1:5", "--batch", "0"], "--batch 0 is not a positive"),
])
def test_bad_input_is_one_paragraph(tmp_path, capsys, extra, expected):
    args = ["tune", LOOP, "--metrics", "signals", "--trials", "2", "--out",
            str(tmp_path / "t"), *extra]
    if "--objective" not in extra:
        args += ["--objective", OBJECTIVE]
    assert main(args) == 1
    err = capsys.readouterr().err
    assert expected in err and "Fix:" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_ctrl_c_keeps_the_finished_trials(tmp_path, monkeypatch):
    from twmr.sweeps.run import execute
    from twmr.tuning import study

    calls = []

    def interrupted(task):
        calls.append(task)
        if len(calls) == 8:  # the 2nd run of the 3rd trial
            raise KeyboardInterrupt
        return execute(task)

    monkeypatch.setattr(study, "execute", interrupted)
    params = ["ctrl.k=log:0.3:30", "ref.time=0.05:0.3"]
    options = {"vary": [HEIGHT], "realisations": 3, "metrics": ["signals"],
               "out": tmp_path / "tune"}
    with pytest.raises(KeyboardInterrupt):
        twmr.tune(LOOP, params, OBJECTIVE, trials=6, **options)
    trials = pd.read_parquet(tmp_path / "tune" / "trials.parquet")
    assert list(trials["trial"]) == [0, 1]
    assert len(pd.read_parquet(tmp_path / "tune" / "realisations.parquet")) == 6
    monkeypatch.setattr(study, "execute", execute)
    outcome = twmr.tune(LOOP, params, OBJECTIVE, trials=6, **options)
    assert outcome.ran == 4 and len(outcome.trials) == 6
    assert list(pd.read_parquet(tmp_path / "tune" / "trials.parquet")["ctrl.k"][:2]) == \
        list(trials["ctrl.k"])
    assert (tmp_path / "tune" / "report" / "importance.png").exists()


def test_a_refused_objective_does_not_lock_the_folder_to_it(tmp_path):
    options = {"vary": [HEIGHT], "realisations": 3, "metrics": ["signals"],
               "out": tmp_path / "tune"}
    with pytest.raises(SweepError, match="'ms_err_z' is not a figure"):
        twmr.tune(LOOP, ["ctrl.k=log:0.3:30"], "ms_err_z", trials=2, **options)
    assert twmr.tune(LOOP, ["ctrl.k=log:0.3:30"], OBJECTIVE, trials=2, **options).ran == 2


def test_the_command_writes_the_study(tmp_path):
    import twmr.tuning  # the package beside the function: `twmr.tune` is plainly the function

    assert twmr.tune is twmr.api.tune and twmr.tuning.tune is not twmr.tune
    out = tmp_path / "cli"
    assert main(["tune", LOOP, "--param", "ctrl.k=log:0.3:30", "--objective", OBJECTIVE,
                 "--metrics", "signals", "--vary", HEIGHT, "--realisations", "2",
                 "--trials", "3", "--out", str(out), "-q"]) == 0
    assert {p.name for p in out.iterdir()} >= {"tune.json", "trials.parquet", "best.yaml",
                                              "realisations.parquet", "report"}
    best = pd.read_parquet(out / "trials.parquet").sort_values("objective").iloc[0]
    k = twmr.load(out / "best.yaml").system.components["ctrl"].get("k")
    assert k == pytest.approx(best["ctrl.k"])
