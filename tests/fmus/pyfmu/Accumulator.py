"""A plain pythonfmu model (not a twmr component): x' = k u, y = x, explicit in each step."""
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real


class Accumulator(Fmi2Slave):
    author = "twmr-cosim tests"
    description = "y(t + h) = y(t) + k u h"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.k = 2.0
        self.u = 0.0
        self.y = 0.0
        self.register_variable(Real("k", causality=Fmi2Causality.parameter,
                                    variability=Fmi2Variability.tunable))
        self.register_variable(Real("u", causality=Fmi2Causality.input))
        self.register_variable(Real("y", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.y += self.k * self.u * step_size
        return True
