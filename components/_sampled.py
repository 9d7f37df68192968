"""What the sampled sensors (encoder, imu) share: when a sample is due. Its C twin is
c/sampled.h."""
from __future__ import annotations

from twmr.core.kernel import kernel_function

#: a sample is due this fraction of a period early (the rounding of t = start + k h)
EARLY = 1e-9


@kernel_function
def sample_due(t: float, t_last: float, period: float) -> bool:
    """Whether a sensor that last sampled at t_last [s] samples at t [s]: a time has passed
    since, and at least `period` [s] (0: every communication point)."""
    dt = t - t_last
    return dt > 0.0 and dt >= period * (1.0 - EARLY)
