"""Engine core: ports, components, units, errors."""
from twmr.core.component import Component
from twmr.core.errors import (
    AlgebraicLoopError,
    ComponentError,
    CosimError,
    FmuError,
    HardwareError,
    Location,
    Problem,
    ScenarioError,
    UnitError,
    WiringError,
)
from twmr.core.port import BOOLEAN, INTEGER, REAL, STRING, Input, Output, Parameter, State, Variable

__all__ = [
    "BOOLEAN",
    "INTEGER",
    "REAL",
    "STRING",
    "AlgebraicLoopError",
    "Component",
    "ComponentError",
    "CosimError",
    "FmuError",
    "HardwareError",
    "Input",
    "Location",
    "Output",
    "Parameter",
    "Problem",
    "ScenarioError",
    "State",
    "UnitError",
    "Variable",
    "WiringError",
]
