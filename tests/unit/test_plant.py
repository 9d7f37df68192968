"""TWMR plant: eq. (8) term by term, M positive definite, straight driving, energy, RK4 order."""
from __future__ import annotations

import math

import numpy as np
import pytest

from twmr.components._model import derivative
from twmr.components.plant import TwmrPlant
from twmr.testing import Harness

A, IG, ID, IW, R, B, MW, MG = 0.3, 15.625, 0.0025, 0.1, 0.15, 0.75, 1.0, 30.0


def paper_matrices(varpi: float) -> dict[str, np.ndarray]:
    """The matrices of eq. (8) transcribed independently from the paper (Table I values)."""
    m11 = MG * (R**2 / 4 + A**2 * R**2 / (4 * B**2)) + R**2 / (4 * B**2) * (IG + 2 * ID) \
        + 2 * MW * R**2 + IW
    m12 = MG * (R**2 / 4 - A**2 * R**2 / (4 * B**2)) - R**2 / (4 * B**2) * (IG + 2 * ID)
    q1 = MG * R / 4 * (1 + A**2 / B**2) + R / (4 * B) * (IG + 2 * ID)
    q2 = MG * R / 4 * (1 - A**2 / B**2) - R / (4 * B) * (IG + 2 * ID)
    return {"M": np.array([[m11, m12], [m12, m11]]),
            "B": MG * R**2 / (2 * B) * varpi * np.array([[0.0, 1.0], [-1.0, 0.0]]),
            "Q": np.array([[q1, q2], [q2, q1]]),
            "C": MG * R / 2 * varpi * np.ones(2),
            "G": MG * A * R / (2 * B) * np.array([1.0, -1.0])}


def plant(initial: dict | None = None, step: float = 1e-3, **kw) -> Harness:
    """An initialized harness around the plant with parameters `kw` and start values `initial`,
    on [0, 10] s at communication step `step`. m11, m12, q1, q2 and `coefficients` are the model's
    own figures, not ports: they are read from `.component`."""
    return Harness(TwmrPlant, name="plant", parameters=kw, initial=initial, stop=10.0,
                   step=step).initialize()


def test_inertia_terms_match_the_paper() -> None:
    p = plant().component
    mats = paper_matrices(0.0)
    m11, m12, q1, q2 = p.m11, p.m12, p.q1, p.q2
    assert m11 == pytest.approx(mats["M"][0, 0], rel=1e-14)
    assert m12 == pytest.approx(mats["M"][0, 1], rel=1e-14)
    assert (q1, q2) == pytest.approx((mats["Q"][0, 0], mats["Q"][0, 1]), rel=1e-14)
    # by hand from Table I: m11 = 30 (0.005625 + 0.000900) + 0.01 (15.63) + 0.045 + 0.1
    assert m11 == pytest.approx(30 * (0.005625 + 0.0009) + 0.01 * 15.63 + 0.045 + 0.1)


def test_mass_matrix_is_symmetric_positive_definite() -> None:
    M = paper_matrices(0.0)["M"]
    assert np.allclose(M, M.T) and np.all(np.linalg.eigvalsh(M) > 0)


@pytest.mark.parametrize("seed", range(5))
def test_derivative_is_eq_8_and_eq_11_term_by_term(seed: int) -> None:
    rng = np.random.default_rng(seed)
    x, y, th, wR, wL = rng.normal(size=5)
    tau, mu, mu2, td = (rng.normal(size=2), rng.normal(size=3), rng.normal(size=3),
                        rng.normal(size=2))
    p = plant().component
    d = derivative(x, y, th, wR, wL, *tau, *mu, *mu2, *td, *p.coefficients)
    beta = R * (wR + wL) / 2 + (mu[0] + mu[1]) / 2  # eq. (2)
    varpi = R * (wR - wL) / (2 * B) + (mu[0] - mu[1]) / (2 * B)  # eq. (3)
    assert d[0] == pytest.approx(beta * math.cos(th) - mu[2] * math.sin(th))  # eq. (11)
    assert d[1] == pytest.approx(beta * math.sin(th) + mu[2] * math.cos(th))
    assert d[2] == pytest.approx(varpi)
    m = paper_matrices(varpi)
    nu = np.array([wR, wL])
    rhs = tau - m["B"] @ nu - m["Q"] @ mu2[:2] - m["C"] * mu[2] - m["G"] * mu2[2] - td  # eq. (8)
    np.testing.assert_allclose(d[3:], np.linalg.solve(m["M"], rhs), rtol=1e-12)


def test_b_is_skew_symmetric() -> None:
    Bm = paper_matrices(0.7)["B"]
    np.testing.assert_allclose(Bm, -Bm.T)


def test_equal_wheel_speeds_without_slip_drive_straight() -> None:
    p = plant(initial={"wheel_speed": (2.0, 2.0)})
    p.step(1000)  # 1 s at 1 ms
    x, y, th = p["pose"]
    assert th == 0.0 and y == 0.0
    assert x == pytest.approx(2.0 * R * 1.0, rel=1e-12)
    assert p["com"] == pytest.approx((x + A, 0.0))


def kinetic_energy(p: Harness) -> float:
    nu = np.array(p["wheel_speed"])
    c = p.component
    M = np.array([[c.m11, c.m12], [c.m12, c.m11]])
    return 0.5 * nu @ M @ nu


def test_energy_is_conserved_without_torque_slip_or_disturbance() -> None:
    p = plant(initial={"wheel_speed": (3.0, -1.0)})
    e0 = kinetic_energy(p)
    p.step(2000)  # 2 s at 1 ms
    assert kinetic_energy(p) == pytest.approx(e0, rel=1e-9)
    assert p["wheel_speed"] != (3.0, -1.0)  # B did exchange energy between the wheels


def run(internal_step: float) -> np.ndarray:
    p = plant(initial={"wheel_speed": (1.0, 0.2)}, step=1.0, internal_step=internal_step)
    p.set(slip_rate=(0.3, -0.2, 0.1), slip_accel=(0.5, 0.1, -0.2), disturbance=(0.4, -0.1))
    p.set(torque=(2.0, -1.0))
    p.step()  # one communication step of 1 s: do_step(0.0, 1.0)
    return np.array(p["pose"] + p["wheel_speed"])


def test_rk4_is_fourth_order() -> None:
    exact = run(1e-4)
    e1 = np.max(np.abs(run(0.1) - exact))
    e2 = np.max(np.abs(run(0.05) - exact))
    assert 10.0 < e1 / e2 < 22.0, e1 / e2


def test_scale_multiplies_masses_and_inertias() -> None:
    p, q = plant(scale=1.25), plant(m_G=37.5, m_W=1.25, I_G=15.625 * 1.25, I_D=0.003125,
                                     I_W=0.125)
    assert p.component.coefficients == pytest.approx(q.component.coefficients, rel=1e-14)
