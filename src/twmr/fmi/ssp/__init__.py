"""SSP (System Structure and Parameterization, Modelica Association; 1.0 and 2.0) import and
export (`twmr.fmi.ssp.write.export_ssp`: a scenario as an .ssp of FMUs).

`load_ssp(path)` reads an `.ssp` archive, an unpacked folder (holding `SystemStructure.ssd`) or
one `.ssd` file into the flat `ScenarioSpec` every loader produces: FMU components (nested
systems flattened into dotted names `sub.comp`), connections with their transformations,
parameter bindings (`.ssv`, `.ssm`, inline), units and the `DefaultExperiment`. Modules:
`xmlsafe` (hostile XML), `schema` (the standard's XSDs), `archive` (safe extraction),
`params` (parameter sets and mappings), `transform` (the component a transformation puts on a
wire), `read` (the system structure), `flatten` (its FMUs and wires), `listing`
(`twmr inspect`)."""
from __future__ import annotations

from twmr.fmi.ssp.read import load_ssp

__all__ = ["load_ssp"]
