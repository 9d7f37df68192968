"""Build the test FMUs from their C sources (tests/fmus/) at test time, into a given folder."""
from __future__ import annotations

import os
import platform
import shutil
import subprocess
import zipfile
from pathlib import Path

import fmpy

SOURCES = Path(__file__).parent / "fmus"


def fmi_platform() -> str:
    """fmpy's platform folder name for binaries (e.g. linux64)."""
    return fmpy.platform


def build_c_fmu(name: str, out_dir: Path) -> Path:
    """Compile tests/fmus/<name>/<name>.c into a shared library and zip the FMU."""
    src = SOURCES / name
    headers = Path(fmpy.__file__).parent / "c-code"
    work = out_dir / f"{name}_build"
    binaries = work / "binaries" / fmi_platform()
    binaries.mkdir(parents=True, exist_ok=True)
    ext = {"Windows": ".dll", "Darwin": ".dylib"}.get(platform.system(), ".so")
    cc = os.environ.get("CC", "cc")
    subprocess.run([cc, "-shared", "-fPIC", "-O2", f"-I{headers}", str(src / f"{name}.c"),
                    "-o", str(binaries / f"{name}{ext}"), "-lm"], check=True)
    shutil.copy(src / "modelDescription.xml", work / "modelDescription.xml")
    fmu = out_dir / f"{name}.fmu"
    with zipfile.ZipFile(fmu, "w") as z:
        for path in work.rglob("*"):
            if path.is_file():
                z.write(path, path.relative_to(work).as_posix())
    return fmu
