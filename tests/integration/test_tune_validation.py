"""`twmr tune` with validation realisations: the best trials by training objective run on
realisations drawn apart (a seed stream of their own, never optimised on) and the best is chosen
there. On a seeded toy whose in-sample optimum over-fits — y = (k - r)^2 with r uniform on [0, 1],
one training realisation r = 0.943, k in {0.1, 0.5, 0.9} — training picks k = 0.9 and validation
the generalising k = 0.5 (E[(k - r)^2] is least at k = E[r]); the test part judges the chosen one
only; a second call resumes from the journal without running anything again."""
from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

import twmr
from twmr.tuning import TuneError

pytestmark = pytest.mark.timeout(180)

TOY = """components:
  k: {kind: constant, parameters: {value: 0.5}}
  r: {kind: constant, parameters: {value: 0.0}}
  d: {kind: sum, parameters: {signs: "+-"}}
  sq: {kind: product, parameters: {ops: "**"}}
connections: [k.y -> d.u1, r.y -> d.u2, d.y -> sq.u1, d.y -> sq.u2]
experiment: {stop: 0.01, step: 0.01}
"""
POINTS = [{"k.value": v} for v in (0.1, 0.5, 0.9)]


def tune(folder: Path, **given: object) -> object:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "toy.yaml"
    path.write_text(TOY)
    args: dict[str, object] = dict(vary=["r.value=uniform:0:1"], realisations=1, trials=3, seed=4,
                                   start=POINTS, out=folder / "tune", report=False)
    return twmr.tune(path, ["k.value=values:0.1,0.5,0.9"], "final_sq_y", **{**args, **given})


def test_validation_picks_the_point_that_generalises(tmp_path: Path) -> None:
    trained = tune(tmp_path / "a")
    assert trained.best["k.value"] == 0.9  # type: ignore[attr-defined]  # over-fits r = 0.943
    chosen = tune(tmp_path / "b", validation=30, validate_top=3, test=20)
    best = chosen.best  # type: ignore[attr-defined]
    assert best["k.value"] == 0.5
    assert best["objective"] > min(t["objective"] for t in chosen.trials)  # not the in-sample one
    assert best["gap"] == pytest.approx(best["validation_objective"] - best["objective"])
    assert "test_objective" in best
    trials = pd.read_parquet(tmp_path / "b" / "tune" / "trials.parquet")
    assert trials["validation_objective"].notna().sum() == 3
    validated = trials.set_index("k.value")["validation_objective"]
    assert validated.idxmin() == 0.5 and validated[0.9] > validated[0.5]
    runs = pd.read_parquet(tmp_path / "b" / "tune" / "validation.parquet")
    assert sorted(runs["part"].value_counts().items()) == [("test", 20), ("validation", 90)]
    r_train = pd.read_parquet(tmp_path / "b" / "tune" / "realisations.parquet")["r.value"]
    assert not set(r_train) & set(runs["r.value"])  # drawn apart
    assert "validation" in json.loads((tmp_path / "b" / "tune" / "tune.json").read_text())
    assert "validation realisation(s)" in (tmp_path / "b" / "tune" / "best.yaml").read_text()


def test_a_second_call_resumes_the_held_out_runs(tmp_path: Path) -> None:
    first = tune(tmp_path, validation=10, validate_top=3)
    again = tune(tmp_path, validation=10, validate_top=3)
    assert again.ran == 0  # type: ignore[attr-defined]
    assert again.best == first.best  # type: ignore[attr-defined]


@pytest.mark.parametrize("given, said", [
    ({"validation": -1}, "--validation -1"),
    ({"test": 5}, "--test without --validation"),
    ({"validation": 5, "validate_top": 0}, "--validate-top 0"),
])
def test_held_out_settings_that_cannot_work_are_refused(tmp_path: Path, given: dict[str, int],
                                                        said: str) -> None:
    with pytest.raises(TuneError, match=said):
        tune(tmp_path, **given)
