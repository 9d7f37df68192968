"""The plain sliding-mode controller the paper compares against (its ref. [53] is not given).

What it is here: the same sliding surface s = vartheta x1 + x2 (eq. 25), the same equivalent
control and switching term as eq. (32), with the adaptive term removed (d_hat = 0) — i.e. the
ASMC with eta = 0, and the same look-ahead/clamp remedy. Its defaults are the shared gains of
`_tracking`; a scenario that gives the ASMC other shared gains (lambda, vartheta, k, phi, the
clamp, the look-ahead) compares more than the adaptation.
"""
from __future__ import annotations

from twmr.components._tracking import TrackingController
from twmr.components.ctwins import DRIVES, GAINS, INERTIA, LOOK_AHEAD, TRACKING
from twmr.components.ctwins import C as TWINS
from twmr.core.ctwin import CTwin


class SmcController(TrackingController):
    """Sliding-mode controller without adaptation: eq. (32) with d_hat = 0."""

    kind = "smc"


# -- C twin (`twmr export KIND`: a standalone C FMU from c/) ---------------------------------------
SmcController.c_twin = CTwin(TWINS / "tracking.c", headers=(INERTIA, LOOK_AHEAD),
                             tunable=frozenset(GAINS), choices=TRACKING, defines=DRIVES,
                             work=lambda comp: 4)
