"""An FMU's continuous linear model by its directional derivatives (`twmr linearize --fmu`):
the Reference FMU VanDerPol (FMI 2.0, model exchange, which provides them) at t = 1.5 s of a
run gives A = [[0, 1], [-2 mu x0 x1 - 1, mu (1 - x0^2)]] at the state the run reached there,
and C the identity (its outputs are its states); the FMI 3.0 builds of VanDerPol and Roberts
give theirs by directional and by adjoint derivatives alike, and VanDerPol run as co-simulation
the Jacobian of what it integrates; an FMU without the derivatives asked for is refused with the
reason and the fix."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import twmr
from tests.conformance.corpus import corpus
from twmr.core.errors import CosimError
from twmr.linear_analysis import linearize_fmu

pytestmark = pytest.mark.timeout(240)


def scenario(path: Path, interface: str = "model_exchange") -> dict:
    return {"components": {"vdp": {"kind": "fmu", "parameters": {
        "path": str(path), "interface": interface}}},
        "experiment": {"stop": 5.0, "step": 0.01}}


def test_vanderpol_gives_its_analytic_jacobian_at_the_runs_state() -> None:
    path = corpus("reference-fmus", "VanDerPol_fmi2.fmu")
    model = linearize_fmu(scenario(path), "vdp", at=1.5)
    run = twmr.simulate(twmr.load(scenario(path), ["experiment.stop=1.5"]))
    x0, x1, mu = float(run["vdp.x0"][-1]), float(run["vdp.x1"][-1]), 1.0
    assert model.at == pytest.approx(1.5) and model.states == ["x0", "x1"]
    np.testing.assert_allclose(model.A, [[0.0, 1.0], [-2 * mu * x0 * x1 - 1, mu * (1 - x0 ** 2)]],
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(model.C, np.eye(2))
    assert model.B.shape == (2, 0) and model.inputs == []


@pytest.mark.parametrize("derivatives", ["directional", "adjoint"])
def test_fmi3_vanderpol_gives_it_by_directional_and_by_adjoint_derivatives(derivatives) -> None:
    """FMI 3.0 names the flag providesDirectionalDerivatives (fmpy reads only FMI 2.0's
    singular), and offers adjoint derivatives as well: a row per rate and output."""
    path = corpus("reference-fmus", "VanDerPol_fmi3.fmu")
    model = linearize_fmu(scenario(path), "vdp", at=0.5, derivatives=derivatives)
    run = twmr.simulate(twmr.load(scenario(path), ["experiment.stop=0.5"]))
    x0, x1, mu = float(run["vdp.x0"][-1]), float(run["vdp.x1"][-1]), 1.0
    np.testing.assert_allclose(model.A, [[0.0, 1.0], [-2 * mu * x0 * x1 - 1, mu * (1 - x0 ** 2)]],
                               rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(model.C, np.eye(2))


@pytest.mark.parametrize("name", ["VanDerPol_fmi2.fmu", "VanDerPol_fmi3.fmu"])
def test_a_co_simulation_fmu_gives_the_jacobian_of_what_it_integrates(name) -> None:
    """Run as co-simulation (its own solver), VanDerPol still provides directional derivatives
    (FMI 2.0 and 3.0 allow them between steps): at t = 0.5 s its Jacobian at the state it
    reached is the analytic one, to 1e-12."""
    path = corpus("reference-fmus", name)
    model = linearize_fmu(scenario(path, "co_simulation"), "vdp", at=0.5)
    run = twmr.simulate(twmr.load(scenario(path, "co_simulation"), ["experiment.stop=0.5"]))
    x0, x1 = float(run["vdp.x0"][-1]), float(run["vdp.x1"][-1])
    np.testing.assert_allclose(model.A, [[0.0, 1.0], [-2 * x0 * x1 - 1, 1 - x0 ** 2]],
                               rtol=1e-12, atol=1e-12)


def test_roberts_directional_and_adjoint_derivatives_agree() -> None:
    """The stiff Robertson kinetics (FMI 3.0): the Jacobian by columns (directional) and by rows
    (adjoint) is the same matrix, with the rates' entries -0.04 and 0.04 of y1."""
    path = corpus("reference-fmus", "Roberts_fmi3.fmu")
    by_columns = linearize_fmu(scenario(path), "vdp", at=0.5, derivatives="directional")
    by_rows = linearize_fmu(scenario(path), "vdp", at=0.5, derivatives="adjoint")
    np.testing.assert_allclose(by_rows.A, by_columns.A, rtol=1e-12)
    np.testing.assert_allclose(by_rows.C, by_columns.C, rtol=1e-12)
    assert by_columns.A[0, 0] == pytest.approx(-0.04) and by_columns.A[1, 0] == pytest.approx(0.04)
    assert by_columns.states == ["y1", "y2"]


def test_what_cannot_be_linearised_so_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CosimError, match=r"its co-simulation interface does not provide "
                                         r"directional or adjoint derivatives.*Fix:"):
        linearize_fmu(scenario(corpus("reference-fmus", "Dahlquist_fmi2.fmu"),
                               "co_simulation"), "vdp", at=1.0)
    with pytest.raises(CosimError, match="its model exchange interface does not provide "
                                         "directional or adjoint derivatives"):
        linearize_fmu(scenario(corpus("reference-fmus", "Dahlquist_fmi2.fmu")), "vdp", at=1.0)
    with pytest.raises(CosimError, match="does not provide adjoint derivatives"):
        linearize_fmu(scenario(corpus("reference-fmus", "VanDerPol_fmi2.fmu")), "vdp", at=1.0,
                      derivatives="adjoint")
    with pytest.raises(CosimError, match=r"derivatives = 'forward' is none of"):
        linearize_fmu(scenario(corpus("reference-fmus", "VanDerPol_fmi2.fmu")), "vdp", at=1.0,
                      derivatives="forward")
    with pytest.raises(CosimError, match=r"no FMU component of that name.*did you mean 'vdp'"):
        linearize_fmu(scenario(corpus("reference-fmus", "VanDerPol_fmi2.fmu")), "vpd", at=1.0)


def test_the_command_writes_the_fmus_model(tmp_path: Path) -> None:
    import yaml

    (tmp_path / "vdp.yaml").write_text(yaml.safe_dump(scenario(
        corpus("reference-fmus", "VanDerPol_fmi2.fmu"))))
    done = subprocess.run([sys.executable, "-m", "twmr.cli", "linearize", "vdp.yaml", "--fmu",
                           "vdp", "--at", "1.5", "--out", "lin"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=200)
    assert done.returncode == 0, done.stderr
    plain = json.loads((tmp_path / "lin" / "linear.json").read_text())
    assert plain["continuous"] and plain["states"] == ["x0", "x1"] and "A =" in done.stdout
