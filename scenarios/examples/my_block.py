"""A block of your own: a pose sensor with bounded, reproducible noise (docs/components.md).

Used by noisy_sensor.yaml as `kind: "my_block.py:NoisySensor"`.
"""
from numba import njit

from twmr import Component, Input, Kernel, Output, Parameter

#: the linear congruential generator of the noise: s <- (A s + C) mod M
A, C, M = 1103515245, 12345, 2**31


@njit(cache=True)
def sensor_evaluate(t, x, y, u, p):
    """measured = truth + the noise held over this step; x = (generator state, noise)."""
    truth, noise = u[0], x[1]
    return x, ((truth[0] + noise[0], truth[1] + noise[1], truth[2] + noise[2]),)


@njit(cache=True)
def sensor_step(t, h, x, y, u, p):
    """Draw the noise of the next step, uniform in [-p[i], p[i]]; p = the noise amplitudes."""
    s1 = (A * int(x[0]) + C) % M
    s2 = (A * s1 + C) % M
    s3 = (A * s2 + C) % M
    noise = (p[0] * (2.0 * s1 / M - 1.0), p[1] * (2.0 * s2 / M - 1.0),
             p[2] * (2.0 * s3 / M - 1.0))
    return (float(s3), noise), y


class NoisySensor(Component):
    """Measures a pose (x, y, heading) with uniform noise, drawn anew every step."""

    truth = Input(size=3, unit=("m", "m", "rad"), description="the true pose")
    measured = Output(size=3, unit=("m", "m", "rad"), depends_on=("truth",),
                      description="truth + noise")
    noise = Parameter((0.002, 0.002, 0.01), size=3, unit=("m", "m", "rad"), min=0.0,
                      description="half-width of the uniform noise on x, y, heading")
    seed = Parameter(1, type="Integer", min=0, max=M - 1, description="generator seed")

    def initialize(self) -> None:
        self._x = (float(self.seed), (0.0, 0.0, 0.0))
        self._x, _ = sensor_step.py_func(self.start_time, 0.0, self._x, (self.measured,),
                                         (self.truth,), self.noise)
        self.evaluate(self.start_time)

    def evaluate(self, t: float) -> None:
        self._x, (self.measured,) = sensor_evaluate.py_func(t, self._x, (self.measured,),
                                                            (self.truth,), self.noise)

    def do_step(self, t: float, h: float) -> None:
        self._x, (self.measured,) = sensor_step.py_func(t, h, self._x, (self.measured,),
                                                        (self.truth,), self.noise)

    def kernel(self, h: float) -> Kernel:
        """The compiled form: the same two functions, compiled by numba."""
        return Kernel(params=self.noise, state=self._x, evaluate=sensor_evaluate,
                      step=sensor_step)
