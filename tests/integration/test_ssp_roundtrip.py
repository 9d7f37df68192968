"""Round trip: a paper scenario exported as SSP (`twmr export X.yaml --out X.ssp`) and loaded
back (`twmr.load("X.ssp")`, the SSP import) runs to the rows of the YAML it came from, within
1e-12 of each signal's scale (its blocks are C FMUs held equal to the native blocks, see
docs/export.md), under the scenario's own algorithm (Gauss-Seidel) and under Jacobi.

Needs the SSP import (`twmr.fmi.ssp.read`); skipped where it is not installed."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from tests.integration import ssp_runners as r
from twmr.fmi.ssp.write import export_ssp

pytest.importorskip("twmr.fmi.ssp.read", reason="the SSP import (twmr.fmi.ssp.read) is not here")


@pytest.mark.parametrize("algorithm", ["gauss_seidel", "jacobi"])
@pytest.mark.parametrize("path", r.WITH_SENSORS, ids=lambda p: p.stem)
def test_the_ssp_runs_as_the_yaml_it_came_from(path, algorithm, tmp_path) -> None:
    import twmr

    if path.stem.endswith("_sensors") and algorithm == "jacobi":
        pytest.skip("known gap: under Jacobi the encoder's C FMU and the native encoder give "
                    "different controller inputs (ctrl.s differs from t = 3 ms); Gauss-Seidel "
                    "is exact. Open in issue #23's closing note.")

    data = yaml.safe_load(path.read_text())
    data["experiment"].update(stop=2.0, algorithm=algorithm)
    data["record"]["decimation"] = 1
    scenario = tmp_path / path.name
    scenario.write_text(yaml.safe_dump(data, sort_keys=False))
    ssp = export_ssp(scenario, tmp_path / f"{path.stem}.ssp")
    ours = np.array(twmr.simulate(twmr.load(str(scenario))).to_pandas().to_records(index=False))
    back = twmr.simulate(twmr.load(str(ssp))).to_pandas()
    assert len(back) == len(ours) == 2001
    common = [c for c in ours.dtype.names if c in back.columns and c != "time"]
    assert len(common) >= 10
    np.testing.assert_array_equal(back["time"].to_numpy(), ours["time"])
    for col in common:
        assert r.worst(back[col].to_numpy(), ours[col], ours[col]) <= 1e-12, col


def test_a_scenario_with_subsystems_exports_flat_and_runs_as_its_yaml(tmp_path) -> None:
    """scenarios/nested/paper_trajectory1_asmc.yaml (the robot as a subsystem): each inner block
    is one element named by its path ('robot__plant'); the SSP's rows equal the YAML's."""
    import twmr

    nested = r.ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml"
    ssp = export_ssp(nested, tmp_path / "nested.ssp", ["experiment.stop=0.5"])
    ours = twmr.simulate(twmr.load(nested, ["experiment.stop=0.5"]), formats=())
    theirs = twmr.simulate(twmr.load(str(ssp)), formats=())
    assert np.array_equal(ours.time, theirs.time)  # the YAML's recording, kept in the SSP
    for column in ours.columns[1:]:
        assert np.array_equal(ours[column], theirs[column.replace("robot.", "robot__")]), \
            column


def test_the_events_go_into_the_ssp_and_come_back(tmp_path) -> None:
    """A set event (a gain the controller's FMU declares tunable), a timed fault and a condition
    fault on the nested paper robot: the SSP's system holds no event block (another tool runs
    it without them), our annotation holds the events with the elements' names, and the SSP
    loaded back fires them as the YAML does, the same rows."""
    import zipfile

    import twmr

    nested = r.ROOT / "scenarios" / "nested" / "paper_trajectory1_asmc.yaml"
    text = nested.read_text(encoding="utf-8").replace(
        "path: ", f"path: {nested.parent}/", 1) + (
        "events:\n"
        "  - {name: gain, at: 0.2, set: ctrl.k, value: 40.0}\n"
        "  - {at: 0.3, until: 0.35, port: robot.plant.wheel_speed, fault: freeze}\n"
        "  - {when: 'robot.plant.pose[1] > 0.55', port: ctrl.torque, fault: scale, "
        "value: 0.5, duration: 0.05}\n")
    scenario = tmp_path / "events.yaml"
    scenario.write_text(text, encoding="utf-8")
    ssp = export_ssp(scenario, tmp_path / "events.ssp", ["experiment.stop=0.5"])
    ssd = zipfile.ZipFile(ssp).read("SystemStructure.ssd").decode()
    assert "fault" not in ssd.split("<ssd:DefaultExperiment")[0].lower()  # no event block
    assert 'set="&quot;ctrl.k&quot;"' in ssd and "robot__plant.wheel_speed" in ssd
    assert "robot__plant.pose[1] &gt; 0.55" in ssd
    ours = twmr.simulate(twmr.load(scenario, ["experiment.stop=0.5"]))
    theirs = twmr.simulate(twmr.load(str(ssp)))
    assert [f["located"] for f in theirs.summary["fired"]] == \
        [f["located"] for f in ours.summary["fired"]] and ours.summary["fired"]
    for column in ("robot.plant.pose[1]", "ctrl.torque[1]", "robot.plant.wheel_speed[2]"):
        assert np.array_equal(ours[column], theirs[column.replace("robot.", "robot__")]), \
            column
