"""`twmr export` of standalone C FMUs: the command line, bad input refused with one clear
paragraph, the FMI rules of parameters (fixed, tunable, min/max), FMU state save/restore, and an
FMU shipped without its binary compiled from its own sources by an importer."""
from __future__ import annotations

import math
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from twmr.core.errors import CosimError
from twmr.fmi.cexport import export_c_fmu
from twmr.testing import Harness

TWMR = [sys.executable, "-m", "twmr.cli"]


def test_cli_exports_a_standalone_fmu(tmp_path) -> None:
    out = tmp_path / "ctrl.fmu"
    done = subprocess.run([*TWMR, "export", "asmc", "--fmi", "3", "--out", str(out), "--set",
                           "eta=5.5"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == str(out.resolve())
    md = zipfile.ZipFile(out).read("modelDescription.xml").decode()
    assert 'fmiVersion="3.0"' in md and 'name="eta"' in md and 'start="5.5"' in md
    assert "pythonfmu" not in md.lower()


@pytest.mark.parametrize("args, words", [
    (["export", "no_such_kind"], ["unknown component kind 'no_such_kind'"]),
    (["export", "fmu"], ["kind 'fmu' has no C kernel", "--python"]),
    (["export", "slip_disturbance", "--set", "profile=random"],
     ["profile 'random' has no C kernel", "--python"]),
    (["export", "trajectory", "--set", "shape=waypoints"], ["shape 'waypoints'"]),
    (["export", "state_space", "--set", "A=[1, 2]"], ["A has 2 values but B has 1"]),
    (["export", "asmc", "--set", "eta=-1"], ["'eta'", "below the minimum"]),
    (["export", "asmc", "--set", "etta=1"], ["'etta' is not a parameter"]),
    (["export", "gain", "--fmi", "4"], ["invalid choice: 4"]),
    (["export", "gain", "--python", "--fmi", "3"], ["--python exports FMI 2.0 only"]),
    (["export", "gain", "--set", "k=.inf"], ["'k' = inf is not a finite number"]),
])
def test_cli_refuses_bad_input_in_one_paragraph(args, words, tmp_path) -> None:
    done = subprocess.run([*TWMR, *args, "--out", str(tmp_path / "x.fmu")], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode != 0
    assert "Traceback" not in done.stderr
    for word in words:
        assert word in done.stderr
    assert not (tmp_path / "x.fmu").exists()


def test_missing_compiler_is_named(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv("CC", "no-such-cc")
    with pytest.raises(CosimError, match="no C compiler: 'no-such-cc'"):
        export_c_fmu("gain", tmp_path / "g.fmu")


def _slave(path: Path, tmp: Path):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path), str(tmp)),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    return fmu, {v.name: v.valueReference for v in md.modelVariables}


def test_parameter_rules_fixed_tunable_and_range(tmp_path) -> None:
    from fmpy.fmi1 import FMICallException

    fmu, vr = _slave(export_c_fmu("gain", tmp_path / "g.fmu", {"k": 2.0}), tmp_path / "g")
    plant, pvr = _slave(export_c_fmu("twmr_plant", tmp_path / "p.fmu"), tmp_path / "p")
    try:
        with pytest.raises(FMICallException):  # scale has min 1e-6
            plant.setReal([pvr["scale"]], [0.0])
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        fmu.setReal([vr["u"]], [3.0])
        assert fmu.getReal([vr["y"]]) == [6.0]
        fmu.setReal([vr["k"]], [-1.5])  # tunable: takes effect at once
        assert fmu.getReal([vr["y"]]) == [-4.5]
        plant.enterInitializationMode()
        plant.exitInitializationMode()
        with pytest.raises(FMICallException):  # fixed after initialization
            plant.setReal([pvr["m_G"]], [40.0])
        with pytest.raises(FMICallException):  # an output is never set
            plant.setReal([pvr["com[1]"]], [1.0])
    finally:
        for f in (fmu, plant):
            f.terminate()
            f.freeInstance()


def test_fmu_state_save_restore_and_serialize_replays_exactly(tmp_path) -> None:
    fmu, vr = _slave(export_c_fmu("asmc", tmp_path / "a.fmu"), tmp_path / "a")
    ins = [vr[f"pose[{i}]"] for i in (1, 2, 3)]
    out = [vr["torque[1]"], vr["d_hat[1]"]]

    def run(n: int, t0: float) -> list[float]:
        for k in range(n):
            fmu.setReal(ins, [0.1 * np.sin(t0 + k * 1e-3), 0.2, -0.3])
            fmu.doStep(t0 + k * 1e-3, 1e-3)
        return fmu.getReal(out)

    try:
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        run(50, 0.0)
        state = fmu.getFMUstate()
        blob = fmu.serializeFMUstate(state)
        first = run(50, 0.05)
        fmu.setFMUstate(state)
        assert run(50, 0.05) == first
        restored = fmu.deSerializeFMUstate(blob)
        fmu.setFMUstate(restored)
        assert run(50, 0.05) == first
        fmu.freeFMUstate(state)
        fmu.freeFMUstate(restored)
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_fmu_without_binary_compiles_from_its_sources(tmp_path) -> None:
    full = export_c_fmu("integrator", tmp_path / "full.fmu", {"k": 2.0, "x0": 1.0}, fmi=3)
    bare = tmp_path / "bare.fmu"
    with zipfile.ZipFile(full) as src, zipfile.ZipFile(bare, "w") as dst:
        for name in src.namelist():
            if not name.startswith("binaries/"):
                dst.writestr(name, src.read(name))
    with Harness("fmu", parameters={"path": str(bare), "compile": True}) as h:
        h.set(u=0.5)
        h.initialize()
        for _ in range(10):
            h.step()
        assert h["y"] == pytest.approx(1.0 + 2.0 * 0.5 * 10 * 1e-3, abs=1e-12)
        built = h.component.path  # compiled here from sources/ (FMI 3 buildDescription.xml)
    assert built != bare
    assert any(n.startswith("binaries/") for n in zipfile.ZipFile(built).namelist())


def _logged_slave(path: Path, fmi: int, tmp: Path, stop: float | None):
    """An instance of the FMU at `path` in step mode (experiment from 0 to `stop`) whose log
    lands in the returned FmuLog, and its value references by name."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    from twmr.fmi.log import FmuLog

    md = read_model_description(str(path))
    log = FmuLog("p")
    fmu = (FMU2Slave if fmi == 2 else FMU3Slave)(
        guid=md.guid, unzipDirectory=extract(str(path), str(tmp)),
        modelIdentifier=md.coSimulation.modelIdentifier, instanceName="p")
    if fmi == 2:
        fmu.instantiate(callbacks=log.fmi2_callbacks(), loggingOn=True)
        fmu.setupExperiment(startTime=0.0, stopTime=stop)
        fmu.enterInitializationMode()
    else:
        fmu.instantiate(loggingOn=True, logMessage=log.fmi3_logger())
        fmu.enterInitializationMode(startTime=0.0, stopTime=stop)
    fmu.exitInitializationMode()
    return fmu, log, {v.name: v.valueReference for v in md.modelVariables}


@pytest.mark.parametrize("fmi", [2, 3])
def test_bad_steps_and_nan_inputs_are_refused_and_logged(fmi, tmp_path) -> None:
    """doStep with h <= 0, h not finite, a step the plant cannot take (h = 1e308: more RK4
    substeps than it may do) or one past the experiment's stop time, and a NaN input, each give
    fmi2Error/fmi3Error and a log line saying why; the state is left as it was."""
    from fmpy.fmi1 import FMICallException

    path = export_c_fmu("twmr_plant", tmp_path / "p.fmu", fmi=fmi)
    for stop, cases in [(None, [(0.0, "positive finite"), (-1e-3, "positive finite"),
                                (math.nan, "positive finite"), (math.inf, "positive finite"),
                                (1e308, "RK4 substeps")]),
                        (0.01, [(0.007, "after the experiment's stop time")])]:
        fmu, log, vr = _logged_slave(path, fmi, tmp_path / str(stop), stop)
        get = fmu.getReal if fmi == 2 else fmu.getFloat64
        set_ = fmu.setReal if fmi == 2 else fmu.setFloat64
        try:
            set_([vr["torque[1]"], vr["torque[2]"]], [1.0, 1.0])
            fmu.doStep(0.0, 0.004)
            state = get([vr["pose[1]"], vr["wheel_speed[1]"]])
            assert state[1] > 0.0
            for h, why in cases:
                with pytest.raises(FMICallException):
                    fmu.doStep(0.004, h)
                assert "refused" in log.tail()[-1] and why in log.tail()[-1], log.tail()
                assert get([vr["pose[1]"], vr["wheel_speed[1]"]]) == state
            with pytest.raises(FMICallException):
                set_([vr["torque[1]"]], [math.nan])
            assert "'torque[1]' = NaN is refused" in log.tail()[-1]
            fmu.doStep(0.004, 0.004)  # still usable; the torque held is the last valid one
            assert get([vr["wheel_speed[1]"]])[0] == pytest.approx(2 * state[1], rel=1e-12)
        finally:
            fmu.terminate()
            fmu.freeInstance()


def test_a_non_finite_start_value_is_refused_at_export(tmp_path) -> None:
    with pytest.raises(CosimError, match=r"parameter 'k' = inf is not a finite number.*Fix"):
        export_c_fmu("gain", tmp_path / "g.fmu", {"k": math.inf})
    assert not (tmp_path / "g.fmu").exists()


def test_state_space_exported_without_feedthrough_keeps_d_zero(tmp_path) -> None:
    """D = 0 at export: y does not depend on u in the FMU's structure, so D cannot become
    nonzero through FMI (its min and max are 0); D != 0 at export may be changed freely."""
    from fmpy.fmi1 import FMICallException

    strict, vr = _slave(export_c_fmu("state_space", tmp_path / "s0.fmu"), tmp_path / "s0")
    free, vr1 = _slave(export_c_fmu("state_space", tmp_path / "s1.fmu", {"D": 0.5}),
                       tmp_path / "s1")
    try:
        with pytest.raises(FMICallException):
            strict.setReal([vr["D"]], [0.5])
        free.setReal([vr1["D"]], [0.0])
    finally:
        for f in (strict, free):
            f.freeInstance()
