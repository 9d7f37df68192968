"""Engine core: ports, components, units, errors."""
from twmr.core.component import Component
from twmr.core.errors import (
    AlgebraicLoopError, ComponentError, CosimError, FmuError, HardwareError, Location, Problem,
    ScenarioError, UnitError, WiringError,
)
from twmr.core.port import BOOLEAN, INTEGER, REAL, STRING, Input, Output, Parameter, State, Variable

__all__ = [
    "Component", "Input", "Output", "Parameter", "State", "Variable", "REAL", "INTEGER", "BOOLEAN", "STRING",
    "CosimError", "ScenarioError", "WiringError", "AlgebraicLoopError", "ComponentError", "FmuError",
    "HardwareError", "UnitError", "Location", "Problem",
]
