"""Export a component as an FMI 2.0 co-simulation FMU that runs its Python code (the Python
route: pythonfmu's slave API, and a binary of ours compiled here).

pythonfmu builds the FMU's resources and modelDescription.xml; its prebuilt binary is replaced
by `pyfmu_wrapper/pyslave.c` compiled with this machine's C compiler (pythonfmu 0.6.4 to 0.7.0
release, on every fmi2Instantiate, a reference to the slave module's dict that they do not own,
which corrupts the host's heap). Units (UnitDefinitions, `unit` attributes) and direct feedthrough
(ModelStructure dependencies) are then written into modelDescription.xml. The FMU runs inside a
Python host with twmr-cosim installed; a host without it gets a clear message in its log.
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path
from typing import Any

from twmr.core.component import Component
from twmr.core.errors import CosimError, FmuError
from twmr.core.units import parse_unit
from twmr.fmi.cexport.describe import unit_definitions
from twmr.fmi.slave import element_names
from twmr.registry import lookup

WRAPPER = Path(__file__).resolve().parent / "pyfmu_wrapper" / "pyslave.c"

SCRIPT = '''"""FMU of the twmr-cosim component {what} (needs twmr-cosim in the running Python)."""
from twmr.fmi.slave import TwmrSlave
{imports}

class {model}(TwmrSlave):
    KIND = {kind!r}
    COMPONENT = {component}
    PARAMETERS = {parameters}
'''


def model_name(kind: str) -> str:
    """'motor_driver' -> 'MotorDriver' (the FMU's modelIdentifier)."""
    return "".join(p[:1].upper() + p[1:] for p in re.split(r"[^0-9A-Za-z]+", kind) if p) \
        or "Model"


def _user_class(spec: str | type) -> type:
    """The component class of a class object, 'module:Class' or 'path/file.py:Class'."""
    if isinstance(spec, type):
        cls = spec
    else:
        module, _, name = spec.rpartition(":")
        try:
            if module.endswith(".py"):
                path = Path(module).resolve()
                mod_name = path.stem
                if mod_name not in sys.modules or \
                        Path(getattr(sys.modules[mod_name], "__file__", "") or "") != path:
                    loader_spec = importlib.util.spec_from_file_location(mod_name, path)
                    if loader_spec is None or not path.is_file():
                        raise FileNotFoundError(f"no file {path}")
                    mod = importlib.util.module_from_spec(loader_spec)
                    sys.modules[mod_name] = mod
                    loader_spec.loader.exec_module(mod)  # type: ignore[union-attr]
                mod = sys.modules[mod_name]
            else:
                mod = _import_here(module)
            cls = getattr(mod, name)
        except (ImportError, OSError, AttributeError, SyntaxError) as err:
            if isinstance(err, FileNotFoundError):
                why = f"there is no file {Path(module).resolve()}"
            elif isinstance(err, ModuleNotFoundError):
                why = f"no module '{err.name}' can be imported here"
            elif isinstance(err, AttributeError):
                why = f"'{module}' has no '{name}'"
            elif isinstance(err, SyntaxError):
                why = f"{err.filename}, line {err.lineno}: {err.msg}"
            else:
                why = str(err)
            raise CosimError(f"export {spec}: cannot load the class ({why}). Fix: give "
                             f"'module:Class' for an importable module or "
                             f"'path/to/file.py:Class'.") from None
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise CosimError(f"export {spec!r}: {cls!r} is not a twmr Component class. Fix: export "
                         f"a subclass of twmr.core.component.Component (see "
                         f"docs/export_python.md).")
    if cls.__module__ == "__main__":
        raise CosimError(f"export {cls.__name__}: the class is defined in the running script "
                         f"(__main__), which the FMU cannot import. Fix: put it in a module of "
                         f"its own and export 'module:{cls.__name__}'.")
    return cls


def _import_here(module: str) -> Any:
    """Module `module`, imported as ``python -m`` would from the working folder (which the
    `twmr` command's own path does not hold)."""
    here = os.getcwd()
    added = here not in sys.path and "" not in sys.path
    if added:
        sys.path.insert(0, here)
    try:
        return importlib.import_module(module)
    finally:
        if added and here in sys.path:
            sys.path.remove(here)


def _shipped_module(cls: type) -> Path | None:
    """The file of a top-level single-file module to ship in the FMU; None for a package's
    module or an installed one (the FMU's Python imports those)."""
    mod = sys.modules.get(cls.__module__)
    file = getattr(mod, "__file__", None)
    if "." in cls.__module__ or not file or Path(file).name == "__init__.py":
        return None
    paths = {sysconfig.get_paths()[k] for k in ("purelib", "platlib", "stdlib")}
    return None if any(Path(file).is_relative_to(p) for p in paths) else Path(file)


def export_component(kind: str | type, out_path: str | Path,
                     parameters: dict[str, Any] | None = None) -> Path:
    """Build `out_path` (.fmu) from a registered kind, a Component class, 'module:Class' or
    'path/file.py:Class', with `parameters` applied; the path."""
    if isinstance(kind, str) and ":" not in kind:
        try:
            cls = lookup(kind)
        except KeyError as err:
            raise CosimError(f"{err.args[0]}. Fix: `twmr components` lists the kinds; a class "
                             f"of your own is exported as 'module:Class'.") from None
        label, model, component, imports, files = kind, model_name(kind), "None", "", []
    else:
        cls = _user_class(kind)
        label, model = f"{cls.__module__}:{cls.__qualname__}", model_name(cls.__name__)
        component = cls.__name__
        imports = f"from {cls.__module__} import {cls.__name__}"
        shipped = _shipped_module(cls)
        files = [shipped] if shipped else []
    comp = cls(model)
    for key, value in (parameters or {}).items():
        try:
            comp.set_parameter(key, value)
        except (KeyError, ValueError, TypeError) as err:
            raise CosimError(f"export {label}: parameter {key!r} = {value!r}: {err}. Fix: give "
                             f"a parameter of the component with a fitting value.") from None
    binary = wrapper_binary()
    out = Path(out_path).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    from pythonfmu import FmuBuilder

    with tempfile.TemporaryDirectory(prefix="twmr-export-") as tmp:
        script = Path(tmp) / f"{model}.py"
        script.write_text(SCRIPT.format(
            what=label, model=model, kind=label if component == "None" else "",
            component=component, imports=imports, parameters=json.dumps(parameters or {})))
        sys.modules.pop(model, None)
        try:
            FmuBuilder.build_FMU(script, dest=out, project_files=files)
        except Exception as exc:  # noqa: BLE001 - pythonfmu raises plain exceptions
            raise FmuError(label, None, f"pythonfmu could not build the FMU ({exc}).") from exc
        finally:
            sys.modules.pop(model, None)
    _finish(out, comp, model, binary)
    return out


@functools.lru_cache(maxsize=1)
def wrapper_binary() -> tuple[str, bytes]:
    """(platform folder, shared library) of `pyslave.c` compiled for this machine, once per
    process; CosimError when it cannot be compiled here."""
    import fmpy

    if fmpy.platform not in ("linux64", "darwin64"):
        raise CosimError(f"export: the Python route compiles its FMU binary with a C compiler on "
                         f"Linux or macOS; this is {fmpy.platform}. Fix: export on Linux or "
                         f"macOS, or use the C export (twmr export KIND).")
    cc = os.environ.get("CC") or "cc"
    include = Path(sysconfig.get_paths()["include"])
    fmi_headers = Path(fmpy.__file__).parent / "c-code"
    if not shutil.which(cc):
        raise CosimError(f"export: the Python route compiles a small C binary for the FMU and "
                         f"needs a C compiler ({cc!r} was not found). Fix: install one (e.g. "
                         f"apt-get install gcc) or set CC.")
    if not (include / "Python.h").is_file():
        raise CosimError(f"export: the Python route compiles a small C binary for the FMU and "
                         f"needs Python's C headers ({include / 'Python.h'} is missing). Fix: "
                         f"install them (e.g. apt-get install python3-dev).")
    flags = ["-undefined", "dynamic_lookup"] if fmpy.platform == "darwin64" else []
    with tempfile.TemporaryDirectory(prefix="twmr-pyslave-") as tmp:
        lib = Path(tmp) / f"pyslave{fmpy.sharedLibraryExtension}"
        cmd = [cc, "-shared", "-fPIC", "-O2", "-fvisibility=hidden", f"-I{include}",
               f"-I{fmi_headers}", str(WRAPPER), "-o", str(lib), *flags]
        done = subprocess.run(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            raise CosimError(f"export: compiling the FMU's binary failed ({' '.join(cmd)}): "
                             f"{done.stderr.strip()[-800:]}. Fix: check the C compiler.")
        return fmpy.platform, lib.read_bytes()


#: Python's words for the numbers that are not finite -> xs:double's (what the FMI schema takes)
_XSD_DOUBLE = {"inf": "INF", "-inf": "-INF", "nan": "NaN"}


def _finish(fmu: Path, comp: Any, model: str, binary: tuple[str, bytes]) -> None:
    """Put our binary in place of pythonfmu's ones (and drop its embedded copy: the FMU uses the
    host's pythonfmu, pinned by twmr-cosim); name the slave class; write units and feedthrough
    dependencies into modelDescription.xml."""
    from pythonfmu import __version__ as pythonfmu_version

    from twmr import __version__

    with zipfile.ZipFile(fmu) as z:
        entries = {n: z.read(n) for n in z.namelist()
                   if not n.startswith(("binaries/", "resources/pythonfmu/"))}
    platform, library = binary
    suffix = {"linux64": ".so", "darwin64": ".dylib"}[platform]
    entries[f"binaries/{platform}/{model}{suffix}"] = library
    entries["resources/slaveclass.txt"] = model.encode()
    root = ET.fromstring(entries["modelDescription.xml"])
    root.set("generationTool", f"twmr-cosim {__version__} (Python route: pythonfmu "
                               f"{pythonfmu_version} slave API, twmr's FMI binary)")
    names = element_names(comp)
    index = {fmi: i + 1 for i, (fmi, _, _) in enumerate(names)}
    units: dict[str, Any] = {}
    variables = root.find("ModelVariables")
    assert variables is not None  # written by our own wrapper above
    for sv, (_fmi, var_name, i) in zip(variables, names, strict=False):
        var = comp.variables[var_name]
        unit = var.element_unit(i or 0)
        real = sv.find("Real")
        if real is not None and real.get("start") in _XSD_DOUBLE:  # Python's 'inf', 'nan'
            real.set("start", _XSD_DOUBLE[real.get("start", "")])
        if real is not None and unit:
            real.set("unit", unit)
            units[unit] = parse_unit(unit)
    if units:
        pos = next(i for i, e in enumerate(root) if e.tag == "CoSimulation") + 1
        root.insert(pos, unit_definitions(units))
    structure = root.find("ModelStructure")
    outputs = root.find("ModelStructure/Outputs")
    for unknown in outputs if outputs is not None else []:
        _fmi, var_name, _ = names[int(unknown.get("index", "0")) - 1]
        var = comp.variables[var_name]
        deps = [index[f] for f, v, _ in names if v in getattr(var, "depends_on", ())]
        unknown.set("dependencies", " ".join(str(d) for d in sorted(deps)))
    if outputs is not None and structure is not None and \
            root.find("ModelStructure/InitialUnknowns") is None:
        initial = ET.SubElement(structure, "InitialUnknowns")
        for unknown in outputs:  # states (initial="exact") are known, not initial unknowns
            index_text = unknown.get("index", "0")
            if comp.variables[names[int(index_text) - 1][1]].kind == "output":
                ET.SubElement(initial, "Unknown", index=index_text)
    entries["modelDescription.xml"] = ET.tostring(root, encoding="utf-8", xml_declaration=True)
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as z:
        for name, data in entries.items():
            z.writestr(name, data)
