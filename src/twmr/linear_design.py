"""Controller design on a linear model of a scenario (`twmr linearize --design`,
`twmr.linear_design.design`): an output-feedback controller from the model's outputs to its
inputs, by LQG or by pole placement, with the closed loop's poles and margins, written as a
`state_space` block ready to wire.

The model is discrete at the base step (`twmr.linear_analysis.LinearModel`, a realisation ERA
chose), so the design is too, and is made so that it does not depend on that realisation:

- **LQG**: the regulator K = dlqr(A, B, C' Q C, R) weighs the outputs (Q = q I, R = r I); the
  estimator gain L is the steady Kalman predictor's for process noise entering at the inputs
  (covariance B (w I) B') and measurement noise v I. A change of state coordinates changes K
  and L but not the controller's transfer function nor the closed loop's poles.
- **LQI**: LQG with integral action: an integrator per output, z[k+1] = z[k] + y[k], and
  [Kx Kz] = dlqr of the plant augmented with them (weights q on the outputs, qi on their
  integrals, r on the inputs); with the same Kalman predictor for x. It drives the outputs back
  to the point's values under a constant disturbance (a steady error LQG leaves). It needs at
  least as many inputs as outputs.
- **Pole placement**: K and L placing the regulator's and the estimator's discrete poles.

The controller (a predicting estimator: strictly proper, u[k] depends on y up to k - 1):

    x^[k+1] = (A - B K - L C + L D K) x^[k] + L y[k],   u[k] = -K x^[k]

and for LQI, with the integrators' states z beside x^ (u[k] = -Kx x^[k] - Kz z[k]).

Both work on deviations from the point the model was taken at (y - y0 in, u - u0 out). The
closed loop's poles are those of A - B K and A - L C (separation). `block_yaml()` writes the
controller's continuous twin (the matrix logarithm, exact under the block's zero-order-hold
discretisation at the same step), so in a scenario at that step it acts as the discrete
controller does."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from twmr.core.errors import CosimError
from twmr.linear_analysis import LinearModel, continuous_twin

METHODS = ("lqg", "lqi", "place")


@dataclass
class Design:
    """An output-feedback controller of `model` (see the module docstring): gains K (m x n),
    L (n x p) and the controller's discrete matrices from y (p) to u (m)."""

    model: LinearModel
    method: str
    K: np.ndarray
    L: np.ndarray
    Ac: np.ndarray
    Bc: np.ndarray
    Cc: np.ndarray

    def controller(self) -> Any:
        """The controller as a python-control discrete `StateSpace` from y to u."""
        import control

        m, p = self.Cc.shape[0], self.Bc.shape[1]
        return control.ss(self.Ac, self.Bc, self.Cc, np.zeros((m, p)), self.model.dt)

    def closed_loop(self) -> np.ndarray:
        """The closed loop's state matrix over (plant, controller) states."""
        A, B, C, D = self.model.A, self.model.B, self.model.C, self.model.D
        return np.block([[A, B @ self.Cc], [self.Bc @ C, self.Ac + self.Bc @ D @ self.Cc]])

    def closed_loop_poles(self) -> np.ndarray:
        return np.linalg.eigvals(self.closed_loop())

    def loop(self) -> Any:
        """The loop transfer broken at the plant's input, -controller x plant (negative
        feedback convention; one input and one output)."""
        if self.K.shape[0] != 1 or self.L.shape[1] != 1:
            raise CosimError("margins are read on a loop of one input and one output. Fix: "
                             "linearise from one input port to one output.")
        return -(self.controller() * self.model.ss())

    def margins(self) -> tuple[float, float, float, float]:
        """(gain margin, phase margin [deg], phase crossover [rad/s], gain crossover [rad/s])
        of `loop()` (python-control's `margin`)."""
        import control

        gm, pm, wcg, wcp = control.margin(self.loop())
        return float(gm), float(pm), float(wcg), float(wcp)

    def block_yaml(self, name: str = "") -> str:
        """A `state_space` component `name` (default: the method's) of the controller
        (continuous twin), inputs the model's outputs, outputs its inputs (deviations from the
        point)."""
        import yaml

        a, b = continuous_twin(self.Ac, self.Bc, self.model.dt, "the controller")
        m, p = self.Cc.shape[0], self.Bc.shape[1]
        params = {"n_in": p, "n_out": m, "A": a.tolist(), "B": b.tolist(),
                  "C": self.Cc.tolist(), "D": 0.0 if m * p == 1 else np.zeros((m, p)).tolist()}
        head = (f"# {self.method} controller designed at t = {self.model.at:g} s, step "
                f"{self.model.dt:g} s: in {', '.join(self.model.outputs)}, out "
                f"{', '.join(self.model.inputs)} (deviations from their values then)\n")
        return head + yaml.safe_dump({name or self.method: {"kind": "state_space",
                                                            "parameters": params}},
                                     sort_keys=False)

    def plain(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "method": self.method, "K": self.K.tolist(), "L": self.L.tolist(),
            "Ac": self.Ac.tolist(), "Bc": self.Bc.tolist(), "Cc": self.Cc.tolist(),
            "dt": self.model.dt, "closed_loop_poles": [
                [float(z.real), float(z.imag)] for z in np.sort_complex(self.closed_loop_poles())]}
        if self.K.shape[0] == 1 and self.L.shape[1] == 1:
            gm, pm, wcg, wcp = self.margins()
            out["margins"] = {"gain_margin": gm, "phase_margin_deg": pm,
                              "phase_crossover_rad_s": wcg, "gain_crossover_rad_s": wcp}
        return out


