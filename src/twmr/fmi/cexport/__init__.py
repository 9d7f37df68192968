"""Standalone C FMUs (FMI 2.0 / 3.0 co-simulation) of any block that declares a C twin
(its class's `c_twin`, see `twin`): the FMI wrapper here (c/), the block's C file from beside the
block, a binary compiled here with the system C compiler, no Python at run time. `export_c_fmu`
is what `twmr export KIND --fmi 2|3` calls; docs/export.md explains the design (C twins held
equal to the blocks' kernels by tests/property/test_block_forms.py)."""
from __future__ import annotations

import os
import platform
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path
from typing import Any

from twmr.core.errors import CosimError
from twmr.fmi.cexport import busnode
from twmr.fmi.cexport.describe import (
    config_h,
    elements,
    guid_of,
    model_description,
    model_identifier,
)
from twmr.fmi.cexport.twin import CTwin, twin_of, twins
from twmr.registry import lookup

#: the FMI wrapper's sources (every FMU has them) and the FMI headers
C_DIR = Path(__file__).parent / "c"
#: compiler flags: no contraction into fused multiply-adds, no fast-math, so results follow the
#: same IEEE operations as the numba kernels
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-fPIC", "-fvisibility=hidden")
COMMON = ("kernel.h", "instance.h", "instance.c")
HEADERS = {2: ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"),
           3: ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")}

__all__ = ["C_DIR", "CTwin", "export_c_fmu", "twin_of", "twins", "write_c_fmu"]


def _platform(fmi: int) -> tuple[str, str]:
    """(binaries folder, shared library suffix) of this machine for FMI `fmi`."""
    import fmpy
    from fmpy.fmi3 import platform_tuple

    suffix = {"Windows": ".dll", "Darwin": ".dylib"}.get(platform.system(), ".so")
    return (fmpy.platform if fmi == 2 else platform_tuple), suffix


def _component(kind: str, parameters: dict[str, Any]) -> Any:
    try:
        cls = lookup(kind)
    except KeyError as err:
        raise CosimError(f"{err.args[0]}. Fix: `twmr components` lists the kinds.") from None
    twin_of(kind)
    comp = cls(kind)
    for key, value in sorted(parameters.items(), key=lambda kv: kv[0] not in
                             comp.sizing_parameters):
        if key not in comp.parameters:
            raise CosimError(f"export {kind}: {key!r} is not a parameter of the kind (it has "
                             f"{', '.join(comp.parameters)}). Fix: `twmr components` lists "
                             f"each kind's parameters.")
        try:
            comp.set_parameter(key, value)
        except (KeyError, ValueError, TypeError) as err:
            raise CosimError(f"export {kind}: parameter {key!r} = {value!r}: {err}. Fix: give "
                             f"a value that fits the parameter.") from None
    return comp


def export_c_fmu(kind: str, out_path: str | Path, parameters: dict[str, Any] | None = None,
                 fmi: int = 2, can: str | None = None) -> Path:
    """Build `out_path` (.fmu): a standalone FMI `fmi` (2 or 3) co-simulation FMU of the native
    kind `kind`, the `parameters` given as start values; returns the path. With `can` (a CAN
    protocol: odrive, cia402; FMI 3.0 only) the FMU is an FMI-LS-BUS CAN node that hosts that
    protocol's drives (`busnode`); the node's parameters are given as `drive.<name>`."""
    if fmi not in (2, 3):
        raise CosimError(f"FMI version {fmi!r} is not exported. Fix: use --fmi 2 or --fmi 3.")
    parameters = dict(parameters or {})
    if can is None:
        return write_c_fmu(_component(kind, parameters), kind, out_path, fmi)
    if fmi != 3:
        raise CosimError(f"--can {can}: an FMI-LS-BUS bus node is an FMI 3.0 FMU (clocks, "
                         f"event mode). Fix: add --fmi 3.")
    bus, own = busnode.bus_of(can, parameters)
    return write_c_fmu(_component(kind, own), kind, out_path, fmi, bus)


def write_c_fmu(comp: Any, kind: str, out_path: str | Path, fmi: int = 2,
                bus: busnode.Bus | None = None) -> Path:
    """Build `out_path` (.fmu) of the configured component `comp` of the native kind `kind`
    (its parameters, initial states and input start values as the FMU's start values); the
    path. `bus`: the CAN node of a bus node FMU (`busnode`). CosimError for a variant the
    kind's C twin does not support."""
    twin = twin_of(kind)
    options = twin.options(comp)  # refuses unsupported variants before anything is written
    twin.fill_empty(comp)
    elems = elements(comp, twin)
    extra: dict[str, int | str] = {}
    files: list[Path] = [twin.source, *twin.headers]
    sources = ["instance.c", f"fmi{fmi}.c", twin.source.name]
    common = [*COMMON, *HEADERS[fmi], f"fmi{fmi}.c"]
    if bus is not None:
        elems, extra = busnode.bus_elements(comp, kind, elems, bus)
        node = bus.node
        files += [node.source, *node.codec]
        common += [*busnode.LSBUS_HEADERS, *busnode.LSBUS_SOURCES]
        sources += [*busnode.LSBUS_SOURCES, node.source.name,
                    *(p.name for p in node.codec if p.suffix == ".c")]
    guid = guid_of(kind, elems, {**options, **extra})
    identifier = model_identifier(kind)
    from twmr import __version__

    out = Path(out_path).resolve()
    with tempfile.TemporaryDirectory(prefix="twmr-cexport-") as tmp:
        root = Path(tmp)
        src = root / "sources"
        src.mkdir()
        for name in common:
            shutil.copy(C_DIR / name, src / name)
        for path in files:
            shutil.copy(path, src / path.name)
        (src / "config.h").write_text(config_h(comp, twin, elems, guid, extra))
        if fmi == 3:
            (src / "buildDescription.xml").write_text(_build_description(identifier, sources))
        description = model_description(comp, twin, elems, guid, fmi, sources, __version__)
        if bus is not None:
            description = busnode.with_terminal(description, bus.protocol, len(elems))
            for inside, text in busnode.EXTRA_FILES.items():
                (root / inside).parent.mkdir(parents=True, exist_ok=True)
                (root / inside).write_text(text())
        (root / "modelDescription.xml").write_bytes(description)
        folder, suffix = _platform(fmi)
        binary = root / "binaries" / folder / f"{identifier}{suffix}"
        binary.parent.mkdir(parents=True)
        _compile([src / s for s in sources], src, binary)
        out.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
            for path in sorted(root.rglob("*")):
                if path.is_file():
                    z.write(path, path.relative_to(root).as_posix())
    return out


def _build_description(identifier: str, sources: list[str]) -> str:
    files = "\n".join(f'      <SourceFile name="{s}"/>' for s in sources)
    return (f'<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
            f'  <BuildConfiguration modelIdentifier="{identifier}">\n'
            f'    <SourceFileSet language="C99">\n{files}\n    </SourceFileSet>\n'
            f'  </BuildConfiguration>\n</fmiBuildDescription>\n')


def _compile(sources: list[Path], include: Path, binary: Path) -> None:
    """The shared library from `sources` with the C compiler $CC (default cc)."""
    cc = os.environ.get("CC", "cc")
    if shutil.which(cc) is None:
        raise CosimError(f"no C compiler: '{cc}' is not on the PATH. Fix: install one (e.g. "
                         f"`apt install gcc`) or set CC to its path; or export with --python.")
    cmd = [cc, *CFLAGS, "-shared", f"-I{include}", *map(str, sources), "-o", str(binary), "-lm"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        tail = "\n".join((done.stderr or done.stdout).strip().splitlines()[-8:])
        raise CosimError(f"compiling the FMU failed ({cc} exited with {done.returncode}):\n"
                         f"{tail}\nFix: check the compiler works (`{cc} --version`); report "
                         f"this as a bug of the C export.")
