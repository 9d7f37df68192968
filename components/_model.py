"""The TWMR model of the paper in scalar arithmetic: `kernel_function`s, plain Python when called
from Python (numba not imported), compiled with numba when the compiled loop calls them.

Shared by the plant (eqs 1-8, 11) and the controllers (eqs 9-33). Everything is written with plain
floats — the 2x2 algebra spelled out — so one compiled call does a whole step.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from twmr.core.kernel import kernel_function


def inertia(a: float, I_G: float, I_D: float, I_W: float, r: float, b: float, m_W: float,
            m_G: float) -> tuple[float, float, float, float]:
    """(m11, m12, q1, q2) of eq. (8), exactly as printed (m11 with 2 m_W r^2)."""
    k = r * r / (4.0 * b * b)
    m11 = m_G * (r * r / 4.0 + a * a * r * r / (4.0 * b * b)) + k * (I_G + 2.0 * I_D) \
        + 2.0 * m_W * r * r + I_W  # eq. (8), m11
    m12 = m_G * (r * r / 4.0 - a * a * r * r / (4.0 * b * b)) - k * (I_G + 2.0 * I_D)  # m12
    q1 = m_G * r / 4.0 * (1.0 + a * a / (b * b)) + r / (4.0 * b) * (I_G + 2.0 * I_D)  # q1
    q2 = m_G * r / 4.0 * (1.0 - a * a / (b * b)) - r / (4.0 * b) * (I_G + 2.0 * I_D)  # q2
    return m11, m12, q1, q2


@kernel_function
def derivative(x: float, y: float, th: float, wR: float, wL: float,
               tR: float, tL: float, muR: float, muL: float, dl: float,
               muR2: float, muL2: float, dl2: float, tdR: float, tdL: float,
               m11: float, m12: float, q1: float, q2: float, m_G: float, a: float, r: float,
               b: float) -> tuple[float, float, float, float, float]:
    """State derivative (x_M', y_M', theta', phi_R'', phi_L'') of the plant.

    Inputs: wheel torques tR, tL [N.m]; slip rates muR, muL, dl = mu_R', mu_L', delta' [m/s];
    slip accelerations muR2, muL2, dl2 [m/s2]; disturbance tdR, tdL [N.m]."""
    beta = r * (wR + wL) / 2.0 + (muR + muL) / 2.0  # eq. (2)
    varpi = r * (wR - wL) / (2.0 * b) + (muR - muL) / (2.0 * b)  # eq. (3)
    c, s = math.cos(th), math.sin(th)
    dx = beta * c - dl * s  # eq. (11)
    dy = beta * s + dl * c
    bc = m_G * r * r / (2.0 * b) * varpi  # B = bc [[0, 1], [-1, 0]], eq. (8)
    cc = m_G * r / 2.0 * varpi  # C = cc [1, 1]
    gc = m_G * a * r / (2.0 * b)  # G = gc [1, -1]
    # eq. (8): M nu' = tau - B nu - Q mu'' - C delta' - G delta'' - tau_d
    fR = tR - bc * wL - (q1 * muR2 + q2 * muL2) - cc * dl - gc * dl2 - tdR
    fL = tL + bc * wR - (q2 * muR2 + q1 * muL2) - cc * dl + gc * dl2 - tdL
    det = m11 * m11 - m12 * m12
    return dx, dy, varpi, (m11 * fR - m12 * fL) / det, (m11 * fL - m12 * fR) / det


#: codes of the slip profiles (`SlipProfile.code`); HELD: none given, the plant holds its slip
#: inputs over each step
HELD, PAPER, NO_SLIP, CONSTANT, STEP, MUD = 0, 1, 2, 3, 4, 5
#: the slip profiles a kernel defines (`slip_at`; the plant evaluates them at its RK4 stages),
#: name -> code; the slip block's `random` profile is sampled in Python (its code: HELD)
PROFILES = {"paper": PAPER, "none": NO_SLIP, "constant": CONSTANT, "step": STEP, "mud": MUD}


class SlipProfile(NamedTuple):
    """A slip profile: the slip block's parameter table, its `model` output and the plant's
    `slip_model` input (these values in this order)."""

    code: float  #: PROFILES
    slip_gain: float
    disturbance_gain: float
    slip_R: float  #: slip value mu_R' [m/s] (constant, step, mud)
    slip_L: float  #: mu_L' [m/s]
    slip_delta: float  #: delta' [m/s]
    disturbance_R: float  #: tau_d [N.m] (constant, step, mud)
    disturbance_L: float
    step_time: float  #: [s]
    mud_x: float  #: mud patch centre [m]
    mud_y: float
    mud_radius: float  #: [m]
    phase: float  #: time shift of the paper profile [s]


#: length of a profile descriptor (`SlipProfile`)
DESCRIPTOR = len(SlipProfile._fields)


@kernel_function
def slip_at(p: tuple, t: float, x: float, y: float
            ) -> tuple[float, float, float, float, float, float, float, float]:
    """Slip rates [m/s], slip accelerations [m/s2] and disturbance [N.m] of profile `p` (a
    `SlipProfile`, or its values as a tuple) at time t [s] with M at (x, y) [m] (Sec. IV-A for
    `paper`); zero for HELD."""
    q = SlipProfile(*p)
    code, g, gd = q.code, q.slip_gain, q.disturbance_gain
    if code == PAPER:
        tp = t + q.phase
        c, s = math.cos(tp), math.sin(tp)
        return (g * (1.0 + c), g * (1.0 + s), g * c, -g * s, g * c, -g * s,
                gd * 2.0 * math.sin(3.0 * tp), gd * 2.0 * math.cos(3.0 * tp))
    # np.hypot: the C library's, as numba's and the C twin's (CPython's math.hypot rounds
    # differently)
    on = code == CONSTANT or (code == STEP and t >= q.step_time) or (
        code == MUD and np.hypot(x - q.mud_x, y - q.mud_y) <= q.mud_radius)
    if not on:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return (g * q.slip_R, g * q.slip_L, g * q.slip_delta, 0.0, 0.0, 0.0, gd * q.disturbance_R,
            gd * q.disturbance_L)


@kernel_function
def rk4(n: int, hs: float, t0: float, x: float, y: float, th: float, wR: float, wL: float,
        tR: float, tL: float, muR: float, muL: float, dl: float, muR2: float, muL2: float,
        dl2: float, tdR: float, tdL: float, p: tuple, m11: float, m12: float, q1: float,
        q2: float, m_G: float, a: float, r: float, b: float
        ) -> tuple[float, float, float, float, float, float, float]:
    """`n` classical RK4 steps of size `hs` [s] from t0 [s]; returns the new state and the centre
    of mass G (eq. 4 minus eq. 11: G = M + a (cos, sin)). Torques are held over the steps (the
    controller's zero-order hold); slip and disturbance too, unless `p` (a `SlipProfile`) gives
    their profile, which is then evaluated at every RK4 stage (its time and stage position)."""
    live = SlipProfile(*p).code != HELD
    for i in range(n):
        t = t0 + i * hs
        if live:
            muR, muL, dl, muR2, muL2, dl2, tdR, tdL = slip_at(p, t, x, y)
        k1 = derivative(x, y, th, wR, wL, tR, tL, muR, muL, dl, muR2, muL2, dl2, tdR, tdL,
                        m11, m12, q1, q2, m_G, a, r, b)
        x2, y2 = x + hs / 2 * k1[0], y + hs / 2 * k1[1]
        if live:
            muR, muL, dl, muR2, muL2, dl2, tdR, tdL = slip_at(p, t + hs / 2, x2, y2)
        k2 = derivative(x2, y2, th + hs / 2 * k1[2],
                        wR + hs / 2 * k1[3], wL + hs / 2 * k1[4], tR, tL, muR, muL, dl, muR2,
                        muL2, dl2, tdR, tdL, m11, m12, q1, q2, m_G, a, r, b)
        x3, y3 = x + hs / 2 * k2[0], y + hs / 2 * k2[1]
        if live:
            muR, muL, dl, muR2, muL2, dl2, tdR, tdL = slip_at(p, t + hs / 2, x3, y3)
        k3 = derivative(x3, y3, th + hs / 2 * k2[2],
                        wR + hs / 2 * k2[3], wL + hs / 2 * k2[4], tR, tL, muR, muL, dl, muR2,
                        muL2, dl2, tdR, tdL, m11, m12, q1, q2, m_G, a, r, b)
        x4, y4 = x + hs * k3[0], y + hs * k3[1]
        if live:
            muR, muL, dl, muR2, muL2, dl2, tdR, tdL = slip_at(p, t + hs, x4, y4)
        k4 = derivative(x4, y4, th + hs * k3[2], wR + hs * k3[3],
                        wL + hs * k3[4], tR, tL, muR, muL, dl, muR2, muL2, dl2, tdR, tdL,
                        m11, m12, q1, q2, m_G, a, r, b)
        x += hs / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        y += hs / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        th += hs / 6 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2])
        wR += hs / 6 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3])
        wL += hs / 6 * (k1[4] + 2 * k2[4] + 2 * k3[4] + k4[4])
    return x, y, th, wR, wL, x + a * math.cos(th), y + a * math.sin(th)


@kernel_function
def look_ahead_model(x: float, y: float, th: float, wR: float, wL: float, xT: float,
                     yT: float, vxT: float, vyT: float, m11: float, m12: float, m_G: float,
                     r: float, b: float, L: float, eps: float) -> tuple:
    """The error model of the look-ahead point that the tracking laws share (eqs 9-23):
    (e_p1, e_p2, x1 (2), x1' (2), Z = kappa M^-1 (z11, z12, z21, z22), E (E11, E12, E21, E22)),
    so that x1'' = Z tau + E x1' + (terms a law treats as disturbance).

    x1 is the error of a look-ahead point L [m] on the body axis (x1 = e_p - [L, 0]); kappa uses
    e_p of M (it is the same matrix for that point); |e_p1| in kappa is kept >= eps [m] with its
    sign. x1' is estimated without the unmeasured slip: kappa nu + R(theta) p_T' (eq. 15 with the
    slip terms of xi_1 dropped)."""
    c, s_ = math.cos(th), math.sin(th)
    ex, ey = xT - x, yT - y
    e1 = c * ex + s_ * ey  # eq. (9)
    e2 = -s_ * ex + c * ey
    # the clamp of |e_p1| at eps in kappa: with a large eps a standing part of the law, not a
    # guard of rare instants (docs/model.md, section 3)
    e1k = e1 if abs(e1) >= eps else (eps if e1 >= 0.0 else -eps)
    # eq. (15): kappa
    k11 = (e2 / b - 1.0) * r / 2.0
    k12 = -(e2 / b + 1.0) * r / 2.0
    k21 = -e1k * r / (2.0 * b)
    k22 = e1k * r / (2.0 * b)
    # x1 and x1' (eq. 16 without the slip part of xi_1)
    x11, x12 = e1 - L, e2
    d11 = k11 * wR + k12 * wL + c * vxT + s_ * vyT
    d12 = k21 * wR + k22 * wL - s_ * vxT + c * vyT
    # M^-1
    det_m = m11 * m11 - m12 * m12
    i11, i12 = m11 / det_m, -m12 / det_m
    # B (eq. 8) with varpi estimated without slip: omega = r (phi_R' - phi_L') / (2 b)
    bc = m_G * r * r / (2.0 * b) * (r * (wR - wL) / (2.0 * b))
    # Z = kappa M^-1 (eq. 21)
    z11 = k11 * i11 + k12 * i12
    z12 = k11 * i12 + k12 * i11
    z21 = k21 * i11 + k22 * i12
    z22 = k21 * i12 + k22 * i11
    # E1 = -kappa M^-1 B = -Z B, B = bc [[0, 1], [-1, 0]]
    e1_11, e1_12 = z12 * bc, -z11 * bc
    e1_21, e1_22 = z22 * bc, -z21 * bc
    # kappa^-1
    det_k = k11 * k22 - k12 * k21
    ki11, ki12, ki21, ki22 = k22 / det_k, -k12 / det_k, -k21 / det_k, k11 / det_k
    # E = E1 kappa^-1 (eq. 23)
    E11 = e1_11 * ki11 + e1_12 * ki21
    E12 = e1_11 * ki12 + e1_12 * ki22
    E21 = e1_21 * ki11 + e1_22 * ki21
    E22 = e1_21 * ki12 + e1_22 * ki22
    return (e1, e2, x11, x12, d11, d12, z11, z12, z21, z22, E11, E12, E21, E22)


@kernel_function
def torque_for(v1: float, v2: float, z11: float, z12: float, z21: float, z22: float
               ) -> tuple[float, float]:
    """tau = -Z^-1 v (eq. 32), Z^-1 = M kappa^-1: the wheel torques that give x1'' = -v plus
    the model's own terms."""
    det_z = z11 * z22 - z12 * z21
    tR = -(z22 * v1 - z12 * v2) / det_z
    tL = -(-z21 * v1 + z11 * v2) / det_z
    return tR, tL


@kernel_function
def tracking_law(x: float, y: float, th: float, wR: float, wL: float, xT: float, yT: float,
                 vxT: float, vyT: float, dR: float, dL: float,
                 m11: float, m12: float, m_G: float, r: float, b: float,
                 lam: float, vth: float, k: float, L: float, eps: float, phi: float
                 ) -> tuple[float, float, float, float, float, float]:
    """The sliding-mode law of eqs (9)-(32): (tau_R, tau_L, s_1, s_2, e_p1, e_p2), on the error
    model of the look-ahead point L (`look_ahead_model`, clamp eps); d_hat = (dR, dL) is the
    adaptive term (0 for plain SMC); phi > 0 replaces sgn(s) by sat(s / phi)."""
    (e1, e2, x11, x12, d11, d12, z11, z12, z21, z22, E11, E12, E21,
     E22) = look_ahead_model(x, y, th, wR, wL, xT, yT, vxT, vyT, m11, m12, m_G, r, b, L, eps)
    x21, x22 = d11 + lam * x11, d12 + lam * x12  # x2 = x1' + lambda x1
    s1, s2 = vth * x11 + x21, vth * x12 + x22  # eq. (25)
    # (vartheta I + E)(x2 - lambda x1) + d_hat + k sgn(s)
    w1, w2 = x21 - lam * x11, x22 - lam * x12
    if phi > 0.0:
        g1, g2 = min(1.0, max(-1.0, s1 / phi)), min(1.0, max(-1.0, s2 / phi))
    else:
        g1 = 1.0 if s1 > 0 else (-1.0 if s1 < 0 else 0.0)
        g2 = 1.0 if s2 > 0 else (-1.0 if s2 < 0 else 0.0)
    v1 = (vth + E11) * w1 + E12 * w2 + dR + k * g1
    v2 = E21 * w1 + (vth + E22) * w2 + dL + k * g2
    tR, tL = torque_for(v1, v2, z11, z12, z21, z22)
    return tR, tL, s1, s2, e1, e2
