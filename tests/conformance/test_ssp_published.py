"""SSP files other tools publish: libcosim's own test system (connectors named per element of an
FMI 2 array variable, `p_Crane.f[1]`; an inline parameter set; the base step in an OSP
annotation) run equal to libcosimpy's run of the same file; OMSimulator's embrace test system
(dotted connector names such as `consumerFeed.p`, units written '[m]') runs; a scenario exported
as SSP runs back with the YAML's recording, so its rows and metrics are the YAML's."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.fmi.ssp.read import load_ssp

pytestmark = pytest.mark.timeout(300)

ROOT = Path(__file__).resolve().parents[2]

#: libcosimpy's run of an SSP to `stop`, in a process of its own (libcosim logs to stderr): the
#: last value of every Real variable, by 'instance.variable'
LIBCOSIM = textwrap.dedent("""
    import json, sys
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimObserver import CosimObserver
    ex = CosimExecution.from_ssp_file(ssp_path=sys.argv[1])
    obs = CosimObserver.create_last_value()
    ex.add_observer(obs)
    ex.simulate_until(target_time=int(round(float(sys.argv[2]) * 1e9)))
    out = {}
    for s in ex.slave_infos():
        reals = [v for v in ex.slave_variables(s.index) if v.type == 0]
        got = obs.last_real_values(slave_index=s.index,
                                   variable_references=[v.reference for v in reals])
        out.update({f"{s.name.decode()}.{v.name.decode()}": x for v, x in zip(reals, got)})
    print("END VALUES " + json.dumps(out))
""")


def libcosim_end_values(ssp: Path, stop: float) -> dict[str, float]:
    pytest.importorskip("libcosimpy", reason="libcosimpy (the reference runner) is not here")
    done = subprocess.run([sys.executable, "-c", LIBCOSIM, str(ssp), repr(stop)],
                          capture_output=True, text=True, timeout=240, check=True)
    line = next(x for x in done.stdout.splitlines() if x.startswith("END VALUES "))
    return dict(json.loads(line.removeprefix("END VALUES ")))


def test_libcosim_demo_is_read_with_its_step_algorithm_and_parameters() -> None:
    ssp = corpus("ssp", "libcosim-demo.ssp")
    spec = load_ssp(ssp)
    assert spec.experiment.step.value == 1e-4  # the OSP annotation's baseStepSize
    assert spec.experiment.algorithm.value == "jacobi"  # libcosim's fixed-step algorithm
    crane = spec.components["KnuckleBoomCrane"]
    assert crane.parameters["Spring_Joint.k"].value == 0.005
    assert crane.parameters["mt0_init"].value == 69.0
    wires = {c.value for c in spec.connections}
    assert "CraneController.p_Crane.e[1] -> KnuckleBoomCrane.p_Crane.e[1]" in wires
    assert "KnuckleBoomCrane.p_Crane.f[3] -> CraneController.p_Crane.f[3]" in wires


@pytest.mark.parametrize("stop", [2e-4, 0.05])
def test_libcosim_demo_ends_where_libcosim_ends(stop: float, tmp_path: Path) -> None:
    ssp = corpus("ssp", "libcosim-demo.ssp")
    theirs = libcosim_end_values(ssp, stop)
    scenario = twmr.load(str(ssp), [f"experiment.stop={stop!r}"])
    rows = twmr.simulate(scenario, out=str(tmp_path / "run")).to_pandas()
    assert rows["time"].iloc[-1] == pytest.approx(stop, abs=1e-12)
    shared = [c for c in rows.columns if c in theirs]
    assert len(shared) >= 9  # p_Crane.e[1..3], p_Crane.f[1..3], Act_Limits[1..3]
    for column in shared:
        assert abs(rows[column].iloc[-1] - theirs[column]) <= 1e-9, column


def test_embrace_runs_with_dotted_connectors(tmp_path: Path) -> None:
    import locale

    folder = corpus("ssp", "omsimulator-embrace")
    before = locale.setlocale(locale.LC_ALL)
    spec = load_ssp(folder)
    wires = {c.value for c in spec.connections}
    assert any(".consumerFeed.p" in w for w in wires)
    result = twmr.simulate(twmr.load(str(folder)), out=str(tmp_path / "run"))
    rows = result.to_pandas()
    assert len(rows) == 1001 and rows["time"].iloc[-1] == 1.0
    assert np.isfinite(rows.drop(columns="time").to_numpy()).all()
    assert "Consumer.consumerFeed.p" in rows.columns
    # its FMUs set the C locale (Python would read text as ASCII after them): set back
    assert locale.setlocale(locale.LC_ALL) == before


def test_round_trip_keeps_the_recording_and_so_the_metrics(tmp_path: Path) -> None:
    from twmr.fmi.ssp.write import export_ssp

    yaml_path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    overrides = ["experiment.stop=2.0"]
    ssp = export_ssp(yaml_path, tmp_path / "paper.ssp", overrides)
    ours = twmr.simulate(twmr.load(yaml_path, overrides), metrics=["tracking"])
    back = twmr.simulate(twmr.load(str(ssp)), metrics=["tracking"])
    a, b = ours.to_pandas(), back.to_pandas()
    assert list(a.columns) == list(b.columns) and len(a) == len(b) == 201  # decimation 10
    np.testing.assert_allclose(b.to_numpy(), a.to_numpy(), rtol=0, atol=1e-12)
    ma, mb = ours.summary["metrics"], back.summary["metrics"]
    assert ma.keys() == mb.keys() and ma
    for name in ma:
        assert mb[name] == pytest.approx(ma[name], rel=1e-9, abs=1e-12), name


def test_jacobi_run_keeps_libcosims_states(tmp_path: Path) -> None:
    """The paper scenario under Jacobi, exported as SSP and run by libcosim: every state the
    rows show (pose, wheel speeds, the adaptive gains) equal to twmr's Jacobi run of the YAML
    after 2 s. (A feedthrough output in a row of ours is the one of that row's inputs; libcosim
    shows the one computed before them, a step earlier.)"""
    from twmr.fmi.ssp.write import export_ssp

    yaml_path = ROOT / "scenarios" / "paper_trajectory1_asmc.yaml"
    overrides = ["experiment.stop=2.0", "experiment.algorithm=jacobi"]
    ssp = export_ssp(yaml_path, tmp_path / "paper.ssp", overrides)
    theirs = libcosim_end_values(ssp, 2.0)
    ours = twmr.simulate(twmr.load(yaml_path, overrides)).to_pandas().iloc[-1]
    states = [c for c in ours.index if c.startswith(("plant.pose", "plant.wheel_speed"))
              or "d_hat" in c]
    assert len(states) == 7
    for column in states:
        assert abs(ours[column] - theirs[column]) <= 1e-9 * max(1.0, abs(theirs[column])), column


def test_exported_fmu_computes_its_outputs_in_initialization_mode(tmp_path: Path) -> None:
    """FMI 2.0: a calculated output got in initialization mode is computed from the inputs set
    there (libcosim's initialisation reads them so)."""
    fmpy = pytest.importorskip("fmpy")
    from fmpy.fmi2 import FMU2Slave

    from twmr.fmi.cexport import export_c_fmu

    path = export_c_fmu("gain", tmp_path / "gain.fmu", parameters={"k": 3.0})
    md = fmpy.read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(path), str(tmp_path / "u")),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["u"]], [2.0])
    assert fmu.getReal([vr["y"]]) == [6.0]
    fmu.exitInitializationMode()
    assert fmu.getReal([vr["y"]]) == [6.0]
    fmu.terminate()
    fmu.freeInstance()