def design(model: LinearModel, method: str = "lqg", *, q: float = 1.0, r: float = 1.0,
           w: float = 1.0, v: float = 1.0, qi: float = 1.0, poles: Sequence[complex] = (),
           observer_poles: Sequence[complex] = ()) -> Design:
    """An output-feedback controller of `model` by `method` 'lqg' (weights q on the outputs, r
    on the inputs; noise intensities w at the inputs, v on the outputs), 'lqi' (LQG with an
    integrator per output, weighed qi) or 'place' (the regulator's discrete `poles` and the
    estimator's `observer_poles`, one per state)."""
    import control

    A, B, C, D = model.A, model.B, model.C, model.D
    n, m, p = model.order, B.shape[1], C.shape[0]
    if n == 0:
        raise CosimError("the linear model has no state: there is nothing to control. Fix: "
                         "linearise at a point where the inputs move the outputs.")
    if method == "lqi":
        return _lqi(model, q, r, w, v, qi)
    if method == "lqg":
        for label, value in (("output weight q", q), ("input weight r", r),
                             ("process noise w", w), ("measurement noise v", v)):
            if not (math.isfinite(value) and value > 0):
                raise CosimError(f"{label} {value}: a weight is above 0. Fix: give a "
                                 f"positive number.")
        K, _, _ = control.dlqr(A, B, C.T @ (q * np.eye(p)) @ C + 1e-12 * np.eye(n),
                               r * np.eye(m))
        G = B @ (w * np.eye(m)) @ B.T + 1e-12 * np.eye(n)
        L = _kalman_predictor(A, C, G, v * np.eye(p))
    elif method == "place":
        for label, given in (("--poles", poles), ("--observer-poles", observer_poles)):
            if len(given) != n or any(abs(z) >= 1 for z in given):
                raise CosimError(f"{label}: give {n} discrete poles (the model's order) inside "
                                 f"the unit circle (|z| < 1), e.g. 0.9 for a time constant of "
                                 f"{-model.dt / math.log(0.9):.3g} s.")
        K = control.place(A, B, list(poles))
        L = control.place(A.T, C.T, list(observer_poles)).T
    else:
        raise CosimError(f"--design {method!r} is not a method. Fix: give one of "
                         f"{', '.join(METHODS)}.")
    K, L = np.asarray(K, dtype=float), np.asarray(L, dtype=float)
    Ac = A - B @ K - L @ C + L @ D @ K
    return Design(model, method, K, L, Ac, L, -K)


def _lqi(model: LinearModel, q: float, r: float, w: float, v: float, qi: float) -> Design:
    """LQG with an integrator per output (the module docstring)."""
    import control

    A, B, C, D = model.A, model.B, model.C, model.D
    n, m, p = model.order, B.shape[1], C.shape[0]
    for label, value in (("output weight q", q), ("input weight r", r), ("process noise w", w),
                         ("measurement noise v", v), ("integral weight qi", qi)):
        if not (math.isfinite(value) and value > 0):
            raise CosimError(f"{label} {value}: a weight is above 0. Fix: give a positive "
                             f"number.")
    if m < p:
        raise CosimError(f"lqi integrates each of the {p} outputs with {m} input(s): fewer "
                         f"inputs than integrators cannot hold them all at zero. Fix: "
                         f"linearise to at most {m} output(s), or use --design lqg.")
    Aa = np.block([[A, np.zeros((n, p))], [C, np.eye(p)]])
    Ba = np.vstack([B, D])
    Qa = np.block([[C.T @ (q * np.eye(p)) @ C + 1e-12 * np.eye(n), np.zeros((n, p))],
                   [np.zeros((p, n)), qi * np.eye(p)]])
    Ka, _, _ = control.dlqr(Aa, Ba, Qa, r * np.eye(m))
    Ka = np.asarray(Ka, dtype=float)
    Kx, Kz = Ka[:, :n], Ka[:, n:]
    G = B @ (w * np.eye(m)) @ B.T + 1e-12 * np.eye(n)
    L = _kalman_predictor(A, C, G, v * np.eye(p))
    Ac = np.block([[A - B @ Kx - L @ C + L @ D @ Kx, -B @ Kz + L @ D @ Kz],
                   [np.zeros((p, n)), np.eye(p)]])
    Bc = np.vstack([L, np.eye(p)])
    return Design(model, "lqi", Ka, L, Ac, Bc, -Ka)


def _kalman_predictor(A: np.ndarray, C: np.ndarray, Qn: np.ndarray, Rn: np.ndarray
                      ) -> np.ndarray:
    """The steady Kalman predictor's gain L (x^[k+1] = A x^ + B u + L (y - C x^ - D u)) from
    the discrete Riccati equation of the dual problem."""
    from scipy.linalg import solve_discrete_are

    P = solve_discrete_are(A.T, C.T, Qn, Rn)
    return np.asarray(A @ P @ C.T @ np.linalg.inv(C @ P @ C.T + Rn))
