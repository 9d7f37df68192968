"""Source-only FMUs: compiled for this platform when loaded, with fmpy's build helper (CMake and
the system C compiler), and cached by the FMU's SHA-256 so each FMU is compiled once.

The cache is `$TWMR_CACHE_DIR/fmus` (default `~/.cache/twmr/fmus`); a compiled FMU is the
original with a `binaries/<platform>/` folder added.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
import zipfile
from pathlib import Path
from typing import Any

from twmr.core.errors import FmuError


def binary_folders(md: Any) -> tuple[str, ...]:
    """Names of the binaries folder for this platform: FMI 2 linux64, FMI 3 x86_64-linux (which
    fmpy's `supported_platforms` also reports as linux64)."""
    import fmpy

    return (fmpy.platform,) if md.fmiVersion == "2.0" else (fmpy.platform_tuple, fmpy.platform)


def has_binary(path: Path, md: Any) -> bool:
    import fmpy

    return bool(set(fmpy.supported_platforms(str(path))) & set(binary_folders(md)))


def _missing_libraries(path: Path, md: Any) -> list[str]:
    """binaries/<platform>/<modelIdentifier><ext> the FMU lacks, for each interface it has."""
    import fmpy

    with zipfile.ZipFile(path) as z:
        names = set(z.namelist())
    ext = fmpy.sharedLibraryExtension
    wanted = {i.modelIdentifier for i in (md.coSimulation, md.modelExchange) if i is not None}
    return sorted(f"binaries/{binary_folders(md)[0]}/{ident}{ext}" for ident in wanted
                  if not any(f"binaries/{folder}/{ident}{ext}" in names
                             for folder in binary_folders(md)))


def cache_dir() -> Path:
    root = os.environ.get("TWMR_CACHE_DIR") or Path.home() / ".cache" / "twmr"
    return Path(root) / "fmus"


def _digest(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def runnable(path: Path, md: Any, instance: str) -> Path:
    """`path` itself when it has a binary for this platform; otherwise the FMU compiled from its
    sources (from the cache when compiled before). FmuError when it can be neither."""
    import fmpy

    if has_binary(path, md):
        missing = _missing_libraries(path, md)
        if missing:
            raise FmuError(instance, None, f"FMU '{path.name}' has a binaries folder for this "
                           f"platform but not the shared library its model description names "
                           f"({', '.join(missing)}). Fix: rebuild the FMU so the library is named "
                           f"after its modelIdentifier.")
        return path
    platforms = ", ".join(fmpy.supported_platforms(str(path))) or "none"
    if not md.buildConfigurations or not md.buildConfigurations[0].sourceFileSets:
        raise FmuError(instance, None, f"FMU '{path.name}' has no binary for this platform "
                       f"({binary_folders(md)[0]}; it has: {platforms}) and no C sources to "
                       f"build one. Fix: get a build of the FMU for {binary_folders(md)[0]}.")
    target = cache_dir() / f"{_digest(path)}.fmu"
    if target.exists():
        return target
    missing = [tool for tool in ("cmake", os.environ.get("CC", "cc")) if not shutil.which(tool)]
    if missing:
        raise FmuError(instance, None, f"FMU '{path.name}' ships C sources only (no binary for "
                       f"{binary_folders(md)[0]}), and compiling them needs {' and '.join(missing)}"
                       f", which this machine lacks. Fix: install a C compiler and CMake, or get "
                       f"a build of the FMU for this platform.")
    with tempfile.TemporaryDirectory(prefix="twmr-fmu-build-") as work:
        unzipped = Path(work) / "fmu"
        with zipfile.ZipFile(path) as z:
            z.extractall(unzipped)
        problem = _build(unzipped, Path(work) / "build")
        if problem:
            raise FmuError(instance, None, f"FMU '{path.name}' ships C sources only and "
                           f"compiling them failed: {problem}. Fix: build the FMU for this "
                           f"platform with its vendor's tool.")
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_suffix(f".{os.getpid()}.part")
        with zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as z:
            for file in sorted(unzipped.rglob("*")):
                if file.is_file():
                    z.write(file, file.relative_to(unzipped).as_posix())
        os.replace(partial, target)
    return target


def _build(unzipped: Path, build: Path) -> str:
    """Compile the sources in `unzipped` into its binaries folder with fmpy's CMake project
    (output captured); the failure's last lines, or '' on success."""
    import fmpy
    from fmpy.build import create_cmake_settings

    build.mkdir()
    try:
        create_cmake_settings(unzipped, build)
    except Exception as exc:  # noqa: BLE001 - fmpy raises plain Exception for bad descriptions
        return f"{type(exc).__name__}: {exc}"
    source = Path(fmpy.__file__).parent / "c-code"
    for command in (["cmake", "-S", str(source), "-B", str(build)],
                    ["cmake", "--build", str(build), "--target", "install", "--config",
                     "Release"]):
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode:
            tail = (done.stdout + done.stderr).strip().splitlines()[-6:]
            return " / ".join(tail) or f"exit status {done.returncode}"
    return ""
