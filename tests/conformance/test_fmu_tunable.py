"""A tunable parameter of a third-party FMU changed during a run (a set event): the Reference
FMU BouncingBall (FMI 2.0 and 3.0, co-simulation) with its coefficient of restitution `e`
(variability tunable) set from 0.7 to 0.95 at 1 s gives, at every communication point, the
heights of a hand-written fmpy loop that sets it there; its `g` (fixed) is refused at check."""
from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.core.errors import ScenarioError

pytestmark = pytest.mark.timeout(240)
STEP, STOP, AT, E = 0.01, 3.0, 1.0, 0.95


def _fmpy_loop(path: Path, fmi3: bool) -> np.ndarray:
    """h at every communication point, e set to E before the step from AT: fmpy alone."""
    import fmpy
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    md = fmpy.read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = fmpy.extract(str(path))
    try:
        cls = FMU3Slave if fmi3 else FMU2Slave
        fmu = cls(guid=md.guid if not fmi3 else md.instantiationToken,
                  unzipDirectory=unzipped,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="ball")
        fmu.instantiate()
        if fmi3:
            fmu.enterInitializationMode(startTime=0.0)
        else:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        get = fmu.getFloat64 if fmi3 else fmu.getReal
        put = fmu.setFloat64 if fmi3 else fmu.setReal
        heights = [get([vr["h"]])[0]]
        n = round(STOP / STEP)
        for k in range(n):
            t = k * STEP
            if k == round(AT / STEP):
                put([vr["e"]], [E])
            fmu.doStep(t, STEP) if fmi3 else fmu.doStep(currentCommunicationPoint=t,
                                                         communicationStepSize=STEP)
            heights.append(get([vr["h"]])[0])
        fmu.terminate()
        fmu.freeInstance()
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)
    return np.asarray(heights)


def _scenario(path: Path, event: str) -> dict:
    return {"components": {"ball": {"kind": "fmu", "parameters": {"path": str(path)}}},
            "events": [eval(event)],  # noqa: S307 - the test's own literal
            "experiment": {"stop": STOP, "step": STEP}, "record": {"signals": ["ball.h"]}}


@pytest.mark.parametrize("name", ["BouncingBall_fmi2.fmu", "BouncingBall_fmi3.fmu"])
def test_a_tunable_fmu_parameter_set_mid_run_is_the_fmpy_loops(name: str) -> None:
    pytest.importorskip("fmpy")
    path = corpus("reference-fmus", name)
    ours = twmr.simulate(twmr.load(_scenario(path, f"{{'at': {AT}, 'set': 'ball.e', "
                                                   f"'value': {E}}}")))
    theirs = _fmpy_loop(path, name.endswith("fmi3.fmu"))
    np.testing.assert_array_equal(np.asarray(ours["ball.h"]), theirs)
    plain = twmr.simulate(twmr.load(_scenario(path, f"{{'at': {AT}, 'set': 'ball.e', "
                                                    f"'value': 0.7}}")))
    assert not np.array_equal(np.asarray(plain["ball.h"]), theirs)  # e matters here


def test_a_fixed_fmu_parameter_set_mid_run_is_refused_at_check() -> None:
    path = corpus("reference-fmus", "BouncingBall_fmi2.fmu")
    with pytest.raises(ScenarioError, match=r"'ball.g' cannot change during a run: the FMU "
                                            r"declares it fixed .*Fix:"):
        twmr.load(_scenario(path, "{'at': 1.0, 'set': 'ball.g', 'value': -3.0}"))
