"""Build the test FMUs from their C sources (tests/fmus/) at test time, into a given folder."""
from __future__ import annotations

import hashlib
import os
import platform
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCES = Path(__file__).parent / "fmus"


def fmi_platform() -> str:
    """fmpy's platform folder name for binaries (e.g. linux64)."""
    return fmpy.platform


def build_c_fmu(name: str, out_dir: Path, fmi3: bool = False) -> Path:
    """Compile tests/fmus/<name>/<name>.c into a shared library and zip the FMU (FMI 3.0 binary
    folders are platform tuples such as x86_64-linux)."""
    from fmpy.fmi3 import platform_tuple

    src = SOURCES / name
    headers = Path(fmpy.__file__).parent / "c-code"
    work = out_dir / f"{name}_build"
    binaries = work / "binaries" / (platform_tuple if fmi3 else fmi_platform())
    binaries.mkdir(parents=True, exist_ok=True)
    ext = {"Windows": ".dll", "Darwin": ".dylib"}.get(platform.system(), ".so")
    cc = os.environ.get("CC", "cc")
    sources = [str(src / f"{name}.c")]
    if fmi3:  # fmpy binds every FMI 3.0 function at load: the unused ones return fmi3Error
        sources.append(str(_fmi3_stubs([src / f"{name}.c"], headers, work)))
    subprocess.run([cc, "-shared", "-fPIC", "-O2", f"-I{headers}", *sources,
                    "-o", str(binaries / f"{name}{ext}"), "-lm"], check=True)
    shutil.copy(src / "modelDescription.xml", work / "modelDescription.xml")
    fmu = out_dir / f"{name}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for path in work.rglob("*"):
            if path.is_file():
                z.write(path, path.relative_to(work).as_posix())
    return fmu


def _fmi3_stubs(sources: list[Path], headers: Path, work: Path) -> Path:
    """A C file defining every FMI 3.0 function the model sources do not, each returning
    fmi3Error (3); compiled without the FMI headers, so no prototypes clash."""
    declared = re.findall(r"FMI3_Export\s+fmi3\w+TYPE\s+(fmi3\w+)\s*;",
                          (headers / "fmi3Functions.h").read_text())
    defined = {f for source in sources for f in re.findall(r"\b(fmi3\w+)\s*\(", source.read_text())}
    stubs = work / "fmi3_stubs.c"
    stubs.write_text("".join(f"int {f}(void) {{ return 3; }}\n" for f in declared
                             if f not in defined))
    return stubs


LSBUS = SOURCES / "lsbus"


LSBUS_PLACES = {"modelDescription.xml": "modelDescription.xml",
                "terminalsAndIcons.xml": "terminalsAndIcons/terminalsAndIcons.xml",
                "fmi-ls-manifest.xml": "extra/org.fmi-standard.fmi-ls-bus/fmi-ls-manifest.xml"}


def build_lsbus_fmu(name: str, out_dir: Path, edits: dict[str, str] | None = None) -> Path:
    """Build an LS-BUS CAN node of tests/fmus/lsbus/ (`cannode_triggered`, `cannode_countdown`,
    `cannode_periodic`: one source `cannode.c`, -DCOUNTDOWN for the two whose Tx clock is an
    input clock) or the bus simulation `canbus` (`canbus.c`), with its
    terminalsAndIcons.xml and LS-BUS manifest; `edits` replaces text in its XML files (a test's
    broken variant: another MIME type, another version)."""
    source = LSBUS / ("canbus.c" if name == "canbus" else "cannode.c")
    defines = [] if name in ("canbus", "cannode_triggered") else ["-DCOUNTDOWN"]
    tag = name if not edits else \
        f"{name}_{hashlib.sha1(repr(sorted(edits.items())).encode()).hexdigest()[:8]}"
    return _pack_lsbus_fmu(name, tag, [source], [], defines, LSBUS / name, out_dir, edits)


def build_lsbus_example(example: Path, ls_bus_headers: Path, out_dir: Path) -> Path:
    """Build a published FMI-LS-BUS example (a folder of modelica/fmi-ls-bus-examples, as its
    PackFmu.py lays it out: src/*.c and headers, description/ with modelDescription.xml,
    terminalsAndIcons.xml and fmi-ls-manifest.xml) with the LS-BUS headers of
    `ls_bus_headers`; the shared library is named after the modelIdentifier."""
    text = (example / "description" / "modelDescription.xml").read_text()
    found = re.search(r'modelIdentifier="([^"]+)"', text)
    if found is None:
        raise ValueError(f"{example}: modelDescription.xml names no modelIdentifier")
    sources = sorted((example / "src").glob("*.c"))
    return _pack_lsbus_fmu(found.group(1), example.name, sources,
                           [example / "src", ls_bus_headers], [], example / "description",
                           out_dir, None)


def _pack_lsbus_fmu(model: str, tag: str, sources: list[Path], includes: list[Path],
                    defines: list[str], descriptions: Path, out_dir: Path,
                    edits: dict[str, str] | None) -> Path:
    """Compile `sources` (plus stubs for the FMI 3.0 functions they leave out) into
    binaries/<platform>/<model>.so and zip it with the three description files of
    `descriptions` (each with `edits` applied) into <out_dir>/<tag>.fmu."""
    from fmpy.fmi3 import platform_tuple

    headers = Path(fmpy.__file__).parent / "c-code"
    work = out_dir / f"{tag}_build"
    binaries = work / "binaries" / platform_tuple
    binaries.mkdir(parents=True, exist_ok=True)
    ext = {"Windows": ".dll", "Darwin": ".dylib"}.get(platform.system(), ".so")
    subprocess.run([os.environ.get("CC", "cc"), "-shared", "-fPIC", "-O2", f"-I{headers}",
                    *(f"-I{d}" for d in includes), *defines, *map(str, sources),
                    str(_fmi3_stubs(sources, headers, work)),
                    "-o", str(binaries / f"{model}{ext}"), "-lm"], check=True)
    fmu = out_dir / f"{tag}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for path in work.rglob("*"):
            if path.is_file():
                z.write(path, path.relative_to(work).as_posix())
        for file, inside in LSBUS_PLACES.items():
            text = (descriptions / file).read_text()
            for old, new in (edits or {}).items():
                text = text.replace(old, new)
            z.writestr(inside, text)
    return fmu
