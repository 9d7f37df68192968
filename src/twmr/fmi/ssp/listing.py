"""`twmr inspect X.ssp`: what the SSP was read as, component by component."""
from __future__ import annotations

from pathlib import Path

from twmr.fmi.ssp.flatten import MAP_KIND
from twmr.scenario.structure import ScenarioSpec


def describe_ssp(spec: ScenarioSpec) -> str:
    """Each FMU component with its file and the values bound to it (and where), each
    transformation put on a wire, then the wires and the inputs left at their start values."""
    lines = [f"SSP {spec.source}", "components:"]
    for name, comp in spec.components.items():
        values = {**comp.parameters, **comp.initial}
        if comp.kind.value == MAP_KIND:
            p = {k: v.value for k, v in values.items()}
            what = f"table {p['table']}" if p["table"] else \
                f"y = {p['factor']:g} * u + {p['offset']:g}"
            lines.append(f"  {name}: transformation ({p['in_type']} -> {p['out_type']}), "
                         f"{what}  [{comp.where}]")
            continue
        lines.append(f"  {name}: FMU {Path(str(values.pop('path').value)).name}  "
                     f"[{comp.where}]")
        for key, given in values.items():
            lines.append(f"      {key} = {given.value!r}  ({given.where})")
    lines.append("connections:")
    lines += [f"  {c.value}" for c in spec.connections]
    if spec.open:
        lines.append("inputs at their start values: " + ", ".join(o.value for o in spec.open))
    return "\n".join(lines)
