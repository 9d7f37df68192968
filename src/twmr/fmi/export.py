"""Export a native component kind as an FMI 2.0 co-simulation FMU (pythonfmu), with units
(UnitDefinitions and `unit` attributes) and direct feedthrough (ModelStructure dependencies)
written into its modelDescription.xml after pythonfmu has built it."""
from __future__ import annotations

import json
import re
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError, FmuError
from twmr.core.units import BASES, parse_unit
from twmr.fmi.slave import element_names
from twmr.registry import lookup

SCRIPT = '''"""FMU of the twmr-cosim component kind {kind!r} (needs twmr-cosim in the running Python)."""
from twmr.fmi.slave import TwmrSlave


class {model}(TwmrSlave):
    KIND = {kind!r}
    PARAMETERS = {parameters}
'''


def model_name(kind: str) -> str:
    """'motor_driver' -> 'MotorDriver' (the FMU's modelIdentifier)."""
    return "".join(p.capitalize() for p in re.split(r"[^0-9A-Za-z]+", kind) if p) or "Model"


def export_component(kind: str, out_path: str | Path,
                     parameters: dict[str, Any] | None = None) -> Path:
    """Build `out_path` (.fmu) from the native kind with `parameters` applied; the path."""
    from pythonfmu import FmuBuilder

    try:
        cls = lookup(kind)
    except KeyError as err:
        raise CosimError(f"{err.args[0]}. Fix: `twmr components` lists the kinds.") from None
    comp = cls(kind)
    for key, value in (parameters or {}).items():
        try:
            comp.set_parameter(key, value)
        except (KeyError, ValueError, TypeError) as err:
            raise CosimError(f"export {kind}: parameter {key!r} = {value!r}: {err}. Fix: give "
                             f"a parameter of the kind with a fitting value.") from None
    out = Path(out_path).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    model = model_name(kind)
    with tempfile.TemporaryDirectory(prefix="twmr-export-") as tmp:
        script = Path(tmp) / f"{model}.py"
        script.write_text(SCRIPT.format(kind=kind, model=model,
                                        parameters=json.dumps(parameters or {})))
        sys.modules.pop(model, None)
        try:
            FmuBuilder.build_FMU(script, dest=out)
        except Exception as exc:  # noqa: BLE001 - pythonfmu raises plain exceptions
            raise FmuError(kind, None, f"pythonfmu could not build the FMU ({exc}).") from exc
        finally:
            sys.modules.pop(model, None)
    _annotate(out, comp)
    return out


def _annotate(fmu: Path, comp: Any) -> None:
    """Add units and feedthrough dependencies to the FMU's modelDescription.xml."""
    with zipfile.ZipFile(fmu) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    root = ET.fromstring(entries["modelDescription.xml"])
    names = element_names(comp)
    index = {fmi: i + 1 for i, (fmi, _, _) in enumerate(names)}
    units: dict[str, Any] = {}
    for sv, (fmi, var_name, i) in zip(root.find("ModelVariables"), names):
        var = comp.variables[var_name]
        unit = var.element_unit(i or 0)
        real = sv.find("Real")
        if real is not None and unit:
            real.set("unit", unit)
            units[unit] = parse_unit(unit)
    if units:
        defs = ET.Element("UnitDefinitions")
        for name, u in units.items():
            unit_el = ET.SubElement(defs, "Unit", name=name)
            base = {b: str(e) for b, e in zip(BASES, u.exponents) if e}
            if u.factor != 1.0:
                base["factor"] = repr(u.factor)
            if u.offset:
                base["offset"] = repr(u.offset)
            ET.SubElement(unit_el, "BaseUnit", base)
        pos = list(root).index(root.find("CoSimulation")) + 1
        root.insert(pos, defs)
    outputs = root.find("ModelStructure/Outputs")
    for unknown in outputs if outputs is not None else []:
        fmi, var_name, _ = names[int(unknown.get("index")) - 1]
        var = comp.variables[var_name]
        deps = [index[f] for f, v, _ in names if v in getattr(var, "depends_on", ())]
        unknown.set("dependencies", " ".join(str(d) for d in sorted(deps)))
    if outputs is not None and root.find("ModelStructure/InitialUnknowns") is None:
        initial = ET.SubElement(root.find("ModelStructure"), "InitialUnknowns")
        for unknown in outputs:  # states (initial="exact") are known, not initial unknowns
            if comp.variables[names[int(unknown.get("index")) - 1][1]].kind == "output":
                ET.SubElement(initial, "Unknown", index=unknown.get("index"))
    entries["modelDescription.xml"] = ET.tostring(root, encoding="utf-8", xml_declaration=True)
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in entries.items():
            z.writestr(name, data)
